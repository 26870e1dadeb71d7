#!/usr/bin/env python3
"""The router's web API (`--http`), driven by clients we did not write: `requests` for REST,
`aiohttp` for the WebSocket, raw sockets for hostile clients, and a headless Chromium for the
inspector page. Two pymavlink vehicles feed the router: system 1 in MAVLink 2, system 2 in
MAVLink 1; a pymavlink ground station listens on another endpoint.

Checks:
  tree        GET /v1/mavlink lists both vehicles and the ground station; sub-paths give a message, its status (RFC 3339
              times, a counter, a frequency) and one field; enums, bit masks and text in
              mavlink2rest's forms; MAVLink 1 understood.
  missing     a path that names nothing is a 404 with a JSON error.
  helper      GET /v1/helper/mavlink?name=COMMAND_LONG gives the template; an unknown name 404.
  post        a COMMAND_LONG posted from 255/190 reaches vehicle 1 from 255/190, and is kept
              under vehicles/255/components/190; a body that does not decode is a 400 saying
              why; a huge body is refused with 413.
  ws          a WebSocket with filter=^ATTITUDE$ gets ATTITUDEs of system 1 with their header,
              nothing else; what it sends reaches the vehicle (`Ok(N)` back); it closes at once;
              an invalid filter is a 400.
  slow_ws     a WebSocket client that never reads, while a vehicle sends 3,000 ATTITUDEs a
              second for 6 s: another client and the ground station still get (nearly) every
              one, and /info counts what the stalled client lost.
  hostile     malformed HTTP, and a thousand idle connections held open: the API still answers
              and the router still routes.
  page        the inspector at / loads in Chromium with no console error; the ATTITUDE row's
              value changes as the vehicle sends; ticking roll draws a plot; a screenshot is
              written (--screenshot).
"""

import argparse
import asyncio
import json
import os
import re
import resource
import shutil
import socket
import subprocess
import sys
import threading
import time

sys.dont_write_bytecode = True
os.environ["MAVLINK20"] = "1"

from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v10 import ardupilotmega as v1  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as v2  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
CHECKS = ("tree", "missing", "helper", "post", "ws", "slow_ws", "hostile", "page")
RFC3339 = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?(Z|[+-]\d\d:\d\d)$")


class CheckFailed(Exception):
    pass


class CheckSkipped(Exception):
    pass


def free_port(kind=socket.SOCK_STREAM):
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Vehicle(threading.Thread):
    """A pymavlink vehicle sending telemetry to the router's udpin port: ATTITUDE at `rate` Hz
    (roll a slow sine), and once a second HEARTBEAT, SYS_STATUS, PARAM_VALUE and STATUSTEXT.
    It records every COMMAND_LONG it receives."""

    def __init__(self, port, sysid, mavlink1=False, rate=50):
        super().__init__(daemon=True)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(0.01)
        self.to = ("127.0.0.1", port)
        module = v1 if mavlink1 else v2
        self.mav = module.MAVLink(self, srcSystem=sysid, srcComponent=1)
        self.parser = v2.MAVLink(None)
        self.rate, self.sysid = rate, sysid
        self.commands = []
        self.running = True
        self.sent_attitudes = 0

    def write(self, buf):
        self.sock.sendto(buf, self.to)

    def run(self):
        t0 = time.monotonic()
        next_slow = 0.0
        while self.running:
            now = time.monotonic() - t0
            self.mav.attitude_send(int(now * 1000), 0.5 * __import__("math").sin(now), 0.1, -0.2,
                                   0.01, 0.02, 0.03)
            self.sent_attitudes += 1
            if now >= next_slow:
                next_slow = now + 1
                self.mav.heartbeat_send(2, 3, 128 | 81, 4, 4)
                self.mav.sys_status_send(1 | 2 | 32, 1 | 2, 1, 500, 12000, -1, 80, 0, 0, 0, 0,
                                         0, 0)
                self.mav.param_value_send(b"SURFACE_DEPTH", 1.5, 9, 850, 12)
                self.mav.statustext_send(6, b"ArduCopter V4.5")
            try:
                data, _ = self.sock.recvfrom(4096)
                for m in self.parser.parse_buffer(data) or []:
                    if m.get_type() == "COMMAND_LONG":
                        self.commands.append(m)
            except socket.timeout:
                pass
            except OSError:
                pass
            time.sleep(1.0 / self.rate)


