#!/usr/bin/env python3
"""Check the NDLCom, ModRob-1 and TosNet dissectors that `ferrolink wireshark` generates.

Usage:
    others.py --ferrolink BIN --workdir DIR [--captures DIR] [--only NAME]

The script renders the dissectors for our own definitions (`BIN wireshark ... --out
DIR/all.lua`), writes pcap files itself (libpcap headers by hand; UDP over IPv4 over Ethernet,
and the USER0 / USER1 link types for serial byte streams) with frames made by our own encoders
(`BIN ndlcom encode`, `BIN modrob encode`; TosNet frames, for which there is no encoder command,
are built here after the frame format) and by the real MAVLink captures in ../shared/captures
(their payloads become NDLCom payloads), mixed with garbage, bad checksums, broken escapes and
truncation. It runs `tshark -X lua_script:FILE -r PCAP -T json` with an empty configuration
directory and compares the decoded field values with what our own decoders say about the same
bytes (`BIN ndlcom decode` / `ndlcom export`, `BIN modrob decode`), or with the values the frames
were built from.

Every tshark run must be free of Lua errors, of the dissectors' own "Dissector error" expert
info and of malformed-packet exceptions. The Lua is also compiled with luac5.2 and luac5.4 and
run under lua5.2 and lua5.4 against a small stand-in for Wireshark's Lua API, so the code paths
Wireshark's Lua 5.4 builds take are exercised too.

  lua_syntax                  luac5.2 -p and luac5.4 -p accept the file for our definitions, for
                              each kind of input alone, and for the generator's test fixtures.
  lua_runtimes                The three dissectors run outside Wireshark on a stand-in for its
                              Lua API under Lua 5.2 (bit32), 5.2 without bit32 (arithmetic) and
                              5.4 (the operator): frames, mutated frames and random bytes, every
                              intact frame shown with a good checksum, no error.
  ndlcom_user0                A serial capture (USER0): frames of every message of our
                              dictionaries, several per packet, garbage, a bad FCS, an invalid
                              escape, a missing flag between frames, a cut frame, escaped header
                              and payload bytes, zero-filled and overlong payloads, unknown ids.
                              Frames, FCS statuses and every payload field as our decoders say.
  ndlcom_udp                  The same bytes in UDP datagrams on the bridge's ports 34000/34001.
  ndlcom_decode_as_and_prefs  Port 5555 decoded only through "Decode As" or the ports preference;
                              moving the preference releases port 34000.
  ndlcom_real_captures        MAVLink payloads from the real captures (CRC checked, MAVLink 2
                              ones trimmed) as NDLCom payloads, decoded like `ndlcom export`.
  modrob_ethernet             Ethernet-1 packets from `modrob encode` on the example robot's
                              ports: every message of every batch with its instance, variable,
                              value, command and source names; ULID, UUID and sender; a bad CRC
                              inside a packet, a cut packet, trailing bytes, limits, unknown MIs.
  modrob_uart_user1           UART.B-1 streams (USER1) with noise, false starts, a bad CRC, a
                              reserved command with a good CRC and an unfinished message,
                              compared with `modrob decode --transport uart`.
  modrob_ports_and_heuristic  Default port, "Decode As", the ports preference, the UDP heuristic
                              (and random bytes it must leave alone).
  modrob_without_robot        Module dictionaries alone: names from their own MIs, no instances.
  tosnet                      Every command; DATA before setup (map order), after NET_SET and
                              REG_SET (ring order 0 2 1 3), with a bad CRC, marked broken
                              upstream, fitting no map; malformed frames; "Decode As" and prefs.
  generator_fixtures          the dictionary crate's fixtures: every field type, arrays, text (some of it not
                              UTF-8), keyword names, gaps, several maps and dictionaries at once.
  no_lua_errors               Mutated and random packets for every protocol and link, one and
                              two passes.

One line is printed per check: `ok   NAME`, `FAIL NAME: detail` or `skip NAME: why` (tshark,
luac or lua missing), then `N passed, M failed`. The exit status is 0 when nothing failed.
"""

import argparse
import glob
import json
import math
import os
import random
import shutil
import struct
import subprocess
import sys
import tempfile

sys.dont_write_bytecode = True  # keep the source tree clean

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MAVLINK_DEFS = sorted(glob.glob(os.path.join(ROOT, "definitions", "mavlink", "*.xml")))
ROBOT = os.path.join(ROOT, "definitions", "modrob", "robot.toml")
RING = os.path.join(ROOT, "definitions", "tosnet", "minivgt.toml")

LINKTYPE_ETHERNET = 1
LINKTYPE_USER0 = 147  # NDLCom serial byte streams
LINKTYPE_USER1 = 148  # ModRob-1 UART.B-1 byte streams

NDLCOM_PORT_IN, NDLCOM_PORT_OUT = 34000, 34001  # a bridge's udp:// interface defaults
MODROB_PORT = 47000  # the example robot's first module
TOSNET_PORT = 35100  # node i of the MiniVGT example listens on 35100 + i
OTHER_PORT = 5555  # no dissector's default: for "Decode As"


class CheckFailed(Exception):
    pass


class Skip(Exception):
    pass


def require(cond, detail):
    if not cond:
        raise CheckFailed(detail)


# --- running things ------------------------------------------------------------------------------


class Env:
    def __init__(self, ferrolink, workdir, captures):
        self.bin = ferrolink
        self.workdir = workdir
        self.captures = captures
        self.config = tempfile.mkdtemp(prefix="empty-config-", dir=workdir)
        self.tshark = shutil.which("tshark")
        self._ir = {}

    def run(self, args, stdin="", ok_codes=(0,)):
        p = subprocess.run([self.bin, *args], input=stdin, capture_output=True, text=True, timeout=300)
        if p.returncode not in ok_codes:
            raise CheckFailed(f"`ferrolink {' '.join(args[:2])}` exited {p.returncode}: {p.stderr.strip()[:500]}")
        return p.stdout

    def ir(self, *inputs):
        if inputs not in self._ir:
            self._ir[inputs] = json.loads(self.run(["ir", *inputs]))
        return self._ir[inputs]

    def render(self, name, *inputs):
        out = os.path.join(self.workdir, name)
        if not os.path.exists(out):
            self.run(["wireshark", *inputs, "--out", out])
        return out

    def path(self, name):
        return os.path.join(self.workdir, name)

    def tshark_json(self, lua, pcap, *extra):
        """Runs tshark and returns the packets' layers, each an Obj; fails on any Lua error."""
        if not self.tshark:
            raise Skip("tshark is not installed")
        env = dict(os.environ, HOME=self.config, XDG_CONFIG_HOME=self.config)
        cmd = [self.tshark, "-n", "-X", f"lua_script:{lua}", "-r", pcap, "-T", "json", *extra]
        p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
        if p.returncode != 0:
            raise CheckFailed(f"tshark exited {p.returncode}: {p.stderr.strip()[:800]}")
        for stream in (p.stdout, p.stderr):
            for needle in ("Lua Error", "LUA ERROR", "Lua: Error", "lua_error"):
                if needle in stream:
                    line = next(l for l in stream.splitlines() if needle in l)
                    raise CheckFailed(f"tshark reported a Lua error: {line.strip()[:400]}")
        packets = json.loads(p.stdout or "[]", object_pairs_hook=Obj)
        layers = [pkt.get("_source").get("layers") for pkt in packets]
        for n, layer in enumerate(layers, 1):
            for key, value in leaves(layer):
                if key == "_ws.malformed.expert" or (key == "_ws.expert.message" and value and "Exception occurred" in value):
                    raise CheckFailed(f"packet {n}: malformed-packet exception")
                if key == "_ws.expert.message" and value and value.startswith("Dissector error"):
                    raise CheckFailed(f"packet {n}: {value[:300]}")
                if key == "_ws.lua.error" or (key == "_ws.expert.message" and value and "Lua Error" in value):
                    raise CheckFailed(f"packet {n}: Lua error {value}")
        return layers


class Obj(list):
    """A JSON object as its (key, value) pairs, duplicate keys and order kept (tshark repeats
    keys for repeated fields and for several protocol trees in one packet)."""

    def get(self, key, default=None):
        for k, v in self:
            if k == key:
                return v
        return default

    def all(self, key):
        return [v for k, v in self if k == key]


def leaves(obj):
    """(key, value) for every item below `obj` in tree order; a subtree gives (key, None) first."""
    for k, v in obj:
        if isinstance(v, Obj):
            yield k, None
            yield from leaves(v)
        else:
            yield k, v


def values(obj, key):
    return [v for k, v in leaves(obj) if k == key]


def first(obj, key, default=None):
    for k, v in leaves(obj):
        if k == key:
            return v
    return default


def experts(obj):
    """The abbreviations of the expert infos below `obj`."""
    out = []
    for k, v in obj:
        if isinstance(v, Obj):
            if k == "_ws.expert":
                out.extend(kk for kk, _ in v if not kk.startswith("_ws."))
            else:
                out.extend(experts(v))
    return out


def num(text):
    return int(text, 0)


def same_float(text, expected, bits=32):
    """tshark writes floats with 6 significant digits (doubles with 15): equal to that precision."""
    got = float(text)
    if math.isnan(expected) or math.isnan(got):
        return math.isnan(expected) and math.isnan(got)
    if math.isinf(expected) or math.isinf(got):
        return got == expected
    return math.isclose(got, expected, rel_tol=6e-6 if bits == 32 else 1e-14, abs_tol=0.0)


# --- pcap files ----------------------------------------------------------------------------------


def write_pcap(path, linktype, packets):
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 262144, linktype))
        for i, p in enumerate(packets):
            f.write(struct.pack("<IIII", 1_700_000_000 + i, 0, len(p), len(p)))
            f.write(p)
    return path


def ipv4_checksum(header):
    total = sum(struct.unpack("!10H", header))
    while total >> 16:
        total = (total & 0xFFFF) + (total >> 16)
    return ~total & 0xFFFF


