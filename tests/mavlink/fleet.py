#!/usr/bin/env python3
"""Two `ferrolink mavlink router`s joined only by Zenoh, with real peers on both sides.

Usage:
    fleet.py --router BIN --dialect-dir DIR --workdir DIR [--only NAME]...

Router A listens for Zenoh on loopback, router B connects to it (peer mode). Behind each
router's udpin endpoint runs its own pymavlink vehicle (tests/mavlink/vehicle.py): system 1 on
A, system 2 on B. Checks (each prints `ok   NAME`, `FAIL NAME: detail` or `skip NAME: why`;
the last line is `N passed, M failed`; the status is 0 only if nothing failed):

  command_raw     encoding=raw: a pymavlink ground station (255/190) on router A's udpin
                  sends COMMAND_LONG to system 2 and gets exactly one COMMAND_ACK from it,
                  and vehicle 2 acknowledged exactly one command; the same for system 1,
                  which sits on the ground station's own router.
  subscriber_raw  A subscriber from the Python `eclipse-zenoh` package, joined to router A,
                  gets HEARTBEAT samples of both vehicles on
                  <prefix>/mavlink/<sysid>/1/HEARTBEAT and the ground station's on
                  <prefix>/mavlink/255/190/HEARTBEAT; every sample is one frame pymavlink
                  parses (CRC checked), on the key its source and type name; a frame of
                  an id no dialect has arrives byte for byte on .../UNKNOWN_60000.
  tx_put          A put of a COMMAND_LONG as JSON on <prefix>/mavlink/2/1/tx (the message
                  alone, target from the key) and one as a raw frame reach vehicle 2 exactly
                  once each; its two ACKs appear on <prefix>/mavlink/2/1/COMMAND_ACK.
  fleet           `ferrolink mavlink fleet --json` lists both routers, each with the Zenoh
                  link and its own vehicle on its udpin link.
  command_json    encoding=json on both routers: the subscriber gets
                  {"sysid":2,"compid":1,"seq":..,"msg":{"mavpackettype":"HEARTBEAT",...}}
                  objects, and the ground station's command to system 2 (re-encoded from JSON
                  on the way) is acknowledged exactly once.
  netns           command_raw with each router in a network namespace of its own, joined by
                  a veth pair; skipped where namespaces cannot be made (no root, no `ip`).
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import threading
import time
import uuid

sys.dont_write_bytecode = True
os.environ["MAVLINK20"] = "1"

from pymavlink import mavutil  # noqa: E402
from ports import free_port  # noqa: E402

HOST = "127.0.0.1"
HERE = os.path.dirname(os.path.abspath(__file__))
CHECKS = ("command_raw", "subscriber_raw", "tx_put", "fleet", "command_json", "netns")
CMD_A = 511   # MAV_CMD_SET_MESSAGE_INTERVAL: any command the vehicle acknowledges
CMD_B = 512


class CheckFailed(Exception):
    pass


class CheckSkipped(Exception):
    pass


class Proc:
    """A helper process whose output goes to a log file."""

    def __init__(self, cmd, log, prefix=()):
        self.log = log
        self.out = open(log, "w")
        self.p = subprocess.Popen(list(prefix) + cmd, stdin=subprocess.DEVNULL,
                                  stdout=self.out, stderr=subprocess.STDOUT)

    def text(self):
        self.out.flush()
        with open(self.log, errors="replace") as f:
            return f.read()

    def wait_for(self, needle, timeout):
        deadline = time.time() + timeout
        while time.time() < deadline:
            if needle in self.text():
                return True
            if self.p.poll() is not None:
                return needle in self.text()
            time.sleep(0.05)
        return False

    def stop(self):
        if self.p.poll() is None:
            self.p.terminate()
            try:
                self.p.wait(10)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
        self.out.close()
        return self.p.returncode


class Fleet:
    """Routers A and B joined by Zenoh, a vehicle behind each, a ground station on A."""

    def __init__(self, args, name, encoding="raw", netns=None):
        self.args, self.name = args, name
        self.prefix = "ft" + uuid.uuid4().hex[:10]
        self.dir = os.path.join(args.workdir, name)
        os.makedirs(self.dir, exist_ok=True)
        ns_a, ns_b = netns or (None, None)
        self.host_a = "10.77.0.1" if netns else HOST
        self.zport = free_port()
        self.udp_a, self.udp_b = free_port(), free_port()
        dialect = os.path.join(args.dialect_dir, "common.xml")
        zenoh_a = "zenoh://?mode=peer&listen=tcp/%s:%d&encoding=%s&prefix=%s" % (
            self.host_a, self.zport, encoding, self.prefix)
        zenoh_b = "zenoh://?mode=peer&connect=tcp/%s:%d&encoding=%s&prefix=%s" % (
            self.host_a, self.zport, encoding, self.prefix)
        self.zenoh_a = zenoh_a
        inside = lambda ns: ("ip", "netns", "exec", ns) if ns else ()
        self.procs = []
        self.router_a = self.start([args.router, "mavlink", "router", "--dialect", dialect,
                                    "--run-for", "120", "udpin://%s:%d" % (HOST, self.udp_a),
                                    zenoh_a], "router_a.log", inside(ns_a))
        self.router_b = self.start([args.router, "mavlink", "router", "--dialect", dialect,
                                    "--run-for", "120", "udpin://%s:%d" % (HOST, self.udp_b),
                                    zenoh_b], "router_b.log", inside(ns_b))
        for r in (self.router_a, self.router_b):
            if not r.wait_for("ready", 20):
                raise CheckFailed("a router did not get ready: %s" % r.text()[-400:])
        vehicle = [sys.executable, os.path.join(HERE, "vehicle.py"), "--seconds", "60"]
        self.vehicle_a = self.start(vehicle + ["udpout:%s:%d" % (HOST, self.udp_a),
                                               "--sysid", "1"], "vehicle1.log", inside(ns_a))
        self.vehicle_b = self.start(vehicle + ["udpout:%s:%d" % (HOST, self.udp_b),
                                               "--sysid", "2"], "vehicle2.log", inside(ns_b))
        self.ns_a = ns_a

    def start(self, cmd, log, prefix=()):
        p = Proc(cmd, os.path.join(self.dir, log), prefix)
        self.procs.append(p)
        return p

    def gcs(self):
        """A pymavlink ground station on router A that has said hello."""
        if self.ns_a:
            raise CheckFailed("the ground station runs in the root namespace only")
        m = mavutil.mavlink_connection("udpout:%s:%d" % (HOST, self.udp_a),
                                       source_system=255, source_component=190,
                                       dialect="common")
        m.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                             mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        return m

    def wait_for_system(self, m, sysid, timeout=30):
        """Heartbeats until system `sysid` was heard (so both routers know the way). The
        wait covers two routers, two Python vehicles and a Zenoh connection starting on a
        machine that runs other tests beside them (a QEMU firmware among them)."""
        deadline = time.time() + timeout
        heard = set()
        while time.time() < deadline:
            m.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                 mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            msg = m.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
            if msg is not None:
                heard.add(msg.get_srcSystem())
                if msg.get_srcSystem() == sysid:
                    return
        logs = "; ".join("%s: %s" % (os.path.basename(p.log), p.text()[-300:].strip())
                         for p in self.procs)
        raise CheckFailed("no HEARTBEAT of system %d reached the ground station in %d s "
                          "(heard %s); %s" % (sysid, timeout, sorted(heard), logs))

    def stop(self):
        for p in reversed(self.procs):
            p.stop()


def command_once(fleet, m, sysid, command):
    """Sends `command` to `sysid`; exactly one ACK must come back within 3 s."""
    m.mav.command_long_send(sysid, 1, command, 0, 0, 0, 0, 0, 0, 0, 0)
    acks = []
    deadline = time.time() + 3
    while time.time() < deadline:
        msg = m.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.2)
        if msg is not None and msg.get_srcSystem() == sysid and msg.command == command:
            acks.append(msg)
    if len(acks) != 1:
        raise CheckFailed("%d COMMAND_ACKs of command %d from system %d, expected 1"
                          % (len(acks), command, sysid))


def acknowledged(vehicle, command):
    return vehicle.text().count("command %d from" % command)


def check_commands(fleet):
    m = fleet.gcs()
    fleet.wait_for_system(m, 2)
    fleet.wait_for_system(m, 1)
    command_once(fleet, m, 2, CMD_A)
    command_once(fleet, m, 1, CMD_B)
    time.sleep(0.3)
    if acknowledged(fleet.vehicle_b, CMD_A) != 1:
        raise CheckFailed("vehicle 2 acknowledged command %d %d times: %s"
                          % (CMD_A, acknowledged(fleet.vehicle_b, CMD_A),
                             fleet.vehicle_b.text()[-300:]))
    if acknowledged(fleet.vehicle_a, CMD_B) != 1 or acknowledged(fleet.vehicle_b, CMD_B):
        raise CheckFailed("command %d went elsewhere than vehicle 1 alone" % CMD_B)
    return m


def zenoh_session(fleet):
    import zenoh
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps(["tcp/%s:%d" % (fleet.host_a, fleet.zport)]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(conf)


def subscribe(fleet, session, seconds, gcs=None, extra=None):
    """(key, payload bytes) of every sample under <prefix>/mavlink/** for `seconds`, while
    `gcs` (if any) sends a heartbeat, and the bytes `extra`, every 0.5 s."""
    samples = []
    lock = threading.Lock()

    def on_sample(sample):
        with lock:
            samples.append((str(sample.key_expr), bytes(sample.payload.to_bytes())))

    sub = session.declare_subscriber("%s/mavlink/**" % fleet.prefix, on_sample)
    deadline = time.time() + seconds
    while time.time() < deadline:
        if gcs is not None:
            gcs.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                   mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            if extra is not None:
                gcs.write(extra)
        time.sleep(0.5)
    sub.undeclare()
    with lock:
        return list(samples)


def check_command_raw(args):
    fleet = Fleet(args, "command_raw")
    try:
        check_commands(fleet)
    finally:
        fleet.stop()


def need_zenoh():
    try:
        import zenoh
        zenoh.Config  # a folder named zenoh on the path is not the package
    except (ImportError, AttributeError):
        raise CheckSkipped("the eclipse-zenoh package is missing")


def check_subscriber_raw(args):
    need_zenoh()
    fleet = Fleet(args, "subscriber_raw")
    try:
        m = fleet.gcs()
        fleet.wait_for_system(m, 2)
        # A frame of an id no dialect has: forwarded as a broadcast, put on UNKNOWN_<id>.
        unknown = bytes([0xFD, 3, 0, 0, 7, 255, 190, 0x60, 0xEA, 0x00, 1, 2, 3, 0x12, 0x34])
        with zenoh_session(fleet) as session:
            samples = subscribe(fleet, session, 3.0, m, extra=unknown)
        unknown_key = "%s/mavlink/255/190/UNKNOWN_60000" % fleet.prefix
        got = [p for k, p in samples if k == unknown_key]
        samples = [(k, p) for k, p in samples if k != unknown_key]
        if got[:1] != [unknown]:
            raise CheckFailed("the unknown id's frame on %s: %r" % (unknown_key, got[:1]))
        mav = mavutil.mavlink.MAVLink(None)
        seen = {}
        for key, payload in samples:
            parsed = mav.parse_buffer(payload) or []
            if len(parsed) != 1:
                raise CheckFailed("sample on %s is not one frame: %r" % (key, payload[:20]))
            msg = parsed[0]
            want = "%s/mavlink/%d/%d/%s" % (fleet.prefix, msg.get_srcSystem(),
                                            msg.get_srcComponent(), msg.get_type())
            if key != want:
                raise CheckFailed("frame %s on key %s" % (want, key))
            seen[want] = seen.get(want, 0) + 1
        for sysid in (1, 2):
            k = "%s/mavlink/%d/1/HEARTBEAT" % (fleet.prefix, sysid)
            if seen.get(k, 0) < 2:
                raise CheckFailed("%d samples on %s in 3 s: %s" % (seen.get(k, 0), k, seen))
        if not any("/255/190/" in k for k in seen):
            raise CheckFailed("the ground station's heartbeats were not published: %s" % seen)
    finally:
        fleet.stop()


def check_tx_put(args):
    need_zenoh()
    fleet = Fleet(args, "tx_put")
    try:
        m = fleet.gcs()
        fleet.wait_for_system(m, 2)
        with zenoh_session(fleet) as session:
            acks = []
            sub = session.declare_subscriber(
                "%s/mavlink/2/1/COMMAND_ACK" % fleet.prefix,
                lambda s: acks.append(bytes(s.payload.to_bytes())))
            time.sleep(1.0)
            key = "%s/mavlink/2/1/tx" % fleet.prefix
            session.put(key, json.dumps({"mavpackettype": "COMMAND_LONG", "command": CMD_A}))
            raw = mavutil.mavlink.MAVLink(None, srcSystem=250, srcComponent=191)
            frame = raw.command_long_encode(2, 1, CMD_B, 0, 0, 0, 0, 0, 0, 0, 0).pack(raw)
            session.put(key, bytes(frame))
            time.sleep(2.0)
            sub.undeclare()
        for cmd in (CMD_A, CMD_B):
            if acknowledged(fleet.vehicle_b, cmd) != 1:
                raise CheckFailed("vehicle 2 acknowledged command %d %d times"
                                  % (cmd, acknowledged(fleet.vehicle_b, cmd)))
        if acknowledged(fleet.vehicle_a, CMD_A) or acknowledged(fleet.vehicle_a, CMD_B):
            raise CheckFailed("vehicle 1 got a command for vehicle 2")
        mav = mavutil.mavlink.MAVLink(None)
        got = sorted(mav.parse_buffer(a)[0].command for a in acks)
        if got != [CMD_A, CMD_B]:
            raise CheckFailed("ACKs on Zenoh for commands %s, expected [%d, %d]"
                              % (got, CMD_A, CMD_B))
    finally:
        fleet.stop()


def check_fleet(args):
    fleet = Fleet(args, "fleet")
    try:
        m = fleet.gcs()
        fleet.wait_for_system(m, 2)
        fleet.wait_for_system(m, 1)
        uri = "zenoh://?mode=peer&connect=tcp/%s:%d&prefix=%s" % (HOST, fleet.zport, fleet.prefix)
        out = subprocess.run([args.router, "mavlink", "fleet", "--json", "--timeout", "2", uri],
                             capture_output=True, text=True, timeout=30)
        if out.returncode != 0:
            raise CheckFailed("fleet failed: %s" % out.stderr[-400:])
        routers = [json.loads(line) for line in out.stdout.splitlines() if line.strip()]
        if len(routers) != 2:
            raise CheckFailed("%d routers listed: %s" % (len(routers), out.stdout))
        for sysid, port in ((1, fleet.udp_a), (2, fleet.udp_b)):
            local = "udpin://%s:%d" % (HOST, port)
            owners = [r for r in routers
                      if any(s["sysid"] == sysid and s["link"].startswith(local)
                             for s in r["systems"])]
            if len(owners) != 1:
                raise CheckFailed("system %d on %s in %d listings: %s"
                                  % (sysid, local, len(owners), out.stdout))
            if not any(link.startswith("zenoh://") for link in owners[0]["links"]):
                raise CheckFailed("no Zenoh link listed: %s" % owners[0])
    finally:
        fleet.stop()


def check_command_json(args):
    need_zenoh()
    fleet = Fleet(args, "command_json", encoding="json")
    try:
        check_commands(fleet)
        with zenoh_session(fleet) as session:
            samples = subscribe(fleet, session, 2.5)
        beats = [json.loads(p) for k, p in samples
                 if k == "%s/mavlink/2/1/HEARTBEAT" % fleet.prefix]
        if not beats:
            raise CheckFailed("no JSON heartbeat of system 2: %s" % samples[:3])
        b = beats[0]
        if (b.get("sysid"), b.get("compid"), b["msg"].get("mavpackettype")) != (2, 1, "HEARTBEAT") \
                or "seq" not in b or b["msg"].get("type") != mavutil.mavlink.MAV_TYPE_QUADROTOR:
            raise CheckFailed("unexpected JSON: %s" % b)
    finally:
        fleet.stop()


def check_netns(args):
    if os.geteuid() != 0 or shutil.which("ip") is None:
        raise CheckSkipped("network namespaces need root and iproute2")
    tag = uuid.uuid4().hex[:6]
    ns = ("fla" + tag, "flb" + tag)
    veth = ("vfa" + tag, "vfb" + tag)

    def ip(*a):
        return subprocess.run(["ip"] + list(a), capture_output=True, text=True)

    made = []
    try:
        for n in ns:
            if ip("netns", "add", n).returncode != 0:
                raise CheckSkipped("cannot create network namespaces here")
            made.append(n)
        steps = [
            ("link", "add", veth[0], "netns", ns[0], "type", "veth", "peer", "name", veth[1],
             "netns", ns[1]),
            ("-n", ns[0], "addr", "add", "10.77.0.1/24", "dev", veth[0]),
            ("-n", ns[1], "addr", "add", "10.77.0.2/24", "dev", veth[1]),
            ("-n", ns[0], "link", "set", veth[0], "up"),
            ("-n", ns[1], "link", "set", veth[1], "up"),
            ("-n", ns[0], "link", "set", "lo", "up"),
            ("-n", ns[1], "link", "set", "lo", "up"),
        ]
        for step in steps:
            r = ip(*step)
            if r.returncode != 0:
                raise CheckSkipped("cannot wire namespaces: ip %s: %s"
                                   % (" ".join(step), r.stderr.strip()))
        fleet = Fleet(args, "netns", netns=ns)
        try:
            # The ground station runs inside A's namespace, through a helper.
            gcs = subprocess.run(
                ["ip", "netns", "exec", ns[0], sys.executable, os.path.abspath(__file__),
                 "--role", "gcs", "--port", str(fleet.udp_a)],
                capture_output=True, text=True, timeout=60)
            if gcs.returncode != 0 or "commands ok" not in gcs.stdout:
                raise CheckFailed("ground station in namespace A: %s %s"
                                  % (gcs.stdout[-300:], gcs.stderr[-300:]))
            if acknowledged(fleet.vehicle_b, CMD_A) != 1:
                raise CheckFailed("vehicle 2 acknowledged command %d %d times"
                                  % (CMD_A, acknowledged(fleet.vehicle_b, CMD_A)))
        finally:
            fleet.stop()
    finally:
        for n in made:
            ip("netns", "del", n)


def role_gcs(port):
    """The ground station of `netns`, run inside namespace A."""

    class Stub:
        pass

    f = Stub()
    f.udp_a, f.ns_a = port, None
    m = Fleet.gcs(f)
    Fleet.wait_for_system(f, m, 2)
    command_once(f, m, 2, CMD_A)
    print("commands ok", flush=True)
    return 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--router")
    ap.add_argument("--dialect-dir")
    ap.add_argument("--workdir")
    ap.add_argument("--only", action="append", default=[])
    ap.add_argument("--role")
    ap.add_argument("--port", type=int)
    args = ap.parse_args()
    if args.role == "gcs":
        return role_gcs(args.port)
    passed = failed = 0
    for name in CHECKS:
        if args.only and name not in args.only:
            continue
        try:
            globals()["check_" + name](args)
            print("ok   %s" % name, flush=True)
            passed += 1
        except CheckSkipped as e:
            print("skip %s: %s" % (name, e), flush=True)
        except Exception as e:  # noqa: BLE001 - every failure is reported, the run goes on
            print("FAIL %s: %s" % (name, e), flush=True)
            failed += 1
    print("%d passed, %d failed" % (passed, failed), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