class Setup:
    """The router with a vehicle endpoint, a ground-station endpoint and the web API."""

    def __init__(self, args, name, rate=50):
        self.args = args
        self.vport, self.gport, self.hport = (free_port(socket.SOCK_DGRAM),
                                              free_port(socket.SOCK_DGRAM), free_port())
        self.base = "http://127.0.0.1:%d" % self.hport
        self.log = open(os.path.join(args.workdir, name + ".router.log"), "w")
        self.router = subprocess.Popen(
            [args.router, "mavlink", "router", "udpin://127.0.0.1:%d" % self.vport,
             "udpin://127.0.0.1:%d" % self.gport, "--http", "127.0.0.1:%d" % self.hport],
            stdout=self.log, stderr=subprocess.STDOUT)
        wait_for(lambda: get_ok(self.base + "/info"), 20, "the web API to answer")
        self.vehicles = [Vehicle(self.vport, 1, rate=rate), Vehicle(self.vport, 2, True, rate=5)]
        for v in self.vehicles:
            v.start()
        self.gcs = mavutil.mavlink_connection("udpout:127.0.0.1:%d" % self.gport,
                                              source_system=255, source_component=190)
        self.running = True

        def beat():
            # A udpin peer quiet for 10 s is forgotten: the ground station speaks every second.
            while self.running:
                self.gcs.mav.heartbeat_send(6, 8, 0, 0, 4)
                time.sleep(1)

        threading.Thread(target=beat, daemon=True).start()
        wait_for(lambda: get_ok(self.base + "/v1/mavlink/vehicles/2/components/1/messages/"
                                "HEARTBEAT"), 20, "both vehicles in the tree")
        # A second of telemetry, for the rates.
        time.sleep(1)

    def close(self):
        self.running = False
        for v in self.vehicles:
            v.running = False
        self.router.terminate()
        try:
            self.router.wait(10)
        except subprocess.TimeoutExpired:
            self.router.kill()
        self.log.close()


def get_ok(url):
    import requests
    try:
        return requests.get(url, timeout=2).status_code == 200
    except requests.RequestException:
        return False


def wait_for(predicate, seconds, what):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.05)
    raise CheckFailed("waited %d s for %s" % (seconds, what))


def expect(what, got, want):
    if got != want:
        raise CheckFailed("%s: got %r, expected %r" % (what, got, want))


def check_tree(s):
    import requests
    tree = requests.get(s.base + "/v1/mavlink").json()
    expect("systems", sorted(tree["vehicles"]), ["1", "2", "255"])
    path = s.base + "/v1/mavlink/vehicles/1/components/1/messages/"
    att = requests.get(path + "ATTITUDE").json()
    expect("ATTITUDE keys", sorted(att), ["message", "status"])
    expect("ATTITUDE type", att["message"]["type"], "ATTITUDE")
    expect("pitch", att["message"]["pitch"], 0.10000000149011612)
    t = att["status"]["time"]
    for k in ("first_update", "last_update"):
        if not RFC3339.match(t[k]):
            raise CheckFailed("%s is not RFC 3339: %r" % (k, t[k]))
    if t["counter"] < 10 or not t["frequency"] > 5:
        raise CheckFailed("ATTITUDE status: %r" % t)
    field = requests.get(path + "ATTITUDE/message/yaw")
    expect("one field", field.json(), -0.20000000298023224)
    hb = requests.get(path + "HEARTBEAT/message").json()
    expect("HEARTBEAT", hb, {
        "type": "HEARTBEAT", "custom_mode": 4, "mavtype": {"type": "MAV_TYPE_QUADROTOR"},
        "autopilot": {"type": "MAV_AUTOPILOT_ARDUPILOTMEGA"},
        "base_mode": "MAV_MODE_FLAG_SAFETY_ARMED | MAV_MODE_FLAG_MANUAL_INPUT_ENABLED | "
                     "MAV_MODE_FLAG_STABILIZE_ENABLED | MAV_MODE_FLAG_CUSTOM_MODE_ENABLED",
        "system_status": {"type": "MAV_STATE_ACTIVE"}, "mavlink_version": 3})
    pv = requests.get(path + "PARAM_VALUE/message").json()
    expect("PARAM_VALUE", (pv["param_id"], pv["param_value"], pv["param_type"]),
           ("SURFACE_DEPTH", 1.5, {"type": "MAV_PARAM_TYPE_REAL32"}))
    ss = requests.get(path + "SYS_STATUS/message/onboard_control_sensors_present").json()
    expect("a bit mask", ss, "MAV_SYS_STATUS_SENSOR_3D_GYRO | MAV_SYS_STATUS_SENSOR_3D_ACCEL | "
           "MAV_SYS_STATUS_SENSOR_GPS")
    text = requests.get(path + "STATUSTEXT/message/text").json()
    expect("text", text, "ArduCopter V4.5")
    v1_att = requests.get(s.base + "/v1/mavlink/vehicles/2/components/1/messages/ATTITUDE/message")
    expect("MAVLink 1's ATTITUDE", v1_att.json()["pitch"], 0.10000000149011612)
    same = requests.get(s.base + "/mavlink/vehicles/1/components/1/messages/ATTITUDE/message/pitch")
    expect("without /v1", same.json(), 0.10000000149011612)