def udp_packet(payload, sport, dport, ident=0):
    """Ethernet II, IPv4 (10.0.0.1 -> 10.0.0.2) and UDP (no checksum) around `payload`."""
    udp = struct.pack("!HHHH", sport, dport, 8 + len(payload), 0) + payload
    ip = struct.pack("!BBHHHBBH4s4s", 0x45, 0, 20 + len(udp), ident & 0xFFFF, 0, 64, 17, 0,
                     bytes([10, 0, 0, 1]), bytes([10, 0, 0, 2]))
    ip = ip[:10] + struct.pack("!H", ipv4_checksum(ip)) + ip[12:]
    eth = bytes.fromhex("020000000002" "020000000001" "0800")
    return eth + ip + udp


def udp_pcap(path, datagrams):
    """`datagrams`: (payload, sport, dport)."""
    return write_pcap(path, LINKTYPE_ETHERNET,
                      [udp_packet(p, s, d, i) for i, (p, s, d) in enumerate(datagrams)])


# --- NDLCom --------------------------------------------------------------------------------------

NDLCOM_HEADER_KEYS = {"ndlcom.receiver", "ndlcom.sender", "ndlcom.counter", "ndlcom.length"}


def ndlcom_messages(ir):
    """Messages by id as NDLCom payloads name them (ids below 256; a later dictionary wins)."""
    by_id = {}
    for module in ir["modules"]:
        for m in module["messages"]:
            if m["id"] < 256:
                by_id[m["id"]] = m
    return by_id


PACK = {"u8": "B", "i8": "b", "char": "B", "u16": "H", "i16": "h", "u32": "I", "i32": "i",
        "u64": "Q", "i64": "q", "f32": "f", "f64": "d"}


def random_scalar(rng, primitive):
    if primitive == "f32":
        return rng.choice([rng.uniform(-1e4, 1e4), rng.uniform(-1, 1), 0.0, -0.0, 1e-30, 3.0e38])
    if primitive == "f64":
        return rng.uniform(-1e9, 1e9)
    size = struct.calcsize(PACK[primitive])
    if primitive.startswith("u") or primitive == "char":
        return rng.randrange(1 << (8 * size))
    return rng.randrange(-(1 << (8 * size - 1)), 1 << (8 * size - 1))


TEXT_PIECES = [b"a", b"Z", b"0", b" ", b"_", b"-", "\u00e9".encode(), "\u20ac".encode(), b"\xff", b"\xe2\x82", b"\xc3"]


def random_text(rng, size):
    """Up to `size` bytes of text without NUL, some of it not valid UTF-8."""
    out = b""
    for _ in range(rng.randrange(size + 1)):
        piece = rng.choice(TEXT_PIECES)
        if len(out) + len(piece) > size:
            break
        out += piece
    return out


def message_body(rng, m):
    """A message's whole wire layout with random values."""
    body = bytearray(m["max_len"])
    for f in m["fields"]:
        prim, count = f["ty"]["primitive"], f["ty"]["array"]
        if prim == "char":
            text = random_text(rng, count or 1)
            body[f["offset"]:f["offset"] + len(text)] = text
            continue
        fmt = "<" + PACK[prim]
        size = struct.calcsize(fmt)
        for k in range(count or 1):
            at = f["offset"] + k * size
            body[at:at + size] = struct.pack(fmt, random_scalar(rng, prim))
    return bytes(body)


def ndlcom_encode(env, frames):
    """frames: (receiver, sender, counter, payload bytes) -> encoded frames (bytes)."""
    lines = "".join(json.dumps({"receiver": r, "sender": s, "counter": c, "payload": p.hex()}) + "\n"
                    for r, s, c, p in frames)
    out = env.run(["ndlcom", "encode"], lines).split()
    require(len(out) == len(frames), f"ndlcom encode gave {len(out)} frames for {len(frames)}")
    return [bytes.fromhex(x) for x in out]


def ndlcom_decode(env, packet):
    """What our parser finds in one packet: ([(receiver, sender, counter, payload hex)], crc_failures)."""
    lines = env.run(["ndlcom", "decode"], packet.hex() + "\n").splitlines()
    frames = [json.loads(l) for l in lines[:-1]]
    summary = json.loads(lines[-1])
    return [(f["receiver"], f["sender"], f["counter"], f["payload"]) for f in frames], summary["crc_failures"]


def ndlcom_dissected(layers):
    """Per packet, the frames the dissector shows: dicts with header, payload, status and values."""
    out = []
    for layer in layers:
        frames = []
        for tree in layer.all("ndlcom"):
            if not isinstance(tree, Obj) or tree.get("ndlcom.receiver") is None:
                continue
            frames.append({
                "header": tuple(num(tree.get(k)) for k in ("ndlcom.receiver", "ndlcom.sender", "ndlcom.counter")),
                "payload": (first(tree, "ndlcom.payload") or "").replace(":", ""),
                "status": first(tree, "ndlcom.fcs.status"),
                "message": first(tree, "ndlcom.message"),
                "tree": tree,
            })
        out.append(frames)
    return out


def ndlcom_expected_values(env, frames, dicts):
    """Decodes good frames with `ferrolink ndlcom export`: per frame, (message name, {column: text})
    or None for a payload the dictionary does not name."""
    log = env.path("ndlcom-export.jsonl")
    encoded = ndlcom_encode(env, frames)
    with open(log, "w") as f:
        for t, frame in enumerate(encoded):
            f.write(json.dumps({"t_us": t, "interface": "test", "frame": frame.hex()}) + "\n")
    out = env.path("ndlcom-export")
    shutil.rmtree(out, ignore_errors=True)
    env.run(["ndlcom", "export", log, *[a for d in dicts for a in ("--dict", d)], "--csv", out])
    import csv
    rows = {}
    for path in glob.glob(os.path.join(out, "*.csv")):
        name = os.path.basename(path)[:-4]
        with open(path, newline="") as f:
            for row in csv.DictReader(f):
                t = int(row.pop("t_us"))
                for k in ("sender", "receiver", "counter"):
                    row.pop(k)
                rows[t] = None if name == "unknown" else (name, row)
    return [rows.get(t) for t in range(len(frames))]


def compare_ndlcom(env, lua, pcap, packets, messages, extra=(), dicts=MAVLINK_DEFS):
    """Compares what the dissector shows for `packets` (already in `pcap`) with our decoder's view:
    the same good frames in the same order, as many bad FCS as our parser's CRC failures, and
    every payload field's value as `ndlcom export` decodes it. Returns the number of frames."""
    layers = env.tshark_json(lua, pcap, *extra)
    require(len(layers) == len(packets), f"tshark shows {len(layers)} packets, not {len(packets)}")
    dissected = ndlcom_dissected(layers)
    good_frames = []
    for n, (packet, shown) in enumerate(zip(packets, dissected), 1):
        want, crc_failures = ndlcom_decode(env, packet)
        got = [(f["header"] + (f["payload"],)) for f in shown if f["status"] == "good"]
        require(got == want, f"packet {n}: dissector frames {got[:4]} ... != decoder's {want[:4]} ...")
        bad = sum(1 for f in shown if f["status"] == "bad")
        require(bad == crc_failures, f"packet {n}: {bad} bad FCS shown, the decoder counts {crc_failures}")
        for f in shown:
            if f["status"] == "bad":
                require("ndlcom.fcs.bad" in experts(f["tree"]), f"packet {n}: bad FCS without expert info")
        good_frames.extend(f for f in shown if f["status"] == "good")
    expected = ndlcom_expected_values(
        env, [f["header"] + (bytes.fromhex(f["payload"]),) for f in good_frames], dicts)
    by_name = {m["name"]["wire"]: m for m in messages.values()}
    for i, (frame, exp) in enumerate(zip(good_frames, expected)):
        where = f"frame {i} ({frame['header']})"
        if exp is None:
            require(frame["message"] is None, f"{where}: named {frame['message']}, the decoder knows no such id")
            if frame["payload"]:
                require("ndlcom.unknown_id" in experts(frame["tree"]), f"{where}: unknown id without expert info")
            continue
        name, row = exp
        require(frame["message"] == name, f"{where}: message {frame['message']}, expected {name}")
        m = by_name[name]
        prefix = f"ndlcom.{name.lower()}."
        for fdef in m["fields"]:
            fname, prim, count = fdef["name"]["wire"], fdef["ty"]["primitive"], fdef["ty"]["array"]
            got = values(frame["tree"], prefix + fname)
            if prim == "char":
                require(got == [row[fname]], f"{where}: {prefix}{fname} = {got}, expected {row[fname]!r}")
                continue
            want = [row[f"{fname}[{k}]"] for k in range(count)] if count else [row[fname]]
            require(len(got) == len(want), f"{where}: {len(got)} values of {prefix}{fname}, expected {len(want)}")
            for g, w in zip(got, want):
                if prim in ("f32", "f64"):
                    ok = same_float(g, float(w), 32 if prim == "f32" else 64)
                else:
                    ok = num(g) == int(w)
                require(ok, f"{where}: {prefix}{fname} = {g}, expected {w}")
    return len(good_frames)


def ndlcom_test_frames(env, rng):
    """Frames covering every message of our dictionaries and the awkward cases."""
    messages = ndlcom_messages(env.ir(*MAVLINK_DEFS))
    frames = []
    for mid, m in sorted(messages.items()):
        frames.append((rng.randrange(1, 255), rng.randrange(256), rng.randrange(256), bytes([mid]) + message_body(rng, m)))
    attitude = next(m for m in messages.values() if m["name"]["wire"] == "ATTITUDE")
    heartbeat = next(m for m in messages.values() if m["name"]["wire"] == "HEARTBEAT")
    ping = next(m for m in messages.values() if m["name"]["wire"] == "PING")
    frames += [
        (9, 8, 7, bytes([attitude["id"]]) + message_body(rng, attitude)[:10]),  # zero-filled
        (9, 8, 8, bytes([heartbeat["id"]])),  # id only: all zero
        (9, 8, 9, bytes([heartbeat["id"]]) + message_body(rng, heartbeat) + b"\x01\x02\x03"),  # extra bytes
        (255, 1, 0, bytes([ping["id"]]) + bytes([0x7E, 0x7D] * 7)),  # broadcast, everything escaped
        (0x7E, 0x7D, 0x7E, bytes([0x7E]) + bytes([0x7D, 0x7E, 0x5D, 0x5E] * 4)),  # unknown id 126, escapes
        (3, 4, 5, b""),  # empty payload
        (3, 4, 6, bytes([201]) + bytes(range(40))),  # unknown id
    ]
    return messages, frames


