#!/usr/bin/env python3
"""The documentation site of `ferrolink docs`, built from the project's dictionaries and read in
a headless Chromium.

Usage:
    browser.py --ferrolink BIN --workdir DIR [--screenshot FILE] [--dialect-dir DIR]
               [--chromium PATH]

Runs `BIN docs` for MAVLink minimal.xml and usv.xml, the example robot (which brings its module
dictionaries) and the MiniVGT ring into DIR/site, and, with --dialect-dir (a folder holding
pymavlink's common.xml), `BIN docs common.xml` into DIR/site-common. `BIN ir` on the same inputs
gives what the pages must show. Every check prints `ok   NAME`, `FAIL NAME: detail` or
`skip NAME: why`; the last line is `N passed, M failed`; the status is 0 only if nothing failed.

Over the generated files (no browser needed):
  build          docs wrote index.html, dictionary.json, style.css, search.js, search-index.js
                 and one page per dictionary.
  dictionary_json  dictionary.json is the IR that `ferrolink ir` prints.
  links          every href and src of every page resolves: the file exists in the site and the
                 #anchor is an id in it.
  unique_ids     no id occurs twice on a page.
  offline        nothing points off the machine: no http(s) or protocol-relative URL in a src or
                 href, no url(), @import or @font-face in the stylesheet, no URL and no request
                 API (fetch, XMLHttpRequest, ...) in search.js.
  search_index   search-index.js defines FERROLINK_SEARCH_INDEX with one entry per message,
                 field, enum, entry and variable of the IR, and every url in it resolves.
  static_tables  every message's section is in the static HTML (no script needed) with a row per
                 field showing the IR's wire offset and type, and its CRC_EXTRA in decimal equal
                 to the IR's.
With --dialect-dir the same six file checks run on the common.xml site as NAME_common.

In Chromium (launched headless with its DevTools protocol on a local port; skipped when no
Chromium is found):
  index          index.html opens from file:// with its stylesheet applied and the search box
                 shown (the script ran).
  search         typing HEARTBEAT into the search box lists HEARTBEAT first, linking to
                 mavlink-minimal.html#msg-HEARTBEAT.
  search_follow  clicking that result lands on the element with id msg-HEARTBEAT (the :target,
                 in view).
  search_kinds   a field, an enum entry and a ModRob-1 variable are found too.
  no_js          with JavaScript disabled, the HEARTBEAT field table is on the page and laid out,
                 the CRC_EXTRA reads as the IR's, and the search box stays hidden.
  no_network     every request the pages made was for a file:// or data: URL.
  js_errors      no script error or console error on any page.
  screenshot     a PNG of a dialect page (common.xml's when given, else minimal.xml's) written to
                 --screenshot (default DIR/docs-dialect.png), and of the search results next to it
                 (NAME-search.png) and the dialect page in dark mode (NAME-dark.png).
"""

import argparse
import base64
import html.parser
import json
import os
import re
import secrets
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
import urllib.parse

sys.dont_write_bytecode = True

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PROJECT_INPUTS = [
    "definitions/mavlink/minimal.xml",
    "definitions/mavlink/usv.xml",
    "definitions/modrob/robot.toml",
    "definitions/tosnet/minivgt.toml",
]
C_NAMES = {
    "u8": "uint8_t", "i8": "int8_t", "u16": "uint16_t", "i16": "int16_t",
    "u32": "uint32_t", "i32": "int32_t", "u64": "uint64_t", "i64": "int64_t",
    "f32": "float", "f64": "double", "char": "char",
}
VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source",
        "track", "wbr"}

PASSED = 0
FAILED = 0


def ok(name):
    global PASSED
    PASSED += 1
    print(f"ok   {name}", flush=True)


def fail(name, detail):
    global FAILED
    FAILED += 1
    print(f"FAIL {name}: {detail}", flush=True)


def skip(name, why):
    print(f"skip {name}: {why}", flush=True)


def check(name, problems, limit=8):
    """ok when `problems` is empty, else FAIL with the first few."""
    if problems:
        more = f" (and {len(problems) - limit} more)" if len(problems) > limit else ""
        fail(name, "; ".join(problems[:limit]) + more)
    else:
        ok(name)


def c_type(ty):
    s = C_NAMES[ty["primitive"]]
    if ty["mavlink_version"]:
        s += "_mavlink_version"
    if ty["array"] is not None:
        s += f"[{ty['array']}]"
    return s


# ---------------------------------------------------------------------------------------------
# The generated files, read without a browser