def check_missing(s):
    import requests
    for path in ("/v1/mavlink/vehicles/7", "/v1/mavlink/vehicles/1/components/9",
                 "/v1/mavlink/vehicles/1/components/1/messages/GPS_RAW_INT",
                 "/v1/mavlink/vehicles/1/components/1/messages/ATTITUDE/message/nope",
                 "/v1/mavlink/nothing"):
        r = requests.get(s.base + path)
        expect(path, r.status_code, 404)
        if "error" not in r.json():
            raise CheckFailed("%s: no JSON error: %r" % (path, r.text))


def check_helper(s):
    import requests
    r = requests.get(s.base + "/v1/helper/mavlink", params={"name": "COMMAND_LONG"}).json()
    expect("header", r["header"], {"system_id": 255, "component_id": 0, "sequence": 0})
    expect("command", r["message"]["command"], {"type": "MAV_CMD_NAV_WAYPOINT"})
    expect("unknown", requests.get(s.base + "/v1/helper/mavlink?name=NOPE").status_code, 404)


def command(param1):
    return {"header": {"system_id": 255, "component_id": 190, "sequence": 0},
            "message": {"type": "COMMAND_LONG", "param1": param1, "param2": 0.0, "param3": 0.0,
                        "param4": 0.0, "param5": 0.0, "param6": 0.0, "param7": 0.0,
                        "command": {"type": "MAV_CMD_COMPONENT_ARM_DISARM"},
                        "target_system": 1, "target_component": 1, "confirmation": 0}}


def check_post(s):
    import requests
    r = requests.post(s.base + "/v1/mavlink", json=command(1.0))
    expect("POST status", r.status_code, 200)
    vehicle = s.vehicles[0]
    wait_for(lambda: any(c.param1 == 1.0 for c in vehicle.commands), 5,
             "vehicle 1 to get the posted command")
    got = [c for c in vehicle.commands if c.param1 == 1.0][0]
    expect("sender", (got.get_srcSystem(), got.get_srcComponent(), got.command),
           (255, 190, 400))
    if any(c for c in s.vehicles[1].commands):
        raise CheckFailed("vehicle 2 got a command for vehicle 1")
    kept = requests.get(s.base + "/v1/mavlink/vehicles/255/components/190/messages/COMMAND_LONG/"
                        "message/command").json()
    expect("kept", kept, {"type": "MAV_CMD_COMPONENT_ARM_DISARM"})
    for body in (b"{not json", json.dumps({"message": {"type": "NOPE"}}).encode(),
                 json.dumps({"header": {}, "message": {"type": "ATTITUDE", "roll": "x"}}).encode()):
        r = requests.post(s.base + "/v1/mavlink", data=body)
        expect("bad POST %r" % body[:30], r.status_code, 400)
        if not r.json().get("error"):
            raise CheckFailed("a 400 without a reason: %r" % r.text)
    r = requests.post(s.base + "/v1/mavlink", data=b"x" * (10 << 20))
    expect("a 10 MB body", r.status_code, 413)