def flip_payload_byte(frame):
    """A copy of an encoded frame with one payload bit flipped (no new flag or escape byte)."""
    b = bytearray(frame)
    for i in range(6, len(b) - 3):
        if b[i] not in (0x7E, 0x7D) and b[i] ^ 1 not in (0x7E, 0x7D) and b[i - 1] != 0x7D:
            b[i] ^= 1
            return bytes(b)
    raise CheckFailed("no byte to flip")


def ndlcom_test_packets(env):
    rng = random.Random(12)
    messages, frames = ndlcom_test_frames(env, rng)
    enc = ndlcom_encode(env, frames)
    noise = bytes([0x55, 0xAA, 0x00, 0x13])
    packets = [
        enc[0],  # one frame
        b"".join(enc[1:4]),  # several frames, flags between them
        noise + enc[4] + bytes([1, 2, 3]) + enc[5] + noise,  # garbage around frames
        flip_payload_byte(enc[6]) + enc[7],  # bad FCS, then a good frame
        enc[8][:5] + b"\x7d\x11" + enc[8][5:] + enc[9],  # invalid escape
        enc[10][:-1] + enc[11][1:],  # no flag between two frames
        enc[12] + enc[13][: len(enc[13]) // 2],  # the last frame cut short
        b"".join(enc[14:]),  # the rest: zero-filled, extra bytes, escapes, empty, unknown ids
        b"\x7e\x7e\x7e",  # flags only
        noise,  # garbage only
    ]
    return messages, packets


def check_ndlcom_user0(env):
    messages, packets = ndlcom_test_packets(env)
    lua = env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING)
    pcap = write_pcap(env.path("ndlcom-user0.pcap"), LINKTYPE_USER0, packets)
    n = compare_ndlcom(env, lua, pcap, packets, messages)
    frames = len(ndlcom_test_frames(env, random.Random(12))[1])
    require(n == frames - 3, f"{n} good frames compared; {frames} less the bad FCS, the bad escape and the cut one")
    layers = env.tshark_json(lua, pcap)
    garbage = [values(t, "ndlcom.garbage") for t in layers[2].all("ndlcom")]
    require(any(garbage), "the garbage around frames is not shown as skipped bytes")
    require("ndlcom.bad_escape" in experts(layers[4]), "the invalid escape has no expert info")
    require("ndlcom.truncated" in experts(layers[6]), "the cut frame has no expert info")
    require("ndlcom.short" in experts(layers[7]), "the short payload is not flagged as zero-filled")


def check_ndlcom_udp(env):
    messages, packets = ndlcom_test_packets(env)
    lua = env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING)
    datagrams = [(p, NDLCOM_PORT_OUT, NDLCOM_PORT_IN) if i % 2 else (p, NDLCOM_PORT_IN, NDLCOM_PORT_OUT)
                 for i, p in enumerate(packets)]
    pcap = udp_pcap(env.path("ndlcom-udp.pcap"), datagrams)
    compare_ndlcom(env, lua, pcap, packets, messages)


def check_ndlcom_decode_as_and_prefs(env):
    messages, packets = ndlcom_test_packets(env)
    lua = env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING)
    pcap = udp_pcap(env.path("ndlcom-other-port.pcap"), [(p, 40000, OTHER_PORT) for p in packets])
    plain = env.tshark_json(lua, pcap)
    require(not any(l.all("ndlcom") for l in plain), "port 5555 was decoded as NDLCom without being asked")
    compare_ndlcom(env, lua, pcap, packets, messages, ("-d", f"udp.port=={OTHER_PORT},ndlcom"))
    compare_ndlcom(env, lua, pcap, packets, messages, ("-o", f"ndlcom.udp_ports:{OTHER_PORT}"))
    default = udp_pcap(env.path("ndlcom-default-port.pcap"), [(p, 40000, NDLCOM_PORT_IN) for p in packets])
    moved = env.tshark_json(lua, default, "-o", f"ndlcom.udp_ports:{OTHER_PORT}")
    require(not any(l.all("ndlcom") for l in moved), "port 34000 still decoded after the preference moved it")


def tlog_mavlink_payloads(path, messages, limit):
    """(msgid, payload) of the MAVLink frames in a .tlog whose id NDLCom can carry and whose CRC
    checks with the dictionary's CRC_EXTRA."""
    by_id = {m["id"]: m for m in messages.values()}
    data = open(path, "rb").read()
    out, i = [], 0
    while i + 8 < len(data) and len(out) < limit:
        at = i + 8  # after the record's timestamp
        magic = data[at]
        if magic == 0xFE:
            head_len, signature = 6, 0
        elif magic == 0xFD and at + 2 < len(data):
            head_len, signature = 10, 13 if data[at + 2] & 1 else 0
        else:
            break  # not a record boundary: stop rather than guess
        if at + head_len > len(data):
            break
        n = data[at + 1]
        msgid = data[at + 5] if magic == 0xFE else int.from_bytes(data[at + 7:at + 10], "little")
        end = at + head_len + n + 2 + signature
        if end > len(data):
            break
        payload = data[at + head_len:at + head_len + n]
        crc = int.from_bytes(data[at + head_len + n:at + head_len + n + 2], "little")
        m = by_id.get(msgid)
        if m is not None and x25(data[at + 1:at + head_len] + payload + bytes([m["crc_extra"]])) == crc:
            out.append((msgid, payload))
        i = end
    return out


def x25(data):
    crc = 0xFFFF
    for b in data:
        t = b ^ (crc & 0xFF)
        t = (t ^ (t << 4)) & 0xFF
        crc = ((crc >> 8) ^ (t << 8) ^ (t << 3) ^ (t >> 4)) & 0xFFFF
    return crc


def check_ndlcom_real_captures(env):
    if not env.captures or not os.path.isdir(env.captures):
        raise Skip(f"no captures directory ({env.captures})")
    messages = ndlcom_messages(env.ir(*MAVLINK_DEFS))
    payloads = []
    for name in ("clydemcqueen__ardusub_log_tools__small.tlog", "ArduPilot__UAVLogViewer__vtol.tlog",
                 "code-lever__mavlink-log__2013-10-13_16-58-51.tlog"):
        path = os.path.join(env.captures, name)
        if os.path.exists(path):
            payloads += tlog_mavlink_payloads(path, messages, 150)
    if not payloads:
        raise Skip("none of the expected captures is there")
    frames = [(1, 2, i % 256, bytes([mid]) + p) for i, (mid, p) in enumerate(payloads)]
    enc = ndlcom_encode(env, frames)
    packets = [b"".join(enc[i:i + 7]) + (b"\x00\x7e" if i % 3 == 0 else b"") for i in range(0, len(enc), 7)]
    lua = env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING)
    pcap = write_pcap(env.path("ndlcom-captures.pcap"), LINKTYPE_USER0, packets)
    n = compare_ndlcom(env, lua, pcap, packets, messages)
    names = {messages[mid]["name"]["wire"] for mid, _ in payloads}
    require(n == len(frames), f"{n} frames compared of {len(frames)}")
    require(len(names) >= 3, f"only {sorted(names)} in the captures")


# --- ModRob-1 ------------------------------------------------------------------------------------


def crc8_smbus(data):
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


CROCKFORD = "0123456789ABCDEFGHJKMNPQRSTVWXYZ"


def ulid_text(raw16):
    v = int.from_bytes(raw16, "big")
    return "".join(CROCKFORD[(v >> (5 * (25 - i))) & 31] for i in range(26))


def uuid_text(raw16):
    h = raw16.hex()
    return f"{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:]}"


class RobotNames:
    """MI and VI names as the dissector should give them."""

    def __init__(self, ir):
        self.dicts = ir["modrob"]
        self.by_mi = {}
        for robot in ir["robots"]:
            for inst in robot["instances"]:
                self.by_mi.setdefault(inst["module_id"], (inst["name"]["wire"], self.dicts[inst["dictionary"]]))
        if not ir["robots"]:
            for d in self.dicts:
                self.by_mi.setdefault(d["module_id"], (None, d))

    def variable(self, mi, vi):
        entry = self.by_mi.get(mi)
        if entry is None:
            return None
        for v in entry[1]["variables"]:
            if v["vi"] <= vi < v["vi"] + v["count"]:
                return v["name"]["wire"] + (f"[{vi - v['vi']}]" if v["count"] > 1 else "")
        return None

    def limits(self, mi, vi):
        entry = self.by_mi.get(mi)
        for v in entry[1]["variables"] if entry else []:
            if v["vi"] <= vi < v["vi"] + v["count"]:
                return v["min"], v["max"]
        return None, None


def modrob_dissected(layer):
    """The messages the dissector shows in one packet, in order, as dicts."""
    out = []
    for tree in layer.all("modrob"):
        if not isinstance(tree, Obj):
            continue
        for key, msg in tree:
            if key not in ("modrob.message", "modrob.message_tree") or not isinstance(msg, Obj):
                continue
            get = lambda k: first(msg, k)  # noqa: E731
            out.append({
                "type": num(get("modrob.type")), "mi": num(get("modrob.mi")),
                "vi": get("modrob.vi"), "chunk": get("modrob.chunk"), "chunks": get("modrob.chunks"),
                "value": get("modrob.value"), "frequency": get("modrob.frequency"),
                "command": get("modrob.command"), "source_mi": get("modrob.source_mi"),
                "source_vi": get("modrob.source_vi"), "data": (get("modrob.data") or "").replace(":", ""),
                "status": get("modrob.crc.status"), "instance": get("modrob.instance"),
                "module": get("modrob.module"), "variable": get("modrob.variable"),
                "source_instance": get("modrob.source_instance"),
                "source_variable": get("modrob.source_variable"), "experts": experts(msg), "tree": msg,
            })
    return out