class Page(html.parser.HTMLParser):
    """What the checks need of one HTML file: ids, links, and the cells of rows with an id."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.ids = []              # every id, in order
        self.ancestors = {}        # id -> ids of its ancestors, innermost last
        self.urls = []             # (tag, attribute, value)
        self.rows = {}             # id of a <tr> -> texts of its cells
        self.texts = {}            # id -> text of elements whose class names a value we read
        self.classed = []          # (class list, ancestor ids, text)
        self._stack = []           # (tag, id or None)
        self._rows = []            # [id or None, cells] of open <tr>s
        self._cell = None          # text of the open cell of the innermost row
        self._capture = []         # [classes, ancestor ids, text, depth] of open classed elements

    def _ids_open(self):
        return [i for _, i in self._stack if i]

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        for key in ("href", "src"):
            if a.get(key) is not None:
                self.urls.append((tag, key, a[key]))
        ident = a.get("id")
        if ident is not None:
            self.ids.append(ident)
            self.ancestors[ident] = self._ids_open()
        classes = (a.get("class") or "").split()
        if tag in VOID:
            return
        if classes:
            self._capture.append([classes, self._ids_open() + ([ident] if ident else []), "",
                                  len(self._stack)])
        self._stack.append((tag, ident))
        if tag == "tr":
            self._rows.append([ident, []])
        elif tag in ("td", "th") and self._rows:
            self._cell = ""

    def handle_endtag(self, tag):
        if tag in VOID:
            return
        # Close up to the matching tag (tolerates a missing end tag, which the pages avoid).
        while self._stack:
            open_tag, _ = self._stack.pop()
            depth = len(self._stack)
            while self._capture and self._capture[-1][3] >= depth:
                classes, ids, text, _ = self._capture.pop()
                self.classed.append((classes, ids, " ".join(text.split())))
            if open_tag in ("td", "th") and self._rows and self._cell is not None:
                self._rows[-1][1].append(" ".join(self._cell.split()))
                self._cell = None
            if open_tag == "tr" and self._rows:
                ident, cells = self._rows.pop()
                if ident:
                    self.rows[ident] = cells
            if open_tag == tag:
                break

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data
        for c in self._capture:
            c[2] += data


def parse_site(site):
    pages = {}
    for name in sorted(os.listdir(site)):
        if name.endswith(".html"):
            p = Page()
            with open(os.path.join(site, name), encoding="utf-8") as f:
                p.feed(f.read())
            p.close()
            pages[name] = p
    return pages


def search_entries(site):
    """The entries of search-index.js: one `{name:"..",kind:"..",url:"..",text:".."},` a line
    between `window.FERROLINK_SEARCH_INDEX = [` and `];`, each string a JS literal that JSON
    reads too."""
    with open(os.path.join(site, "search-index.js"), encoding="utf-8") as f:
        text = f.read()
    m = re.search(r"^window\.FERROLINK_SEARCH_INDEX = \[\n(.*?)^\];", text, re.S | re.M)
    if not m:
        raise ValueError("no `window.FERROLINK_SEARCH_INDEX = [` ... `];` in search-index.js")
    string = r'"(?:[^"\\\n]|\\.)*"'
    item = re.compile(rf"\{{name:({string}),kind:({string}),url:({string}),text:({string})\}},")
    entries = []
    # Split on newlines only: texts may hold other Unicode line separators, which JS allows.
    for n, line in enumerate(m.group(1).split("\n"), 1):
        if line == "":
            continue
        hit = item.fullmatch(line)
        if not hit:
            raise ValueError(f"search-index.js: entry {n} is not an index entry: {line[:100]!r}")
        values = [json.loads(g, strict=False) for g in hit.groups()]
        entries.append(dict(zip(("name", "kind", "url", "text"), values)))
    return entries


def resolve(site, pages, page, url, cache):
    """None when `url` (found on `page`) resolves inside the site, else why not."""
    parsed = urllib.parse.urlsplit(url)
    if parsed.scheme or parsed.netloc:
        return f"{page}: {url} leaves the site"
    path = urllib.parse.unquote(parsed.path)
    target = page if path == "" else os.path.normpath(os.path.join(os.path.dirname(page), path))
    if target.startswith(".."):
        return f"{page}: {url} points outside the site"
    full = os.path.join(site, target)
    if not os.path.isfile(full):
        return f"{page}: {url}: no file {target}"
    if parsed.fragment:
        frag = urllib.parse.unquote(parsed.fragment)
        if target not in pages:
            if target not in cache:
                p = Page()
                with open(full, encoding="utf-8", errors="replace") as f:
                    p.feed(f.read())
                cache[target] = p
            ids = cache[target].ids
        else:
            ids = pages[target].ids
        if frag not in ids:
            return f"{page}: {url}: no id {frag!r} in {target}"
    return None


def expected_pages(ir):
    files = ["index.html"]
    files += [f"mavlink-{m['name']['wire']}.html" for m in ir["modules"]]
    files += [f"modrob-{m['name']['wire']}.html" for m in ir["modrob"]]
    files += [f"robot-{r['name']['wire']}.html" for r in ir["robots"]]
    files += [f"tosnet-{r['name']['wire']}.html" for r in ir["rings"]]
    return files


def file_checks(suffix, site, ir):
    """The checks over the generated files of one site. Returns the parsed pages (or None)."""
    name = lambda n: n + suffix  # noqa: E731
    missing = [f for f in ["dictionary.json", "style.css", "search.js", "search-index.js"]
               + expected_pages(ir) if not os.path.isfile(os.path.join(site, f))]
    check(name("build"), [f"missing {f}" for f in missing])
    if "index.html" in missing:
        for n in ("dictionary_json", "links", "unique_ids", "offline", "search_index",
                  "static_tables"):
            skip(name(n), "the site was not built")
        return None

    try:
        with open(os.path.join(site, "dictionary.json"), encoding="utf-8") as f:
            dumped = json.load(f)
        check(name("dictionary_json"), [] if dumped == ir else
              ["dictionary.json differs from `ferrolink ir`"])
    except (OSError, ValueError) as e:
        fail(name("dictionary_json"), str(e))

    pages = parse_site(site)
    cache = {}
    problems = []
    for page, p in pages.items():
        for tag, key, url in p.urls:
            why = resolve(site, pages, page, url, cache)
            if why:
                problems.append(f"<{tag} {key}>: {why}")
    n_urls = sum(len(p.urls) for p in pages.values())
    check(name("links"), problems or ([] if n_urls else ["no links at all"]))

    problems = []
    for page, p in pages.items():
        seen = set()
        for i in p.ids:
            if i in seen:
                problems.append(f"{page}: id {i!r} twice")
            seen.add(i)
    check(name("unique_ids"), problems)

    problems = []
    external = re.compile(r"^\s*(?:[a-z][a-z0-9+.-]*:|//)", re.I)
    for page, p in pages.items():
        for tag, key, url in p.urls:
            if external.match(url) and not url.lower().startswith("data:"):
                problems.append(f"{page}: <{tag} {key}={url!r}>")
    with open(os.path.join(site, "style.css"), encoding="utf-8") as f:
        css = f.read()
    for pattern in (r"url\s*\(", r"@import", r"@font-face"):
        if re.search(pattern, css, re.I):
            problems.append(f"style.css has {pattern.replace(chr(92), '')}")
    # The search script must not load anything (search-index.js is data: its texts may quote
    # URLs from the dictionaries' descriptions, which are never requested).
    with open(os.path.join(site, "search.js"), encoding="utf-8") as f:
        text = f.read()
    code = re.sub(r"//[^\n]*|/\*.*?\*/", "", text, flags=re.S)
    for hit in re.findall(r"(?:https?|wss?)://[^\s\"')]+", text):
        problems.append(f"search.js names {hit}")
    for api in re.findall(r"\bfetch\s*\(|XMLHttpRequest|WebSocket|importScripts|sendBeacon|"
                          r"EventSource|createElement\(\s*[\"'](?:script|link|img|iframe)", code):
        problems.append(f"search.js calls {api.strip('(')}")
    check(name("offline"), problems)

    try:
        entries = search_entries(site)
        problems = []
        kinds = {}
        for e in entries:
            if set(e) != {"name", "kind", "url", "text"}:
                problems.append(f"entry {e!r} lacks a key")
                continue
            kinds.setdefault(e["kind"], set()).add(e["name"])
            why = resolve(site, pages, "index.html", e["url"], cache)
            if why:
                problems.append(f"{e['kind']} {e['name']}: {why}")
        want = {
            "message": {m["name"]["wire"] for mod in ir["modules"] for m in mod["messages"]},
            "field": {f"{m['name']['wire']}.{f['name']['wire']}"
                      for mod in ir["modules"] for m in mod["messages"] for f in m["fields"]},
            "enum": {e["name"]["wire"] for e in ir["enums"]},
            "entry": {n["name"]["wire"] for e in ir["enums"] for n in e["entries"]},
            "variable": {f"{m['name']['wire']}.{v['name']['wire']}"
                         for m in ir["modrob"] for v in m["variables"]},
        }
        have = dict(kinds)
        have["enum"] = kinds.get("enum", set()) | kinds.get("bitmask", set())
        for kind, names in want.items():
            lost = sorted(names - have.get(kind, set()))
            if lost:
                problems.append(f"no {kind} entry for {', '.join(lost[:5])}"
                                + (" ..." if len(lost) > 5 else ""))
        check(name("search_index"), problems)
    except (OSError, ValueError) as e:
        fail(name("search_index"), str(e))

    problems = []
    crc = {}
    for p in pages.values():
        for classes, ids, text in p.classed:
            if "crc-extra" in classes:
                owner = next((i for i in reversed(ids) if i.startswith("msg-")), None)
                if owner:
                    crc[owner] = text
    n_msgs = 0
    for mod in ir["modules"]:
        file = f"mavlink-{mod['name']['wire']}.html"
        p = pages.get(file)
        if p is None:
            problems.append(f"no {file}")
            continue
        for msg in mod["messages"]:
            n_msgs += 1
            mid = f"msg-{msg['name']['wire']}"
            if mid not in p.ids:
                problems.append(f"{file}: no #{mid}")
                continue
            if crc.get(mid) != str(msg["crc_extra"]):
                problems.append(f"{mid}: CRC_EXTRA shown as {crc.get(mid)!r}, "
                                f"the IR has {msg['crc_extra']}")
            for f in msg["fields"]:
                rid = f"field-{msg['name']['wire']}-{f['name']['wire']}"
                cells = p.rows.get(rid)
                if cells is None or mid not in p.ancestors.get(rid, []):
                    problems.append(f"{file}: no row #{rid} in #{mid}")
                    continue
                if len(cells) < 4 or cells[0] != str(f["offset"]) or cells[3] != c_type(f["ty"]):
                    problems.append(f"{rid}: cells {cells[:4]}, the IR has offset "
                                    f"{f['offset']} and type {c_type(f['ty'])}")
    check(name("static_tables"), problems or ([] if n_msgs or not ir["modules"] else []))
    return pages


# ---------------------------------------------------------------------------------------------
# Chromium over the DevTools protocol, with a minimal WebSocket client


class WebSocket:
    """Just enough of RFC 6455 for the DevTools protocol: text frames, client-side masking."""

    def __init__(self, host, port, path, timeout=30):
        self.sock = socket.create_connection((host, port), timeout=timeout)
        key = base64.b64encode(secrets.token_bytes(16)).decode()
        self.sock.sendall((f"GET {path} HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                           "Sec-WebSocket-Version: 13\r\n\r\n").encode())
        head = b""
        while b"\r\n\r\n" not in head:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise ConnectionError("the DevTools socket closed during the handshake")
            head += chunk
        head, self.buf = head.split(b"\r\n\r\n", 1)
        status = head.split(b"\r\n", 1)[0]
        if b" 101 " not in status + b" ":
            raise ConnectionError(f"DevTools refused the WebSocket: {status.decode(errors='replace')}")

    def _exact(self, n):
        while len(self.buf) < n:
            chunk = self.sock.recv(max(65536, n - len(self.buf)))
            if not chunk:
                raise ConnectionError("the DevTools socket closed")
            self.buf += chunk
        out, self.buf = self.buf[:n], self.buf[n:]
        return out

    def _frame(self, opcode, payload):
        head = bytes([0x80 | opcode])
        n = len(payload)
        if n < 126:
            head += bytes([0x80 | n])
        elif n < 1 << 16:
            head += bytes([0x80 | 126]) + struct.pack(">H", n)
        else:
            head += bytes([0x80 | 127]) + struct.pack(">Q", n)
        mask = secrets.token_bytes(4)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        self.sock.sendall(head + mask + masked)

    def send(self, text):
        self._frame(0x1, text.encode())

    def recv(self, timeout):
        self.sock.settimeout(timeout)
        parts = []
        while True:
            b0, b1 = self._exact(2)
            opcode, n = b0 & 0x0F, b1 & 0x7F
            if n == 126:
                n = struct.unpack(">H", self._exact(2))[0]
            elif n == 127:
                n = struct.unpack(">Q", self._exact(8))[0]
            mask = self._exact(4) if b1 & 0x80 else None
            payload = self._exact(n)
            if mask:
                payload = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
            if opcode == 0x8:
                raise ConnectionError("DevTools closed the WebSocket")
            if opcode == 0x9:
                self._frame(0xA, payload)
                continue
            if opcode in (0x0, 0x1, 0x2):
                parts.append(payload)
                if b0 & 0x80:
                    return b"".join(parts).decode()

    def close(self):
        try:
            self._frame(0x8, b"")
        except OSError:
            pass
        self.sock.close()


class Browser:
    """A headless Chromium of our own, spoken to over one DevTools WebSocket."""

    def __init__(self, binary, workdir):
        self.profile = tempfile.mkdtemp(prefix="chromium-profile-", dir=workdir)
        self.log = open(os.path.join(workdir, "chromium.log"), "wb")
        self.proc = subprocess.Popen(
            [binary, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
             "--no-first-run", "--no-default-browser-check", "--disable-background-networking",
             "--disable-component-update", "--disable-sync", "--disable-extensions",
             "--disable-default-apps", "--hide-scrollbars", "--mute-audio",
             f"--user-data-dir={self.profile}", "--remote-debugging-port=0",
             "--window-size=1400,1000", "about:blank"],
            stdin=subprocess.DEVNULL, stdout=self.log, stderr=self.log, start_new_session=True)
        port_file = os.path.join(self.profile, "DevToolsActivePort")
        deadline = time.monotonic() + 30
        lines = []
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"chromium exited with {self.proc.returncode} "
                                   f"(see {self.log.name})")
            try:
                with open(port_file) as f:
                    lines = f.read().split()
                if len(lines) >= 2:
                    break
            except OSError:
                pass
            time.sleep(0.1)
        else:
            raise RuntimeError("chromium did not open its DevTools port within 30 s")
        self.ws = WebSocket("127.0.0.1", int(lines[0]), lines[1])
        self.next_id = 0
        self.events = []

    def call(self, method, params=None, session=None, timeout=30):
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        self.ws.send(json.dumps(msg))
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"{method}: no answer within {timeout} s")
            reply = json.loads(self.ws.recv(left))
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error'].get('message')}")
                return reply.get("result", {})
            if "method" in reply:
                self.events.append(reply)

    def pump(self, seconds):
        """Collects events for a while."""
        deadline = time.monotonic() + seconds
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return
            try:
                self.events.append(json.loads(self.ws.recv(left)))
            except (socket.timeout, TimeoutError):
                return

    def wait_event(self, method, session, timeout=30, since=0):
        deadline = time.monotonic() + timeout
        while True:
            for e in self.events[since:]:
                if e.get("method") == method and e.get("sessionId") == session:
                    return e
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no {method} within {timeout} s")
            try:
                self.events.append(json.loads(self.ws.recv(left)))
            except (socket.timeout, TimeoutError):
                pass

    def tab(self, javascript=True):
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.call("Target.attachToTarget",
                            {"targetId": target, "flatten": True})["sessionId"]
        tab = Tab(self, session)
        for domain in ("Page", "Runtime", "Network", "Log", "DOM"):
            self.call(f"{domain}.enable", session=session)
        self.call("Emulation.setDeviceMetricsOverride",
                  {"width": 1400, "height": 1000, "deviceScaleFactor": 1, "mobile": False},
                  session=session)
        if not javascript:
            self.call("Emulation.setScriptExecutionDisabled", {"value": True}, session=session)
        return tab

    def requests(self):
        return [e["params"]["request"]["url"] for e in self.events
                if e.get("method") == "Network.requestWillBeSent"]

    def errors(self):
        out = []
        for e in self.events:
            if e.get("method") == "Runtime.exceptionThrown":
                d = e["params"]["exceptionDetails"]
                out.append(d.get("exception", {}).get("description") or d.get("text"))
            elif e.get("method") == "Log.entryAdded" and e["params"]["entry"]["level"] == "error":
                entry = e["params"]["entry"]
                out.append(f"{entry.get('text')} ({entry.get('url', '')})")
            elif (e.get("method") == "Runtime.consoleAPICalled"
                  and e["params"]["type"] in ("error", "assert")):
                out.append(" ".join(str(a.get("value", a.get("description")))
                                    for a in e["params"]["args"]))
        return out

    def close(self):
        try:
            self.call("Browser.close", timeout=5)
        except Exception:  # noqa: BLE001 - closing anyway
            pass
        try:
            self.ws.close()
        except Exception:  # noqa: BLE001
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            pass
        # The Debian wrapper script does not exec; end the whole group we started.
        try:
            os.killpg(self.proc.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
        self.log.close()
        shutil.rmtree(self.profile, ignore_errors=True)


class Tab:
    def __init__(self, browser, session):
        self.b = browser
        self.session = session

    def call(self, method, params=None, timeout=30):
        return self.b.call(method, params, session=self.session, timeout=timeout)

    def goto(self, url, timeout=60):
        since = len(self.b.events)
        result = self.call("Page.navigate", {"url": url}, timeout=timeout)
        if result.get("errorText"):
            raise RuntimeError(f"cannot open {url}: {result['errorText']}")
        if result.get("loaderId"):  # none for a same-document (#anchor) navigation
            self.b.wait_event("Page.loadEventFired", self.session, timeout, since)

    def js(self, expression, timeout=30):
        r = self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                           "awaitPromise": True}, timeout=timeout)
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression[:60]}...: "
                               f"{r['exceptionDetails'].get('exception', {}).get('description')}")
        return r["result"].get("value")

    def wait_js(self, expression, timeout=15):
        """Polls `expression` until it is truthy; returns its value."""
        deadline = time.monotonic() + timeout
        while True:
            value = self.js(expression)
            if value:
                return value
            if time.monotonic() > deadline:
                raise TimeoutError(f"waited {timeout} s for {expression[:80]}")
            self.b.pump(0.1)

    def screenshot(self, path, full_page=False):
        params = {"format": "png"}
        if full_page:
            params["captureBeyondViewport"] = True
        data = base64.b64decode(self.call("Page.captureScreenshot", params, timeout=60)["data"])
        with open(path, "wb") as f:
            f.write(data)
        return data

    def query_all(self, selector):
        root = self.call("DOM.getDocument", {"depth": 0})["root"]["nodeId"]
        return self.call("DOM.querySelectorAll", {"nodeId": root, "selector": selector})["nodeIds"]

    def text_of(self, node):
        outer = self.call("DOM.getOuterHTML", {"nodeId": node})["outerHTML"]
        return " ".join(re.sub(r"<[^>]+>", "", outer).split())


def type_query(tab, text):
    """Clears the search box, types `text` as a user would, returns the result links."""
    tab.js("(() => { const i = document.getElementById('search'); i.value = '';"
           " i.dispatchEvent(new Event('input')); i.focus(); return true; })()")
    tab.call("Input.insertText", {"text": text})
    return tab.wait_js(
        "(() => { const l = document.getElementById('search-results');"
        " if (!l || l.hidden) return null;"
        " const a = [...l.querySelectorAll('a')];"
        " return a.length ? a.map(x => ({href: x.getAttribute('href'),"
        " name: x.querySelector('.r-name').textContent,"
        " kind: x.querySelector('.r-kind').textContent})) : null; })()")


def browser_checks(binary, args, site, ir, common_site, common_ir):
    names = ["index", "search", "search_follow", "search_kinds", "no_js", "no_network",
             "js_errors", "screenshot"]
    if not binary:
        for n in names:
            skip(n, "no Chromium found (give --chromium PATH, or install chromium)")
        return
    try:
        b = Browser(binary, args.workdir)
    except Exception as e:  # noqa: BLE001 - any start failure skips the browser checks
        for n in names:
            skip(n, f"Chromium did not start: {e}")
        return
    index_url = "file://" + urllib.parse.quote(os.path.join(site, "index.html"))
    shot = args.screenshot or os.path.join(args.workdir, "docs-dialect.png")
    stem, ext = os.path.splitext(shot)
    search_shot, dark_shot = f"{stem}-search{ext or '.png'}", f"{stem}-dark{ext or '.png'}"
    heartbeat = next((m for mod in ir["modules"] for m in mod["messages"]
                      if m["name"]["wire"] == "HEARTBEAT"), None)
    hb_page = next((f"mavlink-{mod['name']['wire']}.html" for mod in ir["modules"]
                    if any(m["name"]["wire"] == "HEARTBEAT" for m in mod["messages"])), None)
    try:
        tab = b.tab()
        try:
            tab.goto(index_url)
            state = tab.js("(() => ({title: document.title,"
                           " sticky: getComputedStyle(document.querySelector('header.top')).position,"
                           " form: !document.querySelector('form.search').hidden,"
                           " entries: (window.FERROLINK_SEARCH_INDEX || []).length}))()")
            problems = []
            if not state["title"]:
                problems.append("no title")
            if state["sticky"] != "sticky":
                problems.append("style.css not applied")
            if not state["form"]:
                problems.append("the search box is still hidden")
            if not state["entries"]:
                problems.append("FERROLINK_SEARCH_INDEX is empty")
            check("index", problems)
        except Exception as e:  # noqa: BLE001
            fail("index", str(e))

        followed = False
        try:
            results = type_query(tab, "HEARTBEAT")
            tab.b.pump(0.3)
            tab.screenshot(search_shot)
            want = f"{hb_page}#msg-HEARTBEAT"
            first = results[0]
            if first["href"] != want or first["name"] != "HEARTBEAT":
                fail("search", f"first result is {first['name']} -> {first['href']}, "
                               f"not HEARTBEAT -> {want} ({len(results)} results)")
            else:
                ok("search")
                rect = tab.js("(() => { const r = document.querySelector('#search-results a')"
                              ".getBoundingClientRect(); return [r.x + r.width / 2,"
                              " r.y + r.height / 2]; })()")
                for kind in ("mousePressed", "mouseReleased"):
                    tab.call("Input.dispatchMouseEvent", {"type": kind, "x": rect[0],
                                                          "y": rect[1], "button": "left",
                                                          "clickCount": 1})
                landed = tab.wait_js(
                    "(() => { if (document.readyState !== 'complete') return null;"
                    " if (!location.href.endsWith('/" + want + "')) return null;"
                    " const t = document.getElementById('msg-HEARTBEAT');"
                    " const q = document.querySelector(':target');"
                    " return {found: !!t, target: q && q.id, top: t ? t.getBoundingClientRect().top : null,"
                    " height: innerHeight, url: location.href}; })()")
                tab.b.pump(0.3)
                problems = []
                if not landed["found"]:
                    problems.append("no element with id msg-HEARTBEAT")
                if landed["target"] != "msg-HEARTBEAT":
                    problems.append(f":target is {landed['target']!r}")
                if landed["top"] is None or not 0 <= landed["top"] < landed["height"] / 2:
                    problems.append(f"the section is at y={landed['top']}, not in view")
                check("search_follow", problems)
                followed = True
        except Exception as e:  # noqa: BLE001
            fail("search", str(e))
        if not followed:
            skip("search_follow", "the search did not work")

        try:
            problems = []
            queries = []
            for mod in ir["modules"]:
                for m in mod["messages"]:
                    if m["fields"] and len(queries) < 1:
                        f = m["fields"][-1]
                        queries.append((f"{m['name']['wire']}.{f['name']['wire']}", "field",
                                        f"#field-{m['name']['wire']}-{f['name']['wire']}"))
            entry = next((e for e in ir["enums"] if e["entries"]), None)
            if entry:
                n = entry["entries"][-1]["name"]["wire"]
                queries.append((n, "entry", f"#{n}"))
            var = next(((m, v) for m in ir["modrob"] for v in m["variables"]), None)
            if var:
                queries.append((f"{var[0]['name']['wire']}.{var[1]['name']['wire']}", "variable",
                                f"#var-{var[1]['name']['wire']}"))
            for query, kind, anchor in queries:
                results = type_query(tab, query)
                if not any(r["kind"] == kind and r["name"] == query and r["href"].endswith(anchor)
                           for r in results[:3]):
                    problems.append(f"{query!r}: no {kind} result linking to ...{anchor} among "
                                    f"{[r['name'] for r in results[:3]]}")
            check("search_kinds", problems if queries else ["nothing to search for"])
        except Exception as e:  # noqa: BLE001
            fail("search_kinds", str(e))

        # The dialect page, for the eye.
        try:
            if common_site and common_ir and common_ir["modules"]:
                mod = next((m for m in common_ir["modules"] if m["name"]["wire"] == "common"),
                           common_ir["modules"][-1])
                page_dir = common_site
            else:
                mod = next((m for m in ir["modules"] if m["messages"]), None)
                page_dir = site
            if mod is None:
                raise RuntimeError("no MAVLink module to show")
            # A message with an enum and an extension field shows the most; else the first.
            msgs = sorted(mod["messages"], key=lambda m: m["id"])
            pick = next((m for m in msgs if any(f["extension"] for f in m["fields"])
                         and any(f["enum_name"] for f in m["fields"])), msgs[0] if msgs else None)
            url = "file://" + urllib.parse.quote(
                os.path.join(page_dir, f"mavlink-{mod['name']['wire']}.html"))
            if pick:
                url += f"#msg-{pick['name']['wire']}"
            tab.goto(url, timeout=120)
            tab.b.pump(0.5)
            data = tab.screenshot(shot)
            tab.call("Emulation.setEmulatedMedia",
                     {"features": [{"name": "prefers-color-scheme", "value": "dark"}]})
            tab.b.pump(0.3)
            tab.screenshot(dark_shot)
            tab.call("Emulation.setEmulatedMedia", {"features": []})
            problems = []
            if not data.startswith(b"\x89PNG\r\n\x1a\n"):
                problems.append("not a PNG")
            for p in (shot, search_shot, dark_shot):
                if not os.path.isfile(p) or os.path.getsize(p) < 1000:
                    problems.append(f"{p} missing or empty")
            if problems:
                fail("screenshot", "; ".join(problems))
            else:
                ok("screenshot")
                print(f"     screenshots: {shot}, {search_shot}, {dark_shot}")
        except Exception as e:  # noqa: BLE001
            fail("screenshot", str(e))

        try:
            if heartbeat is None:
                raise RuntimeError("the project's dictionaries have no HEARTBEAT")
            plain = b.tab(javascript=False)
            plain.goto("file://" + urllib.parse.quote(os.path.join(site, hb_page)))
            rows = plain.query_all("#msg-HEARTBEAT table.fields tbody tr[id^='field-HEARTBEAT-']")
            problems = []
            if len(rows) != len(heartbeat["fields"]):
                problems.append(f"{len(rows)} field rows, the IR has {len(heartbeat['fields'])}")
            tables = plain.query_all("#msg-HEARTBEAT table.fields")
            if tables:
                box = plain.call("DOM.getBoxModel", {"nodeId": tables[0]})["model"]
                if box["width"] <= 0 or box["height"] <= 0:
                    problems.append("the field table is not laid out")
            else:
                problems.append("no field table")
            crc_nodes = plain.query_all("#msg-HEARTBEAT .crc-extra")
            shown = plain.text_of(crc_nodes[0]) if crc_nodes else None
            if shown != str(heartbeat["crc_extra"]):
                problems.append(f"CRC_EXTRA reads {shown!r}, the IR has {heartbeat['crc_extra']}")
            if not plain.query_all("form.search[hidden]"):
                problems.append("the search form is not hidden (did a script run?)")
            check("no_js", problems)
        except Exception as e:  # noqa: BLE001
            fail("no_js", str(e))

        b.pump(0.5)
        urls = b.requests()
        off = [u for u in urls if urllib.parse.urlsplit(u).scheme not in ("file", "data", "about")]
        if off:
            fail("no_network", f"{len(off)} requests left the machine: {off[:5]}")
        elif not any(u.startswith("file:") for u in urls):
            fail("no_network", "no requests seen at all; the check saw nothing")
        else:
            ok("no_network")
        check("js_errors", b.errors())
    finally:
        b.close()


# ---------------------------------------------------------------------------------------------


def find_chromium(given):
    if given:
        return given if os.path.exists(given) else None
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


def run(cmd, what):
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    if p.returncode != 0:
        raise RuntimeError(f"{what} failed with {p.returncode}: {p.stderr.strip()[-800:]}")
    return p.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ferrolink", required=True, help="the ferrolink binary")
    ap.add_argument("--workdir", required=True, help="scratch folder for the sites")
    ap.add_argument("--screenshot", help="PNG of a dialect page (default WORKDIR/docs-dialect.png)")
    ap.add_argument("--dialect-dir", help="folder with pymavlink's common.xml")
    ap.add_argument("--chromium", help="the Chromium binary (default: found on PATH)")
    args = ap.parse_args()
    args.workdir = os.path.abspath(args.workdir)
    args.ferrolink = os.path.abspath(args.ferrolink) if os.sep in args.ferrolink else args.ferrolink
    if args.screenshot:
        args.screenshot = os.path.abspath(args.screenshot)
    os.makedirs(args.workdir, exist_ok=True)

    site = os.path.join(args.workdir, "site")
    shutil.rmtree(site, ignore_errors=True)
    inputs = [os.path.join(ROOT, p) for p in PROJECT_INPUTS]
    ir = None
    try:
        ir = json.loads(run([args.ferrolink, "ir", *inputs], "ferrolink ir"))
        run([args.ferrolink, "docs", *inputs, "--out", site], "ferrolink docs")
    except (RuntimeError, ValueError, OSError) as e:
        fail("build", str(e))
    if ir is not None and os.path.isdir(site):
        file_checks("", site, ir)

    common_site = common_ir = None
    if args.dialect_dir:
        common = os.path.join(os.path.abspath(args.dialect_dir), "common.xml")
        common_site = os.path.join(args.workdir, "site-common")
        shutil.rmtree(common_site, ignore_errors=True)
        try:
            common_ir = json.loads(run([args.ferrolink, "ir", common], "ferrolink ir common.xml"))
            run([args.ferrolink, "docs", common, "--out", common_site], "ferrolink docs common.xml")
            file_checks("_common", common_site, common_ir)
        except (RuntimeError, ValueError, OSError) as e:
            fail("build_common", str(e))
            common_site = common_ir = None
    else:
        skip("build_common", "no --dialect-dir")

    if ir is not None and os.path.isfile(os.path.join(site, "index.html")):
        browser_checks(find_chromium(args.chromium), args, site, ir, common_site, common_ir)
    else:
        skip("browser", "the site was not built")

    print(f"{PASSED} passed, {FAILED} failed")
    return 0 if FAILED == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