def check_ws(s):
    import aiohttp

    async def run():
        async with aiohttp.ClientSession() as session:
            async with session.get(s.base + "/v1/ws/mavlink?filter=[") as r:
                expect("invalid filter", r.status, 400)
            ws = await session.ws_connect(s.base + "/v1/ws/mavlink?filter=^ATTITUDE$")
            got = []
            deadline = time.monotonic() + 2
            while time.monotonic() < deadline:
                msg = await ws.receive(timeout=2)
                got.append(json.loads(msg.data))
            names = {g["message"]["type"] for g in got}
            expect("names", names, {"ATTITUDE"})
            if not any(g["header"]["system_id"] == 1 for g in got) or len(got) < 20:
                raise CheckFailed("too few ATTITUDEs of system 1: %d" % len(got))
            if set(got[0]["header"]) != {"system_id", "component_id", "sequence"}:
                raise CheckFailed("header: %r" % got[0]["header"])
            await ws.send_str(json.dumps(command(7.0)))
            while True:
                msg = await ws.receive(timeout=2)
                if msg.data.startswith("Ok("):
                    break
                if msg.data.startswith("Err"):
                    raise CheckFailed("sending over the WebSocket: %s" % msg.data)
            t0 = time.monotonic()
            await ws.close()
            took = time.monotonic() - t0
            if took > 1:
                raise CheckFailed("closing took %.1f s" % took)

    asyncio.run(run())
    wait_for(lambda: any(c.param1 == 7.0 for c in s.vehicles[0].commands), 5,
             "the command sent over the WebSocket")


class Flood(threading.Thread):
    """System 3 sending ATTITUDE at `rate` a second, in bursts of 30."""

    def __init__(self, port, rate, seconds):
        super().__init__(daemon=True)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.to = ("127.0.0.1", port)
        self.mav = v2.MAVLink(self, srcSystem=3, srcComponent=1)
        self.rate, self.seconds, self.sent = rate, seconds, 0

    def write(self, buf):
        self.sock.sendto(buf, self.to)

    def run(self):
        t0 = time.monotonic()
        while time.monotonic() - t0 < self.seconds:
            for _ in range(30):
                self.mav.attitude_send(self.sent, 0.1, 0.2, 0.3, 0, 0, 0)
                self.sent += 1
            ahead = self.sent / self.rate - (time.monotonic() - t0)
            if ahead > 0:
                time.sleep(ahead)


def check_slow_ws(s):
    import aiohttp
    import requests
    # A client that upgrades and then never reads, with a tiny receive window.
    stalled = socket.socket()
    stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    stalled.connect(("127.0.0.1", s.hport))
    stalled.sendall(b"GET /v1/ws/mavlink HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\n"
                    b"Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                    b"Sec-WebSocket-Version: 13\r\n\r\n")
    gcs_counts = {"n": 0}
    flood = Flood(s.vport, 3000, 6)

    def gcs_reader(stop):
        while not stop.is_set():
            m = s.gcs.recv_match(type="ATTITUDE", blocking=True, timeout=0.2)
            if m is not None and m.get_srcSystem() == 3:
                gcs_counts["n"] += 1

    async def run():
        async with aiohttp.ClientSession() as session:
            ws = await session.ws_connect(s.base + "/v1/ws/mavlink?filter=^ATTITUDE$")
            flood.start()
            got = 0
            deadline = time.monotonic() + flood.seconds + 3
            while time.monotonic() < deadline:
                try:
                    msg = await ws.receive(timeout=1)
                except asyncio.TimeoutError:
                    continue
                if json.loads(msg.data)["header"]["system_id"] == 3:
                    got += 1
            await ws.close()
            return got, flood.sent

    stop = threading.Event()
    reader = threading.Thread(target=gcs_reader, args=(stop,), daemon=True)
    reader.start()
    got, sent = asyncio.run(run())
    stop.set()
    reader.join()
    stalled.close()
    if got < sent * 0.9:
        raise CheckFailed("the reading client got %d of %d ATTITUDEs" % (got, sent))
    if gcs_counts["n"] < sent * 0.9:
        raise CheckFailed("the ground station got %d of %d ATTITUDEs" % (gcs_counts["n"], sent))
    info = requests.get(s.base + "/info").json()["ferrolink"]
    if info["ws_dropped"] == 0:
        raise CheckFailed("the stalled client lost nothing? %r" % info)


def check_hostile(s):
    import requests
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (max(soft, min(hard, 4096)), hard))
    garbage = socket.create_connection(("127.0.0.1", s.hport))
    garbage.sendall(b"\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03" + os.urandom(600) + b"\r\n\r\n")
    garbage.settimeout(5)
    try:
        reply = garbage.recv(100)
    except OSError:
        reply = b""
    garbage.close()
    if reply and not reply.startswith(b"HTTP/1.1 4"):
        raise CheckFailed("malformed HTTP answered %r" % reply[:40])
    idle = []
    for _ in range(1000):
        idle.append(socket.create_connection(("127.0.0.1", s.hport)))
    try:
        t0 = time.monotonic()
        r = requests.get(s.base + "/v1/mavlink/vehicles/1/components/1/messages/ATTITUDE",
                         timeout=5)
        expect("with 1000 idle connections", r.status_code, 200)
        before = s.gcs.recv_match(type="ATTITUDE", blocking=True, timeout=2)
        if before is None:
            raise CheckFailed("the router stopped routing")
        if time.monotonic() - t0 > 5:
            raise CheckFailed("the API answered slowly")
    finally:
        for c in idle:
            c.close()