COMMAND_CODES = {"set_value": 0, "set_frequency": 1, "set_subscription": 2}
TYPE_CODES = {"command": 0, "publication": 1, "piecewise": 2}


def compare_modrob_message(where, got, want, names):
    require(got["status"] == "good", f"{where}: CRC status {got['status']}")
    require(got["type"] == TYPE_CODES[want["type"]], f"{where}: type {got['type']}, expected {want['type']}")
    require(got["mi"] == want["module"], f"{where}: MI {got['mi']:#x}, expected {want['module']:#x}")
    instance = names.by_mi.get(want["module"], (None, None))[0]
    require(got["instance"] == instance, f"{where}: instance {got['instance']}, expected {instance}")
    if want["type"] == "piecewise":
        require(num(got["chunk"]) == want["chunk"] and num(got["chunks"]) == want["chunks"],
                f"{where}: chunk {got['chunk']}/{got['chunks']}, expected {want['chunk']}/{want['chunks']}")
        require(got["data"] == want["data"], f"{where}: data {got['data']}, expected {want['data']}")
        return
    require(num(got["vi"]) == want["variable"], f"{where}: VI {got['vi']}, expected {want['variable']}")
    variable = names.variable(want["module"], want["variable"])
    require(got["variable"] == variable, f"{where}: variable {got['variable']}, expected {variable}")

    def as_float(v):
        return {"NaN": math.nan, "inf": math.inf, "-inf": -math.inf}.get(v, v) if isinstance(v, str) else v

    if want["type"] == "publication":
        require(same_float(got["value"], float(as_float(want["value"]))), f"{where}: value {got['value']}, expected {want['value']}")
        return
    require(num(got["command"]) == COMMAND_CODES[want["command"]], f"{where}: command {got['command']}, expected {want['command']}")
    if want["command"] == "set_value":
        require(same_float(got["value"], float(as_float(want["value"]))), f"{where}: value {got['value']}, expected {want['value']}")
    elif want["command"] == "set_frequency":
        require(same_float(got["frequency"], float(as_float(want["value"]))), f"{where}: frequency {got['frequency']}, expected {want['value']}")
    else:
        require(num(got["source_mi"]) == want["source_module"] and num(got["source_vi"]) == want["source_variable"],
                f"{where}: source {got['source_mi']}.{got['source_vi']}, expected {want['source_module']}.{want['source_variable']}")
        sname = names.by_mi.get(want["source_module"], (None, None))[0]
        svar = names.variable(want["source_module"], want["source_variable"])
        require(got["source_instance"] == sname and got["source_variable"] == svar,
                f"{where}: source {got['source_instance']}.{got['source_variable']}, expected {sname}.{svar}")


def modrob_test_messages(ir, rng):
    """JSON messages for `modrob encode`: every instance's variables published, every command kind,
    piecewise chunks, an unknown MI, special values."""
    msgs = []
    robot = ir["robots"][0]
    inst = {i["name"]["wire"]: i for i in robot["instances"]}
    for i in robot["instances"]:
        d = ir["modrob"][i["dictionary"]]
        for v in d["variables"]:
            vi = v["vi"] + rng.randrange(v["count"])
            value = struct.unpack("<f", struct.pack("<f", rng.uniform(-100, 100)))[0]
            msgs.append({"type": "publication", "module": i["module_id"], "variable": vi, "value": value})
    drive, motion = inst["drive_fl"], inst["motion"]
    mode_vi = next(v["vi"] for v in ir["modrob"][drive["dictionary"]]["variables"] if v["name"]["wire"] == "mode")
    wheel_vi = next(v["vi"] for v in ir["modrob"][motion["dictionary"]]["variables"] if v["name"]["wire"] == "wheel_fl")
    msgs += [
        {"type": "command", "command": "set_value", "module": drive["module_id"], "variable": mode_vi, "value": 1.0},
        {"type": "command", "command": "set_value", "module": drive["module_id"], "variable": mode_vi, "value": 5.0},
        {"type": "command", "command": "set_frequency", "module": drive["module_id"], "variable": 3, "value": 10.0},
        {"type": "command", "command": "set_subscription", "module": drive["module_id"], "variable": 0,
         "source_module": motion["module_id"], "source_variable": wheel_vi},
        {"type": "piecewise", "module": motion["module_id"], "chunk": 0, "chunks": 2, "data": b"ModRob-".hex()},
        {"type": "piecewise", "module": motion["module_id"], "chunk": 1, "chunks": 2, "data": b"1".hex()},
        {"type": "publication", "module": 0x7777, "variable": 9, "value": 0.5},
        {"type": "publication", "module": drive["module_id"], "variable": 200, "value": -0.0},
        {"type": "publication", "module": drive["module_id"], "variable": 1, "value": "NaN"},
        {"type": "publication", "module": drive["module_id"], "variable": 1, "value": "-inf"},
    ]
    return msgs


def modrob_encode(env, transport, msgs, *extra):
    lines = "".join(json.dumps(m) + "\n" for m in msgs)
    return [bytes.fromhex(x) for x in env.run(["modrob", "encode", "--transport", transport, *extra], lines).split()]


def modrob_decode(env, transport, data_lines):
    out = env.run(["modrob", "decode", "--transport", transport], "".join(d.hex() + "\n" for d in data_lines), ok_codes=(0, 1))
    return [json.loads(l) for l in out.splitlines() if l.strip()]


def pad_piecewise(msgs_json):
    """`modrob decode` prints a chunk's 7 bytes; the JSON we encode may give fewer."""
    for m in msgs_json:
        if m["type"] == "piecewise":
            m["data"] = (bytes.fromhex(m["data"]) + bytes(7))[:7].hex()
    return msgs_json


def check_modrob_ethernet(env):
    ir = env.ir(ROBOT)
    names = RobotNames(ir)
    rng = random.Random(3)
    msgs = modrob_test_messages(ir, rng)
    sender = next(i for i in ir["robots"][0]["instances"] if i["name"]["wire"] == "motion")
    uuid = uuid_text(bytes(sender["uuid"]))
    first_ulid = "01HZX3V6E9Q4C4B0SMJ6H4G2KD"
    packets = modrob_encode(env, "ethernet", msgs, "--module-uuid", uuid, "--message-ulid", first_ulid,
                            "--max-datagram", str(34 + 12 * 13))
    require(len(packets) >= 3, f"{len(packets)} packets; the batch should need several")
    # A message with a bad CRC inside an intact packet, a packet cut short, trailing bytes.
    damaged = bytearray(packets[0])
    damaged[34 + 12 * 2 + 6] ^= 0x40
    packets_all = packets + [bytes(damaged), packets[1][:34 + 12 * 3 + 5], packets[2] + b"\x00\x01"]
    lua = env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING)
    pcap = udp_pcap(env.path("modrob-ethernet.pcap"),
                    [(p, MODROB_PORT + 9, MODROB_PORT + (i % 14)) for i, p in enumerate(packets_all)])
    layers = env.tshark_json(lua, pcap)
    require(len(layers) == len(packets_all), f"{len(layers)} packets shown")
    compared = 0
    for n, (packet, layer) in enumerate(zip(packets, layers)):
        want = pad_piecewise(modrob_decode(env, "ethernet", [packet]))
        got = modrob_dissected(layer)
        require(len(got) == len(want), f"packet {n}: {len(got)} messages shown, the decoder has {len(want)}")
        for k, (g, w) in enumerate(zip(got, want)):
            compare_modrob_message(f"packet {n} message {k}", g, w, names)
            if w["type"] == "command" and w["command"] == "set_value":
                lo, hi = names.limits(w["module"], w["variable"])
                outside = (lo is not None and w["value"] < lo) or (hi is not None and w["value"] > hi)
                require(("modrob.limits" in g["experts"]) == outside, f"packet {n} message {k}: limits flag wrong")
            if names.variable(w["module"], w.get("variable", 0)) is None and w["type"] != "piecewise":
                require("modrob.unknown" in g["experts"], f"packet {n} message {k}: unknown MI/VI not flagged")
            compared += 1
        tree = layer.get("modrob")
        require(first(tree, "modrob.ulid.text") == ulid_text(packet[:16]),
                f"packet {n}: ULID {first(tree, 'modrob.ulid.text')}, expected {ulid_text(packet[:16])}")
        require(first(tree, "modrob.uuid") == uuid, f"packet {n}: UUID {first(tree, 'modrob.uuid')}")
        require(first(tree, "modrob.sender") == "motion", f"packet {n}: sender {first(tree, 'modrob.sender')}")
        require(num(first(tree, "modrob.count")) == len(want), f"packet {n}: count {first(tree, 'modrob.count')}")
    require(first(layers[0].get("modrob"), "modrob.ulid.text") == first_ulid, "the first packet's ULID is not the one given")
    require(compared == len(msgs), f"{compared} messages compared of {len(msgs)}")
    # The damaged packet: the decoder drops the broken message, the dissector shows it as bad.
    got = modrob_dissected(layers[len(packets)])
    want = pad_piecewise(modrob_decode(env, "ethernet", [bytes(damaged)]))
    require([g["status"] for g in got].count("bad") == 1, "the message with a bad CRC is not shown as bad")
    require(got[2]["status"] == "bad" and "modrob.crc.bad" in got[2]["experts"], "message 2 should have the bad CRC")
    for k, (g, w) in enumerate(zip([g for g in got if g["status"] == "good"], want)):
        compare_modrob_message(f"damaged packet message {k}", g, w, names)
    for layer in layers[len(packets) + 1:]:
        require("modrob.packet.malformed" in experts(layer.get("modrob")), "a malformed packet is not flagged")


def check_modrob_uart(env):
    ir = env.ir(ROBOT)
    names = RobotNames(ir)
    rng = random.Random(5)
    msgs = modrob_test_messages(ir, rng)
    frames = modrob_encode(env, "uart", msgs)
    # A message with a valid CRC but a reserved command type: the decoder skips it whole.
    body = bytes([0x5A]) + ((0x0111 << 8 | 2) << 4 | 6).to_bytes(4, "little") + bytes([0, 0, 0, 0, 7, 0])
    reserved = body + bytes([crc8_smbus(body)])
    bad_crc = bytearray(frames[1])
    bad_crc[7] ^= 0x10
    packets = [
        b"".join(frames[0:3]),
        bytes([0x00, 0x5A, 0xFF, 0x5A, 0x36]) + frames[3] + bytes([0x5A]) + frames[4],  # noise and false starts
        bytes(bad_crc) + frames[5] + reserved + frames[6],
        frames[7] + frames[8][:9],  # an unfinished message at the end
        bytes([0x5A]) + frames[9][:3] + frames[10],  # a false start overlapping a real message
        b"".join(frames[11:]),
        bytes(range(0x50, 0x60)),  # garbage only
    ]
    lua = env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING)
    pcap = write_pcap(env.path("modrob-uart-user1.pcap"), LINKTYPE_USER1, packets)
    layers = env.tshark_json(lua, pcap)
    require(len(layers) == len(packets), f"{len(layers)} packets shown")
    total = 0
    for n, (packet, layer) in enumerate(zip(packets, layers)):
        decoded = modrob_decode(env, "uart", [packet])
        want, summary = pad_piecewise(decoded[:-1]), decoded[-1]
        shown = modrob_dissected(layer)
        got = [g for g in shown if "modrob.reserved.used" not in g["experts"]]
        require(len(got) == len(want), f"packet {n}: {len(got)} messages shown, the decoder finds {len(want)}")
        for k, (g, w) in enumerate(zip(got, want)):
            compare_modrob_message(f"packet {n} message {k}", g, w, names)
        require(len(shown) - len(got) == summary["decode_errors"],
                f"packet {n}: {len(shown) - len(got)} reserved messages shown, decoder counts {summary['decode_errors']}")
        if summary["dropped"] > summary["decode_errors"] * 12:
            require(values(layer.get("modrob"), "modrob.garbage"), f"packet {n}: skipped bytes not shown")
        total += len(want)
    require(total >= len(msgs) - 3, f"only {total} messages compared")


def check_modrob_ports_and_heuristic(env):
    ir = env.ir(ROBOT)
    names = RobotNames(ir)
    msgs = modrob_test_messages(ir, random.Random(8))[:20]
    uuid = uuid_text(bytes(ir["robots"][0]["instances"][0]["uuid"]))
    packet = modrob_encode(env, "ethernet", msgs, "--module-uuid", uuid)[0]
    want = pad_piecewise(modrob_decode(env, "ethernet", [packet]))
    lua = env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING)
    cases = [
        ("default port", [(packet, 40123, MODROB_PORT + 15)], ()),
        ("decode as", [(packet, 40123, OTHER_PORT)], ("-d", f"udp.port=={OTHER_PORT},modrob")),
        ("preference", [(packet, 40123, OTHER_PORT)], ("-o", f"modrob.udp_ports:{OTHER_PORT}")),
        ("heuristic", [(packet, 40123, 40999)], ()),
    ]
    for label, datagrams, extra in cases:
        layers = env.tshark_json(lua, udp_pcap(env.path("modrob-ports.pcap"), datagrams), *extra)
        got = modrob_dissected(layers[0])
        require(len(got) == len(want), f"{label}: {len(got)} messages, expected {len(want)}")
        for k, (g, w) in enumerate(zip(got, want)):
            compare_modrob_message(f"{label} message {k}", g, w, names)
    noise = random.Random(1).randbytes(120)
    layers = env.tshark_json(lua, udp_pcap(env.path("modrob-noise.pcap"), [(noise, 40123, 40999)]))
    require(not layers[0].all("modrob"), "the heuristic took random bytes for Ethernet-1")


def check_modrob_without_robot(env):
    dicts = [os.path.join(ROOT, "definitions", "modrob", n) for n in ("drive.toml", "motion_control.toml")]
    ir = env.ir(*dicts)
    names = RobotNames(ir)
    drive = next(d for d in ir["modrob"] if d["dictionary"] == "drive")
    motion = next(d for d in ir["modrob"] if d["dictionary"] == "motion_control")
    msgs = [
        {"type": "publication", "module": drive["module_id"], "variable": 1, "value": 2.5},
        {"type": "command", "command": "set_value", "module": drive["module_id"], "variable": 0, "value": 60.0},
        {"type": "publication", "module": motion["module_id"], "variable": 7, "value": -1.25},
        {"type": "publication", "module": 0x0111, "variable": 1, "value": 1.0},
    ]
    lua = env.render("modrob-dicts.lua", *dicts)
    frames = modrob_encode(env, "uart", msgs)
    layers = env.tshark_json(lua, write_pcap(env.path("modrob-dicts.pcap"), LINKTYPE_USER1, [b"".join(frames)]))
    got = modrob_dissected(layers[0])
    want = modrob_decode(env, "uart", [b"".join(frames)])[:-1]
    require(len(got) == 4, f"{len(got)} messages shown")
    for k, (g, w) in enumerate(zip(got, want)):
        compare_modrob_message(f"message {k}", g, w, names)
    require([g["module"] for g in got] == ["drive", "drive", "motion_control", None],
            f"modules {[g['module'] for g in got]}")
    require([g["variable"] for g in got] == ["speed", "speed_setpoint", "yaw", None],
            f"variables {[g['variable'] for g in got]}")
    require(all(g["instance"] is None for g in got), "an instance without a robot file")
    require("modrob.limits" in got[1]["experts"], "60 rad/s is outside speed_setpoint's limits and not flagged")
    require("modrob.unknown" in got[3]["experts"], "MI 0x0111 is no dictionary's and not flagged")


# --- TosNet --------------------------------------------------------------------------------------

COMMAND = {"IDLE": 0x0, "MASTER_DSC": 0x2, "MASTER_SET": 0x3, "NET_DSC": 0x4, "NET_SET": 0x5, "REG_DSC": 0x6,
           "REG_SET": 0x7, "SYNC_DSC": 0x8, "SYNC_SET": 0x9, "DATA": 0xA, "ASYNC": 0xC, "HALT": 0xF}


def crc8_tosnet(data):
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x65) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


def tos_frame(command, arg, body=b""):
    head = bytes([COMMAND[command] << 4 | arg]) + body
    return head + bytes([crc8_tosnet(head)])


class RingMap:
    def __init__(self, ring):
        self.ring = ring
        self.nodes = {n["id"]: n for n in ring["nodes"]}

    def layout(self, order=None):
        """(node id, register index) in DATA order: `order` (ring order) or ids ascending."""
        out = []
        for nid in order or sorted(self.nodes):
            regs = {r["index"]: r for r in self.nodes[nid]["registers"]}
            for idx in range(8):
                r = regs.get(idx)
                if r and (r["in_area"] is not None or r["out_area"] is not None):
                    out.append((nid, idx))
        return out

    def masks(self, order):
        out = b""
        for nid in order:
            regs = self.nodes[nid]["registers"]
            inm = sum(1 << r["index"] for r in regs if r["in_area"] is not None)
            outm = sum(1 << r["index"] for r in regs if r["out_area"] is not None)
            out += bytes([inm, outm])
        return out

    def area(self, nid, idx, direction):
        reg = next(r for r in self.nodes[nid]["registers"] if r["index"] == idx)
        i = reg["in_area" if direction == "in" else "out_area"]
        return None if i is None else self.ring["areas"][i]


def fill_area(rng, area):
    """16 bytes with random values in `area`'s fields, and those values."""
    raw = bytearray(rng.randbytes(16))
    vals = {}
    for f in area["fields"] if area else []:
        prim, count = f["ty"]["primitive"], f["ty"]["array"]
        if prim == "char":
            count = count or 1
            text = random_text(rng, count)
            raw[f["offset"]:f["offset"] + count] = text + bytes(count - len(text))
            vals[f["name"]["wire"]] = [text.decode("utf-8", errors="replace")]
            continue
        fmt = "<" + PACK[prim]
        size = struct.calcsize(fmt)
        vals[f["name"]["wire"]] = []
        for k in range(count or 1):
            v = random_scalar(rng, prim)
            at = f["offset"] + k * size
            raw[at:at + size] = struct.pack(fmt, v)
            vals[f["name"]["wire"]].append(struct.unpack(fmt, raw[at:at + size])[0])
    return bytes(raw), vals


def data_frame(rng, rmap, order, cycle, master=0):
    body = struct.pack("<H", cycle)
    expected = []
    for nid, idx in rmap.layout(order):
        for direction in ("out", "in"):
            area = rmap.area(nid, idx, direction)
            raw, vals = fill_area(rng, area)
            body += raw
            expected.append((nid, idx, direction, area["name"]["wire"] if area else None, vals))
    return tos_frame("DATA", master, body), expected


def tosnet_areas(tree):
    """What the dissector shows of a DATA frame: (node, register, direction, area, {field: [values]})."""
    out, node, reg = [], None, None
    for key, value in leaves(tree):
        if key == "tosnet.node":
            node = num(value)
        elif key == "tosnet.register":
            reg = num(value)
        elif key == "tosnet.direction":
            out.append([node, reg, value, None, {}])
        elif key == "tosnet.area" and out:
            out[-1][3] = value
        elif out and out[-1][3] and key.startswith(f"tosnet.{out[-1][3]}."):
            out[-1][4].setdefault(key.split(".")[-1], []).append(value)
    return [tuple(x) for x in out]


def compare_data(where, shown, expected, ring):
    require(len(shown) == len(expected), f"{where}: {len(shown)} areas shown, expected {len(expected)}")
    for (node, reg, d, area, vals), (enode, ereg, ed, earea, evals) in zip(shown, expected):
        require((node, reg, d, area) == (enode, ereg, ed, earea),
                f"{where}: area {(node, reg, d, area)}, expected {(enode, ereg, ed, earea)}")
        for fname, want in evals.items():
            got = vals.get(fname, [])
            fdef = next(f for f in next(a for a in ring["areas"] if a["name"]["wire"] == area)["fields"]
                        if f["name"]["wire"] == fname)
            prim = fdef["ty"]["primitive"]
            require(len(got) == len(want), f"{where}: {len(got)} values of tosnet.{area}.{fname}")
            for g, w in zip(got, want):
                if isinstance(w, str):
                    ok = g == w
                elif prim in ("f32", "f64"):
                    ok = same_float(g, w, 32 if prim == "f32" else 64)
                else:
                    ok = num(g) == w
                require(ok, f"{where}: node {node} register {reg} tosnet.{area}.{fname} = {g}, expected {w}")