def check_page(s):
    sys.path.insert(0, os.path.join(HERE, "..", "docs"))
    from browser import Browser  # noqa: E402
    binary = s.args.chromium or shutil.which("chromium") or shutil.which("chromium-browser")
    if not binary:
        raise CheckSkipped("no Chromium found (give --chromium PATH, or install chromium)")
    b = Browser(binary, s.args.workdir)
    try:
        tab = b.tab()
        tab.goto(s.base + "/")
        row = "document.getElementById('row-1-1-ATTITUDE')"
        tab.wait_js(row + " && " + row + ".cells[3].textContent.length > 0", 15)
        first = tab.js(row + ".cells[3].textContent")
        tab.wait_js(row + ".cells[3].textContent !== " + json.dumps(first), 10)
        tab.js(row + ".click(), true")
        tab.wait_js("document.querySelector('#fields tr[data-field=roll] input') !== null", 5)
        tab.js("(() => { const i = document.querySelector('#fields tr[data-field=roll] input');"
               " i.checked = true; i.dispatchEvent(new Event('change')); return true; })()")
        tab.wait_js("Number(document.getElementById('plot').dataset.points) > 20", 15)
        inked = tab.js("(() => { const c = document.getElementById('plot');"
                       " const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
                       " let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i]) n++;"
                       " return n; })()")
        if inked < 200:
            raise CheckFailed("the plot drew %d pixels" % inked)
        links = tab.wait_js("document.querySelectorAll('#links tbody tr').length", 5)
        if links < 3:
            raise CheckFailed("router links shown: %d" % links)
        b.pump(1.0)
        errors = b.errors()
        if errors:
            raise CheckFailed("console errors: %r" % errors[:5])
        shot = s.args.screenshot or os.path.join(s.args.workdir, "inspector.png")
        tab.screenshot(shot)
    finally:
        b.close()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--router")
    ap.add_argument("--dialect-dir")
    ap.add_argument("--workdir")
    ap.add_argument("--only", action="append", default=[])
    ap.add_argument("--chromium")
    ap.add_argument("--screenshot")
    args = ap.parse_args()
    try:
        import aiohttp  # noqa: F401
        import requests  # noqa: F401
    except ImportError:
        for name in CHECKS:
            print("skip %s: the requests and aiohttp packages are missing" % name, flush=True)
        print("0 passed, 0 failed", flush=True)
        return 0
    passed = failed = 0
    s = Setup(args, "web")
    try:
        for name in CHECKS:
            if args.only and name not in args.only:
                continue
            try:
                globals()["check_" + name](s)
                print("ok   %s" % name, flush=True)
                passed += 1
            except CheckSkipped as e:
                print("skip %s: %s" % (name, e), flush=True)
            except Exception as e:  # noqa: BLE001 - every failure is reported, the run goes on
                print("FAIL %s: %s" % (name, e), flush=True)
                failed += 1
    finally:
        s.close()
    print("%d passed, %d failed" % (passed, failed), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