def check_tosnet(env):
    require(crc8_tosnet(b"123456789") == 0xDF, "the test's own CRC-8 is wrong")
    ir = env.ir(RING)
    ring = ir["rings"][0]
    rmap = RingMap(ring)
    rng = random.Random(21)
    names = {n["id"]: n["name"]["wire"] for n in ring["nodes"]}
    order = [0, 2, 1, 3]  # a ring whose order is not the id order
    d1, e1 = data_frame(rng, rmap, None, 1)
    d2, e2 = data_frame(rng, rmap, order, 2)
    d3, _ = data_frame(rng, rmap, order, 3)
    bad = bytearray(d3)
    bad[10] ^= 0x01
    broken = d3[:-1] + bytes([crc8_tosnet(d3[:-1]) ^ 0x0F])
    odd = tos_frame("DATA", 0, struct.pack("<H", 4) + bytes(64))  # 2 registers: no map fits
    sync_len = len(d1) - 2
    frames = [
        ("data before setup", d1),
        ("MASTER_DSC", tos_frame("MASTER_DSC", 0, bytes([3]))),
        ("MASTER_SET", tos_frame("MASTER_SET", 0)),
        ("NET_DSC", tos_frame("NET_DSC", 0, bytes([2, 0, 2]))),
        ("NET_SET", tos_frame("NET_SET", 0, bytes([4] + order))),
        ("REG_DSC", tos_frame("REG_DSC", 0, bytes([4]) + rmap.masks(order)[:4] + bytes(4))),
        ("REG_SET", tos_frame("REG_SET", 0, bytes([4]) + rmap.masks(order))),
        ("SYNC_DSC", tos_frame("SYNC_DSC", 0, bytes(sync_len))),
        ("SYNC_SET", tos_frame("SYNC_SET", 0, struct.pack("<I", 5460))),
        ("data after setup", d2),
        ("bad CRC", bytes(bad)),
        ("marked broken", broken),
        ("no map fits", odd),
        ("IDLE", tos_frame("IDLE", 3)),
        ("ASYNC", tos_frame("ASYNC", 0, bytes([2]) + b"hello")),
        ("HALT", tos_frame("HALT", 0)),
        ("unknown command", bytes([0x10, 0x00]) + bytes([crc8_tosnet(bytes([0x10, 0x00]))])),
        ("NET_SET too many", tos_frame("NET_SET", 0, bytes([20]) + bytes(20))),
        ("one byte", b"\xa0"),
        ("SYNC_DSC not zero", tos_frame("SYNC_DSC", 0, b"\x01" * 4)),
    ]
    lua = env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING)
    pcap = udp_pcap(env.path("tosnet.pcap"), [(f, TOSNET_PORT + 1, TOSNET_PORT + 2) for _, f in frames])
    layers = env.tshark_json(lua, pcap)
    require(len(layers) == len(frames), f"{len(layers)} packets shown")
    by = {label: layer.get("tosnet") for (label, _), layer in zip(frames, layers)}
    for label, tree in by.items():
        require(tree is not None, f"{label}: not decoded as TosNet")
    for label, frame in frames:
        if len(frame) < 2:
            continue
        want = COMMAND_NAMES.get(frame[0] >> 4)
        require(num(first(by[label], "tosnet.command")) == frame[0] >> 4, f"{label}: command {first(by[label], 'tosnet.command')}")
        status = "good" if crc8_tosnet(frame) == 0 else "bad"
        require(first(by[label], "tosnet.crc.status") == status, f"{label} ({want}): CRC status {first(by[label], 'tosnet.crc.status')}")
    compare_data("DATA before setup (id order)", tosnet_areas(by["data before setup"]), e1, ring)
    compare_data("DATA after NET_SET (ring order 0 2 1 3)", tosnet_areas(by["data after setup"]), e2, ring)
    shown_nodes = values(by["data after setup"], "tosnet.node_name")
    require(shown_nodes[:3] == [names[2]] * 3 and shown_nodes[3:6] == [names[1]] * 3,
            f"node names in ring order: {shown_nodes}")
    require(num(first(by["data after setup"], "tosnet.cycle")) == 2, "cycle counter")
    require(first(by["data after setup"], "tosnet.ring") == ring["name"]["wire"], "register map name")
    require(values(by["NET_SET"], "tosnet.node_id") == [str(i) for i in order], "NET_SET node ids")
    require(num(first(by["SYNC_SET"], "tosnet.delay_ns")) == 5460, "SYNC_SET delay")
    require(first(by["ASYNC"], "tosnet.source") == "2" and first(by["ASYNC"], "tosnet.dest") == "0", "ASYNC addresses")
    require("tosnet.crc.bad" in experts(by["bad CRC"]), "bad CRC without expert info")
    require("tosnet.crc.broken" in experts(by["marked broken"]), "a CRC marked broken upstream is not recognised")
    require("tosnet.crc.broken" not in experts(by["bad CRC"]), "a plain bad CRC taken for a marked one")
    require("tosnet.layout" in experts(by["no map fits"]) and len(values(by["no map fits"], "tosnet.raw")) == 4,
            "a DATA frame no map fits is not shown raw")
    for label in ("unknown command", "NET_SET too many", "one byte", "SYNC_DSC not zero"):
        require("tosnet.malformed" in experts(by[label]), f"{label}: not flagged as malformed")
    # The same capture through "Decode As" and the ports preference.
    other = udp_pcap(env.path("tosnet-other.pcap"), [(f, 40000, OTHER_PORT) for _, f in frames])
    for extra in (("-d", f"udp.port=={OTHER_PORT},tosnet"), ("-o", f"tosnet.udp_ports:{OTHER_PORT}")):
        again = env.tshark_json(lua, other, *extra)
        compare_data(f"DATA via {extra[0]}", tosnet_areas(again[9].get("tosnet")), e2, ring)


COMMAND_NAMES = {v: k for k, v in COMMAND.items()}


# --- the generator's test fixtures: every field type, keyword names, arrays, text, gaps ---------

FIXTURES = sorted(glob.glob(os.path.join(ROOT, "dictionary", "tests", "fixtures", "ok", "*.xml"))
                  + glob.glob(os.path.join(ROOT, "dictionary", "tests", "fixtures", "ok", "*.toml")))


def fixture_frames(env, rng):
    """NDLCom frames for the fixture messages `ndlcom export` can decode the same way as the
    dissector (export takes only dictionaries whose every id fits NDLCom), UART.B-1 frames for
    every fixture variable, and one DATA frame per register map (with its expected areas)."""
    ir = env.ir(*FIXTURES)
    messages = ndlcom_messages(ir)
    def fits(module):
        return all(x["id"] < 256 and x["max_len"] < 255
                   for i in module["closure"] for x in ir["modules"][i]["messages"])

    fitting = {os.path.abspath(m["path"]) for m in ir["modules"] if fits(m)}
    carried = [p for p in FIXTURES if p.endswith(".xml") and os.path.abspath(p) in fitting]
    subset = ndlcom_messages(env.ir(*carried))
    ids = [i for i in sorted(messages) if i in subset and subset[i]["name"] == messages[i]["name"]]
    ndl = [(rng.randrange(1, 255), rng.randrange(256), k % 256, bytes([i]) + message_body(rng, messages[i]))
           for k, i in enumerate(ids)]
    ndl += [(1, 2, 3, bytes([i]) + message_body(rng, messages[i])[: rng.randrange(messages[i]["max_len"])])
            for i in ids]  # every message zero-filled too
    msgs = []
    for robot in ir["robots"]:
        for inst in robot["instances"]:
            for v in ir["modrob"][inst["dictionary"]]["variables"]:
                for vi in range(v["vi"], v["vi"] + v["count"]):
                    value = struct.unpack("<f", struct.pack("<f", rng.uniform(-10, 10)))[0]
                    msgs.append({"type": "publication", "module": inst["module_id"], "variable": vi, "value": value})
                    if v["direction"] == "input":
                        msgs.append({"type": "command", "command": "set_value", "module": inst["module_id"],
                                     "variable": vi, "value": value})
    # Per map: NET_SET and REG_SET of a ring of its nodes, then a DATA frame, which the dissector
    # shows with the map that has all of those nodes and most of their registers.
    rings = []
    maps = [RingMap(ring) for ring in ir["rings"]]
    for rmap in maps:
        order = sorted(rmap.nodes)
        enabled = set(rmap.layout(order))

        def score(other):
            if any(i not in other.nodes for i in order):
                return -1
            return sum(1 for i, reg in enabled if any(r["index"] == reg for r in other.nodes[i]["registers"]))

        if max(maps, key=score) is not rmap:
            continue  # another map fits this ring as well; the dissector takes that one
        setup = [tos_frame("NET_SET", order[0], bytes([len(order)] + order)),
                 tos_frame("REG_SET", order[0], bytes([len(order)]) + rmap.masks(order))]
        frame, expected = data_frame(rng, rmap, order, rng.randrange(65536), order[0])
        rings.append((rmap.ring, setup + [frame], expected))
    return ir, messages, carried, ndl, msgs, rings


def check_fixtures(env):
    if not FIXTURES:
        raise Skip("no generator fixtures")
    rng = random.Random(31)
    ir, messages, carried, ndl, msgs, rings = fixture_frames(env, rng)
    lua = env.render("fixtures.lua", *FIXTURES)
    enc = ndlcom_encode(env, ndl)
    packets = [b"".join(enc[i:i + 3]) for i in range(0, len(enc), 3)]
    pcap = write_pcap(env.path("fixtures-ndlcom.pcap"), LINKTYPE_USER0, packets)
    n = compare_ndlcom(env, lua, pcap, packets, messages, dicts=carried)
    require(n == len(ndl), f"{n} NDLCom frames compared of {len(ndl)}")
    names = RobotNames(ir)
    frames = modrob_encode(env, "uart", msgs)
    packets = [b"".join(frames[i:i + 5]) for i in range(0, len(frames), 5)]
    layers = env.tshark_json(lua, write_pcap(env.path("fixtures-modrob.pcap"), LINKTYPE_USER1, packets))
    compared = 0
    for k, (packet, layer) in enumerate(zip(packets, layers)):
        want = modrob_decode(env, "uart", [packet])[:-1]
        got = modrob_dissected(layer)
        require(len(got) == len(want), f"packet {k}: {len(got)} ModRob messages, expected {len(want)}")
        for j, (g, w) in enumerate(zip(got, want)):
            compare_modrob_message(f"ModRob packet {k} message {j}", g, w, names)
            compared += 1
    require(compared == len(msgs) > 0, f"{compared} ModRob messages compared of {len(msgs)}")
    datagrams = [(f, TOSNET_PORT, TOSNET_PORT + 1) for _, frames3, _ in rings for f in frames3]
    layers = env.tshark_json(lua, udp_pcap(env.path("fixtures-tosnet.pcap"), datagrams))
    for k, (ring, _, expected) in enumerate(rings):
        tree = layers[3 * k + 2].get("tosnet")
        compare_data(f"ring {ring['name']['wire']}", tosnet_areas(tree), expected, ring)
        require(first(tree, "tosnet.ring") == ring["name"]["wire"], f"DATA of {ring['name']['wire']} shown with {first(tree, 'tosnet.ring')}")
    require(len(rings) >= 2, f"only {len(rings)} register maps checked")


# --- robustness ----------------------------------------------------------------------------------


def mutate(rng, frame):
    b = bytearray(frame)
    for _ in range(rng.randrange(1, 4)):
        op = rng.randrange(4)
        if op == 0 and b:
            b[rng.randrange(len(b))] = rng.randrange(256)
        elif op == 1:
            b.insert(rng.randrange(len(b) + 1), rng.choice([0x7E, 0x7D, 0x5A, rng.randrange(256)]))
        elif op == 2 and b:
            del b[rng.randrange(len(b))]
        else:
            b = b[: rng.randrange(len(b) + 1)]
    return bytes(b)


def fuzz_inputs(env, rng):
    """Per protocol, valid frames to mutate and random byte strings."""
    _, ndl = ndlcom_test_frames(env, random.Random(2))
    ndl = ndlcom_encode(env, ndl)
    ir = env.ir(ROBOT)
    msgs = modrob_test_messages(ir, random.Random(4))
    uart = modrob_encode(env, "uart", msgs)
    eth = modrob_encode(env, "ethernet", msgs, "--module-uuid", uuid_text(bytes(16)), "--max-datagram", "200")
    rmap = RingMap(env.ir(RING)["rings"][0])
    tos = [data_frame(rng, rmap, None, 7)[0], tos_frame("NET_SET", 0, bytes([4, 0, 1, 2, 3])),
           tos_frame("REG_SET", 0, bytes([4]) + rmap.masks([0, 1, 2, 3])), tos_frame("ASYNC", 1, bytes([1]) + bytes(70))]
    for code in range(16):  # every command code with random bodies and a valid CRC
        for n in (0, 1, 2, 5, 33, 70):
            head = bytes([code << 4 | rng.randrange(16)]) + rng.randbytes(n)
            tos.append(head + bytes([crc8_tosnet(head)]))
    return {"ndlcom": ndl, "uart": uart, "ethernet": eth, "tosnet": tos}


def check_no_lua_errors(env):
    rng = random.Random(99)
    inputs = fuzz_inputs(env, rng)
    lua = env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING)

    def cases(frames, join):
        out = [b"", bytes([0x7E]), bytes([0x7D]), bytes([0x5A]), bytes([0x7D, 0x7E])]
        out += [rng.randbytes(rng.randrange(1, 300)) for _ in range(60)]
        for _ in range(240):
            picked = [mutate(rng, rng.choice(frames)) if rng.random() < 0.7 else rng.choice(frames)
                      for _ in range(rng.randrange(1, 4 if join else 2))]
            out.append(b"".join(picked))
        return out

    runs = [
        ("ndlcom USER0", write_pcap(env.path("fuzz-ndlcom-user0.pcap"), LINKTYPE_USER0, cases(inputs["ndlcom"], True))),
        ("ndlcom UDP", udp_pcap(env.path("fuzz-ndlcom-udp.pcap"), [(p, 9, NDLCOM_PORT_IN) for p in cases(inputs["ndlcom"], True)])),
        ("modrob USER1", write_pcap(env.path("fuzz-modrob-user1.pcap"), LINKTYPE_USER1, cases(inputs["uart"], True))),
        ("modrob UDP", udp_pcap(env.path("fuzz-modrob-udp.pcap"), [(p, 9, MODROB_PORT) for p in cases(inputs["ethernet"], False)])),
        ("modrob heuristic", udp_pcap(env.path("fuzz-modrob-heur.pcap"), [(p, 9, 40999) for p in cases(inputs["ethernet"], False)])),
        ("tosnet UDP", udp_pcap(env.path("fuzz-tosnet-udp.pcap"), [(p, 9, TOSNET_PORT) for p in cases(inputs["tosnet"], False)])),
    ]
    for label, pcap in runs:
        try:
            env.tshark_json(lua, pcap)
            env.tshark_json(lua, pcap, "-2")  # two passes: frames dissected again
        except CheckFailed as e:
            raise CheckFailed(f"{label}: {e}") from None


# --- Lua versions --------------------------------------------------------------------------------


def check_lua_syntax(env):
    lua = env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING)
    files = [
        lua,
        env.render("modrob-dicts.lua", *[os.path.join(ROOT, "definitions", "modrob", n)
                                         for n in ("drive.toml", "motion_control.toml")]),
        env.render("mavlink-only.lua", *MAVLINK_DEFS),
        env.render("robot-only.lua", ROBOT),
        env.render("ring-only.lua", RING),
        env.render("fixtures.lua", *FIXTURES),
    ]
    compilers = [c for c in ("luac5.2", "luac5.4") if shutil.which(c)]
    if not compilers:
        raise Skip("neither luac5.2 nor luac5.4 is installed")
    for c in compilers:
        for path in files:
            p = subprocess.run([c, "-p", path], capture_output=True, text=True)
            require(p.returncode == 0, f"{c}: {p.stderr.strip()[:400]}")
    text = open(lua).read()
    for proto in ("ndlcom", "modrob", "tosnet"):
        require(f'Proto.new("{proto}"' in text, f"protocol {proto} missing")
    if len(compilers) < 2:
        raise Skip(f"only {compilers[0]} is installed")


# A stand-in for the parts of Wireshark's Lua API the dissectors use, strict about ranges like
# Wireshark is: it runs the generated file and feeds every protocol's dissector bytes.
MOCK_LUA = r"""
local script, inputs = arg[1], arg[2]
if arg[4] == "without-bit32" then bit32 = nil end
local errors, added, statuses = 0, {}, {}
local function bytes_of(s) local t = {} for i = 1, #s do t[i] = s:byte(i) end return t end
local function le_float(b, at)
  local x = b[at] + b[at + 1] * 256 + b[at + 2] * 65536 + b[at + 3] * 16777216
  local sign = x >= 2147483648 and -1 or 1
  local e = math.floor(x / 8388608) % 256
  local m = x % 8388608
  if e == 255 then return m == 0 and sign * math.huge or 0 / 0 end
  if e == 0 then return sign * m * 2 ^ -149 end
  return sign * (1 + m / 8388608) * 2 ^ (e - 127)
end
local Tvb, Range = {}, {}
Tvb.__index, Range.__index = Tvb, Range
local function new_tvb(b) return setmetatable({ b = b }, Tvb) end
function Tvb:len() return #self.b end
function Tvb:range(off, len)
  off = off or 0
  len = len or (#self.b - off)
  if off < 0 or len < 0 or off + len > #self.b then error("Range is out of bounds") end
  return setmetatable({ t = self, off = off, len = len }, Range)
end
Tvb.__call = Tvb.range
function Tvb:raw(off, len)
  local r = self:range(off, len)
  local out = {}
  for i = 1, r.len do out[i] = string.char(self.b[r.off + i]) end
  return table.concat(out)
end
function Range:uint()
  local v = 0
  for i = self.len, 1, -1 do v = v * 256 + self.t.b[self.off + i] end
  return v
end
function Range:le_uint()
  local v = 0
  for i = self.len, 1, -1 do v = v * 256 + self.t.b[self.off + i] end
  return v
end
function Range:uint_be()
  local v = 0
  for i = 1, self.len do v = v * 256 + self.t.b[self.off + i] end
  return v
end
function Range:le_float() if self.len ~= 4 then error("bad float") end return le_float(self.t.b, self.off + 1) end
function Range:string() return self.t:raw(self.off, self.len) end
function Range:bytes()
  local b = {}
  for i = 1, self.len do b[i] = self.t.b[self.off + i] end
  return setmetatable({ b = b }, ByteArrayMT)
end
function Range:tvb() return new_tvb(self:bytes().b) end
ByteArrayMT = {}
ByteArrayMT.__index = ByteArrayMT
function ByteArrayMT:set_size(n) for i = #self.b + 1, n do self.b[i] = 0 end for i = n + 1, #self.b do self.b[i] = nil end end
function ByteArrayMT:set_index(i, v) if i < 0 or i >= #self.b or v < 0 or v > 255 then error("bad index") end self.b[i + 1] = v end
function ByteArrayMT:get_index(i) return self.b[i + 1] end
function ByteArrayMT:len() return #self.b end
function ByteArrayMT:tvb(name) return new_tvb(self.b) end
ByteArray = { new = function() return setmetatable({ b = {} }, ByteArrayMT) end }
local Item = {}
Item.__index = Item
local function add(self, ...)
  local a = { ... }
  local f = a[1]
  if type(f) == "table" and f.abbrev then
    local r = a[2]
    if getmetatable(r) ~= Range then error("field without a range") end
    if f.size and a[3] == nil and r.len ~= f.size then error("range of " .. r.len .. " bytes for " .. f.abbrev) end
    added[f.abbrev] = (added[f.abbrev] or 0) + 1
    if type(a[3]) == "string" then
      added[f.abbrev .. "=" .. a[3]] = true
      if f.abbrev:find("%.status$") then statuses[a[3]] = (statuses[a[3]] or 0) + 1 end
    end
  end
  return setmetatable({}, Item)
end
Item.add, Item.add_le, Item.add_packet_field = add, add, add
function Item:append_text() return self end
function Item:set_generated() return self end
function Item:set_text() return self end
function Item:add_proto_expert_info(e, text)
  if text and tostring(text):find("Dissector error", 1, true) then
    errors = errors + 1
    io.stderr:write(text, "\n")
  end
  return self
end
local SIZES = { UINT8 = 1, INT8 = 1, UINT16 = 2, INT16 = 2, UINT32 = 4, INT32 = 4, UINT64 = 8, INT64 = 8,
  FLOAT = 4, DOUBLE = 8, GUID = 16 }
ftypes = {}
for k in pairs(SIZES) do ftypes[k] = k end
ftypes.STRING, ftypes.BYTES = "STRING", "BYTES"
base = { DEC = 1, HEX = 2, NONE = 0, ASCII = 0, UNICODE = 0 }
ENC_UTF_8 = 2
expert = { group = setmetatable({}, { __index = function() return 0 end }),
  severity = setmetatable({}, { __index = function() return 0 end }) }
ProtoField = { new = function(name, abbrev, t, vs, b, mask, desc)
  if type(abbrev) ~= "string" or not abbrev:match("^[%w_.%-]+$") then error("bad abbreviation " .. tostring(abbrev)) end
  return { abbrev = abbrev, size = SIZES[t] }
end }
ProtoExpert = { new = function(abbrev) return { expert = abbrev } end }
Pref = { range = function(_, d) return d end, uint = function(_, d) return d end, bool = function(_, d) return d end }
local protos, heuristics = {}, {}
Proto = { new = function(name, desc)
  local p = { name = name, prefs = {} }
  function p.register_heuristic(self, list, fn) heuristics[#heuristics + 1] = fn end
  protos[name] = p
  return p
end }
setmetatable(Proto, { __call = function(_, ...) return Proto.new(...) end })
local tables = {}
DissectorTable = { get = function(name)
  tables[name] = tables[name] or { add = function() end, remove = function() end, add_for_decode_as = function() end }
  return tables[name]
end }
wtap_encaps = { USER0 = 45 }
local chunk = assert(loadfile(script))
chunk()
local pinfo_n = 0
local function pinfo()
  pinfo_n = pinfo_n + 1
  local col = { set = function() end, append = function() end }
  return { number = pinfo_n, visited = false, cols = { protocol = col, info = col } }
end
local count = 0
for line in io.lines(inputs) do
  local name, expect, hex = line:match("^(%S+) (%S+) (%x*)$")
  local s = (hex or ""):gsub("%x%x", function(h) return string.char(tonumber(h, 16)) end)
  local p = protos[name]
  if p == nil then error("no protocol " .. tostring(name)) end
  local tvb = new_tvb(bytes_of(s))
  statuses = {}
  p.dissector(tvb, pinfo(), setmetatable({}, Item))
  if expect == "good" and (not statuses.good or statuses.bad) then
    io.stderr:write(name, ": an intact frame not shown with a good checksum: ", hex, "\n")
    errors = errors + 1
  end
  if name == "modrob" then for _, h in ipairs(heuristics) do h(tvb, pinfo(), setmetatable({}, Item)) end end
  count = count + 1
end
for abbrev in (arg[3] or ""):gmatch("[^,]+") do
  if not added[abbrev] then io.stderr:write("never shown: ", abbrev, "\n") errors = errors + 1 end
end
print(_VERSION, count, errors)
os.exit(errors == 0 and 0 or 1)
"""


def own_blocks(path, out):
    """The NDLCom, ModRob-1 and TosNet parts of a generated file: each is a `do ... end` block at
    the left margin under its banner comment, after the part every dissector shares (from its
    banner to the first block's)."""
    lines = open(path).read().splitlines()
    kept, inside, shared = [], False, False
    for line in lines:
        if line.startswith("-- Shared by every dissector"):
            shared = True
        if line.startswith("-----") or line.startswith("-- MAVLink"):
            shared = False
        if any(line.startswith(f"-- {name} ---") for name in ("NDLCom", "ModRob-1", "TosNet")):
            shared, inside = False, True
        if inside or shared:
            kept.append(line)
            if inside and line == "end":
                inside = False
    require(sum(1 for l in kept if l == "do") == 3, "the three protocol blocks are not all in the file")
    with open(out, "w") as f:
        f.write("\n".join(kept) + "\n")
    return out


def mock_inputs(rng, inputs):
    """Lines `PROTOCOL EXPECT HEX` for the stand-in: the frames (EXPECT `good`: every checksum
    shown must be good), mutations of them and random bytes (EXPECT `-`)."""
    lines = []
    for proto, key in (("ndlcom", "ndlcom"), ("modrob.uart", "uart"), ("modrob", "ethernet"), ("tosnet", "tosnet")):
        frames = inputs[key]
        lines += [f"{proto} good {f.hex()}" for f in frames]
        lines += [f"{proto} - {mutate(rng, rng.choice(frames)).hex()}" for _ in range(150)]
        lines += [f"{proto} - {rng.randbytes(rng.randrange(0, 200)).hex()}" for _ in range(30)]
    return lines


def check_lua_runtimes(env):
    interpreters = [c for c in ("lua5.2", "lua5.3", "lua5.4") if shutil.which(c)]
    if not interpreters:
        raise Skip("no lua5.x interpreter is installed")
    harness = env.path("mock.lua")
    with open(harness, "w") as f:
        f.write(MOCK_LUA)
    rng = random.Random(7)
    ours = own_blocks(env.render("all.lua", *MAVLINK_DEFS, ROBOT, RING), env.path("own-blocks.lua"))
    ir, _, _, ndl, msgs, rings = fixture_frames(env, random.Random(31))
    fixtures = own_blocks(env.render("fixtures.lua", *FIXTURES), env.path("fixture-blocks.lua"))
    fixture_inputs = {
        "ndlcom": ndlcom_encode(env, ndl), "uart": modrob_encode(env, "uart", msgs),
        "ethernet": modrob_encode(env, "ethernet", msgs, "--module-uuid", uuid_text(bytes(16)), "--max-datagram", "300"),
        "tosnet": [f for _, frames, _ in rings for f in frames],
    }
    runs = [
        (ours, mock_inputs(rng, fuzz_inputs(env, rng)),
         "ndlcom.receiver,ndlcom.heartbeat.custom_mode,ndlcom.fcs.status=good,ndlcom.fcs.status=bad,"
         "modrob.variable,modrob.value,modrob.crc.status=good,tosnet.motor_state.position,tosnet.crc.status=good"),
        (fixtures, mock_inputs(rng, fixture_inputs),
         "ndlcom.texts.text,tosnet.arrays.label,tosnet.wide.u64,ndlcom.fcs.status=good,tosnet.crc.status=good"),
    ]
    for n, (lua, lines, required) in enumerate(runs):
        data = env.path(f"mock-inputs-{n}.txt")
        with open(data, "w") as f:
            f.write("\n".join(lines) + "\n")
        variants = [(i, "") for i in interpreters] + [("lua5.2", "without-bit32")] * ("lua5.2" in interpreters)
        for interp, variant in variants:
            p = subprocess.run([interp, harness, lua, data, required, variant], capture_output=True, text=True,
                               timeout=300)
            require(p.returncode == 0,
                    f"{interp} {variant} {os.path.basename(lua)}: {(p.stderr or p.stdout).strip()[:600]}")
    if "lua5.4" not in interpreters or "lua5.2" not in interpreters:
        raise Skip(f"only {', '.join(interpreters)} installed")


CHECKS = [
    ("lua_syntax", check_lua_syntax),
    ("lua_runtimes", check_lua_runtimes),
    ("ndlcom_user0", check_ndlcom_user0),
    ("ndlcom_udp", check_ndlcom_udp),
    ("ndlcom_decode_as_and_prefs", check_ndlcom_decode_as_and_prefs),
    ("ndlcom_real_captures", check_ndlcom_real_captures),
    ("modrob_ethernet", check_modrob_ethernet),
    ("modrob_uart_user1", check_modrob_uart),
    ("modrob_ports_and_heuristic", check_modrob_ports_and_heuristic),
    ("modrob_without_robot", check_modrob_without_robot),
    ("tosnet", check_tosnet),
    ("generator_fixtures", check_fixtures),
    ("no_lua_errors", check_no_lua_errors),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ferrolink", required=True, help="the ferrolink binary")
    ap.add_argument("--workdir", required=True, help="where the Lua, pcaps and tool output go")
    ap.add_argument("--captures", default=os.path.join(ROOT, "..", "shared", "captures"),
                    help="the real MAVLink captures (default ../shared/captures)")
    ap.add_argument("--only", action="append", help="run only this check (repeatable)")
    args = ap.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    env = Env(os.path.abspath(args.ferrolink), os.path.abspath(args.workdir), args.captures)
    passed = failed = 0
    for name, check in CHECKS:
        if args.only and name not in args.only:
            continue
        if not env.tshark and check not in (check_lua_syntax, check_lua_runtimes):
            print(f"skip {name}: tshark is not installed", flush=True)
            continue
        try:
            check(env)
        except Skip as e:
            print(f"skip {name}: {e}", flush=True)
            continue
        except CheckFailed as e:
            print(f"FAIL {name}: {e}", flush=True)
            failed += 1
            continue
        except Exception as e:  # a bug in the check itself is a failure too
            print(f"FAIL {name}: {type(e).__name__}: {e}", flush=True)
            failed += 1
            continue
        print(f"ok   {name}", flush=True)
        passed += 1
    print(f"{passed} passed, {failed} failed")
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
