#!/usr/bin/env python3
"""The router on a shared network: broadcast and multicast across network namespaces.

Each host is a network namespace, all joined by one bridge (in a namespace of its own), so that
broadcasts and multicast cross real interfaces between processes that share no address. The
vehicles and ground stations are pymavlink nodes; nothing leaves this machine.

Checks:
  bcast_out   the router's udpbcast://10.78.0.255:PORT reaches two pymavlink `udpin:` vehicles
              on other hosts; each answers the router directly, and a ground station on the
              router's host commands vehicle 1 and gets its acknowledgement. Each vehicle gets
              each frame once.
  bcast_in    a pymavlink `udpbcast:` vehicle on another host broadcasts to the router's
              udpin; the router answers it directly, and a ground station commands it.
  mcast6      the same over IPv6 (ff15::1:5): pymavlink has no IPv6 multicast, so its MAVLink
              codec runs on a socket that joins the group.
  mcast       two pymavlink `mcast:` vehicles on two hosts and the router's
              udpmcast://239.255.145.50:PORT?iface=...: two ground stations (systems 201 and
              202) each command their own vehicle and get its acknowledgement alone; each
              vehicle gets each command once; the router's own frames never come back to it.

Skipped where namespaces cannot be made (no root, no `ip`).
"""

import argparse
import json
import os
import shutil
import socket
import struct
import subprocess
import sys
import time
import uuid

sys.dont_write_bytecode = True
os.environ["MAVLINK20"] = "1"

from pymavlink import mavutil  # noqa: E402

CHECKS = ("bcast_out", "bcast_in", "mcast", "mcast6")
SUBNET = "10.78.0"
COMMAND = 511  # MAV_CMD_SET_MESSAGE_INTERVAL: any command a vehicle acknowledges
SECONDS = 6


class CheckFailed(Exception):
    pass


class CheckSkipped(Exception):
    pass


def ip(*a):
    return subprocess.run(["ip"] + list(a), capture_output=True, text=True)


class Lan:
    """Hosts (network namespaces) on one bridge: host i has address SUBNET.(i + 1)."""

    def __init__(self, hosts):
        if os.geteuid() != 0 or shutil.which("ip") is None:
            raise CheckSkipped("network namespaces need root and iproute2")
        tag = uuid.uuid4().hex[:6]
        self.bridge = "flbr" + tag
        self.hosts = ["flh%d%s" % (i, tag) for i in range(hosts)]
        self.ifaces = ["vh%d%s" % (i, tag) for i in range(hosts)]
        self.made = []
        for n in [self.bridge] + self.hosts:
            if ip("netns", "add", n).returncode != 0:
                self.close()
                raise CheckSkipped("cannot create network namespaces here")
            self.made.append(n)
        steps = [("-n", self.bridge, "link", "add", "br0", "type", "bridge",
                  "mcast_snooping", "0"),
                 ("-n", self.bridge, "link", "set", "br0", "up")]
        for i, (host, iface) in enumerate(zip(self.hosts, self.ifaces)):
            port = "bp%d%s" % (i, tag)
            steps += [
                ("link", "add", iface, "netns", host, "type", "veth", "peer", "name", port,
                 "netns", self.bridge),
                ("-n", self.bridge, "link", "set", port, "master", "br0"),
                ("-n", self.bridge, "link", "set", port, "up"),
                ("-n", host, "addr", "add", "%s.%d/24" % (SUBNET, i + 1), "brd", "+",
                 "dev", iface),
                # No duplicate address detection: IPv6 is usable at once.
                ("netns", "exec", host, "sysctl", "-qw",
                 "net.ipv6.conf.%s.accept_dad=0" % iface),
                ("-n", host, "link", "set", iface, "up"),
                ("-n", host, "link", "set", "lo", "up"),
                # pymavlink's mcast: joins and sends on the interface the routing table names.
                ("-n", host, "route", "add", "224.0.0.0/4", "dev", iface),
            ]
        for step in steps:
            r = ip(*step)
            if r.returncode != 0:
                self.close()
                raise CheckSkipped("cannot wire namespaces: ip %s: %s"
                                   % (" ".join(step), r.stderr.strip()))
        self.procs = []

    def run(self, host, cmd, log):
        out = open(log, "w")
        p = subprocess.Popen(["ip", "netns", "exec", self.hosts[host]] + cmd,
                             stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT)
        self.procs.append((p, out, log))
        return p, log

    def role(self, host, log, *args):
        return self.run(host, [sys.executable, os.path.abspath(__file__)] + list(args), log)

    def close(self):
        for p, out, _ in getattr(self, "procs", []):
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
            out.close()
        for n in self.made:
            ip("netns", "del", n)
        self.made = []


def text(log):
    with open(log, errors="replace") as f:
        return f.read()


def result(proc, log):
    """The JSON summary a role printed as its last line."""
    try:
        proc.wait(SECONDS + 20)
    except subprocess.TimeoutExpired:
        raise CheckFailed("%s did not finish: %s" % (log, text(log)[-400:]))
    lines = text(log).strip().splitlines()
    try:
        return json.loads(lines[-1])
    except (IndexError, ValueError):
        raise CheckFailed("%s printed no summary: %s" % (log, text(log)[-400:]))


def start_router(lan, args, host, endpoints, name):
    log = os.path.join(args.workdir, name + ".router.log")
    proc, _ = lan.run(host, [args.router, "mavlink", "router", "--run-for", str(SECONDS + 10)]
                      + endpoints, log)
    deadline = time.time() + 20
    while "ready" not in text(log):
        if proc.poll() is not None or time.time() > deadline:
            raise CheckFailed("the router did not get ready: %s" % text(log)[-400:])
        time.sleep(0.05)
    return log


def expect(what, got, want):
    if got != want:
        raise CheckFailed("%s: got %r, expected %r" % (what, got, want))


def check_bcast_out(args):
    lan = Lan(3)
    try:
        gcs_port = 14601
        router = start_router(lan, args, 0, [
            "udpin://127.0.0.1:%d" % gcs_port,
            "udpbcast://%s.255:14550" % SUBNET], "bcast_out")
        vehicles = [lan.role(h, os.path.join(args.workdir, "bcast_out.v%d.log" % h),
                             "--role", "vehicle", "--uri", "udpin:0.0.0.0:14550",
                             "--sysid", str(h)) for h in (1, 2)]
        gcs = lan.role(0, os.path.join(args.workdir, "bcast_out.gcs.log"), "--role", "gcs",
                       "--uri", "udpout:127.0.0.1:%d" % gcs_port, "--sysid", "255",
                       "--target", "1")
        g = result(*gcs)
        v = [result(*p) for p in vehicles]
        expect("vehicles the ground station heard", g["heard"], [1, 2])
        expect("acknowledgements the ground station got", g["acks"], {"1": g["sent"]})
        expect("commands vehicle 1 got", v[0]["commands"], {"255": g["sent"]})
        expect("commands vehicle 2 got", v[1]["commands"], {})
        for i, s in enumerate(v):
            if s["duplicates"]:
                raise CheckFailed("vehicle %d got %d frames twice" % (i + 1, s["duplicates"]))
            if 255 not in s["heard"]:
                raise CheckFailed("vehicle %d never heard the ground station: %r\n%s"
                                  % (i + 1, s, text(router)[-600:]))
    finally:
        lan.close()


def check_bcast_in(args):
    lan = Lan(2)
    try:
        gcs_port, port = 14602, 14560
        start_router(lan, args, 0, ["udpin://127.0.0.1:%d" % gcs_port,
                                    "udpin://0.0.0.0:%d" % port], "bcast_in")
        vehicle = lan.role(1, os.path.join(args.workdir, "bcast_in.v1.log"), "--role",
                           "vehicle", "--uri", "udpbcast:%s.255:%d" % (SUBNET, port),
                           "--sysid", "1")
        gcs = lan.role(0, os.path.join(args.workdir, "bcast_in.gcs.log"), "--role", "gcs",
                       "--uri", "udpout:127.0.0.1:%d" % gcs_port, "--sysid", "255",
                       "--target", "1")
        g, v = result(*gcs), result(*vehicle)
        expect("vehicles the ground station heard", g["heard"], [1])
        expect("acknowledgements the ground station got", g["acks"], {"1": g["sent"]})
        expect("commands the vehicle got", v["commands"], {"255": g["sent"]})
    finally:
        lan.close()


def check_mcast(args, group="239.255.145.50", v6=False):
    lan = Lan(3)
    try:
        port = 14570
        name = "mcast6" if v6 else "mcast"
        router = start_router(lan, args, 0, [
            "udpin://127.0.0.1:14603", "udpin://127.0.0.1:14604",
            "udpmcast://%s:%d?iface=%s" % ("[%s]" % group if v6 else group, port,
                                           lan.ifaces[0])], name)
        uri = lambda h: ("mcast6:%s:%d:%s" % (group, port, lan.ifaces[h]) if v6
                         else "mcast:%s:%d" % (group, port))
        vehicles = [lan.role(h, os.path.join(args.workdir, "%s.v%d.log" % (name, h)), "--role",
                             "vehicle", "--uri", uri(h), "--sysid", str(h)) for h in (1, 2)]
        stations = [lan.role(0, os.path.join(args.workdir, "%s.gcs%d.log" % (name, t)), "--role",
                             "gcs", "--uri", "udpout:127.0.0.1:%d" % (14602 + t),
                             "--sysid", str(200 + t), "--target", str(t)) for t in (1, 2)]
        g = [result(*p) for p in stations]
        v = [result(*p) for p in vehicles]
        for t in (1, 2):
            mine = g[t - 1]
            expect("systems ground station %d heard" % (200 + t), mine["heard"],
                   [1, 2, 200 + 3 - t])
            expect("acknowledgements ground station %d got" % (200 + t), mine["acks"],
                   {str(t): mine["sent"]})
            expect("commands vehicle %d got" % t, v[t - 1]["commands"],
                   {str(200 + t): mine["sent"]})
            if v[t - 1]["duplicates"]:
                raise CheckFailed("vehicle %d got %d frames twice" % (t, v[t - 1]["duplicates"]))
        links = [line for line in text(router).splitlines() if "link up: udpmcast" in line]
        if len(links) != 3:
            raise CheckFailed("the group and two hosts should be links: %r" % links)
    finally:
        lan.close()


def check_mcast6(args):
    check_mcast(args, "ff15::1:5", v6=True)


class Mcast6:
    """pymavlink's MAVLink codec on an IPv6 multicast group, as `mcast:` is on IPv4: a socket
    that joins the group on an interface, and one that sends to it (whose port marks our own
    datagrams coming back)."""

    def __init__(self, group, port, iface, sysid):
        index = socket.if_nametoindex(iface)
        self.group = (group, port, 0, index)
        self.port = socket.socket(socket.AF_INET6, socket.SOCK_DGRAM)
        self.port.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.port.bind(("::", port))
        self.port.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_JOIN_GROUP,
                             socket.inet_pton(socket.AF_INET6, group) + struct.pack("@I", index))
        self.out = socket.socket(socket.AF_INET6, socket.SOCK_DGRAM)
        self.out.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_MULTICAST_IF, index)
        self.out.bind(("::", 0))
        self.mine = self.out.getsockname()[1]
        self.mav = mavutil.mavlink.MAVLink(self, srcSystem=sysid, srcComponent=1)
        self.pending = []

    def write(self, buf):
        self.out.sendto(buf, self.group)

    def recv_match(self, blocking=True, timeout=0.05):
        end = time.time() + timeout
        while not self.pending:
            left = end - time.time()
            if left <= 0:
                return None
            self.port.settimeout(left)
            try:
                data, sender = self.port.recvfrom(65536)
            except socket.timeout:
                return None
            if sender[1] != self.mine:
                self.pending += self.mav.parse_buffer(data) or []
        return self.pending.pop(0)


def role_vehicle(uri, sysid):
    """A vehicle: a heartbeat 5 times a second; acknowledges every COMMAND_LONG for it."""
    if uri.startswith("mcast6:"):
        group, port, iface = uri[len("mcast6:"):].rsplit(":", 2)
        m = Mcast6(group, int(port), iface, sysid)
    else:
        m = mavutil.mavlink_connection(uri, source_system=sysid, source_component=1)
    commands, heard, seen, duplicates = {}, set(), set(), 0
    end, beat = time.time() + SECONDS, 0.0
    while time.time() < end:
        if time.time() >= beat:
            m.mav.heartbeat_send(2, 3, 0, 0, 4)
            beat = time.time() + 0.2
        msg = m.recv_match(blocking=True, timeout=0.05)
        if msg is None or msg.get_type() == "BAD_DATA":
            continue
        key = (msg.get_srcSystem(), msg.get_srcComponent(), msg.get_seq(), msg.get_msgId())
        if key in seen:
            duplicates += 1
        seen.add(key)
        heard.add(msg.get_srcSystem())
        if msg.get_type() == "COMMAND_LONG" and msg.target_system == sysid:
            src = str(msg.get_srcSystem())
            commands[src] = commands.get(src, 0) + 1
            m.mav.command_ack_send(msg.command, 0, 0, 0, msg.get_srcSystem(),
                                   msg.get_srcComponent())
    print(json.dumps({"commands": commands, "heard": sorted(heard),
                      "duplicates": duplicates}), flush=True)
    return 0


def role_gcs(uri, sysid, target):
    """A ground station: heartbeats, and a command to `target` every half second after the
    first second, each with a confirmation number of its own."""
    m = mavutil.mavlink_connection(uri, source_system=sysid, source_component=190)
    heard, acks, sent = set(), {}, 0
    start = time.time()
    beat = next_command = start
    while time.time() < start + SECONDS - 1:
        now = time.time()
        if now >= beat:
            m.mav.heartbeat_send(6, 8, 0, 0, 4)
            beat = now + 0.2
        if now >= next_command and now > start + 1 and sent < 6:
            m.mav.command_long_send(target, 1, COMMAND, sent, 0, 0, 0, 0, 0, 0, 0)
            sent += 1
            next_command = now + 0.5
        msg = m.recv_match(blocking=True, timeout=0.05)
        if msg is None or msg.get_type() == "BAD_DATA":
            continue
        heard.add(msg.get_srcSystem())
        if msg.get_type() == "COMMAND_ACK" and msg.target_system == sysid:
            src = str(msg.get_srcSystem())
            acks[src] = acks.get(src, 0) + 1
    # Late acknowledgements.
    end = time.time() + 1
    while time.time() < end:
        msg = m.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.1)
        if msg is not None and msg.target_system == sysid:
            src = str(msg.get_srcSystem())
            acks[src] = acks.get(src, 0) + 1
    print(json.dumps({"heard": sorted(heard - {sysid}), "acks": acks, "sent": sent}),
          flush=True)
    return 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--router")
    ap.add_argument("--dialect-dir")
    ap.add_argument("--workdir")
    ap.add_argument("--only", action="append", default=[])
    ap.add_argument("--role")
    ap.add_argument("--uri")
    ap.add_argument("--sysid", type=int)
    ap.add_argument("--target", type=int)
    args = ap.parse_args()
    if args.role == "vehicle":
        return role_vehicle(args.uri, args.sysid)
    if args.role == "gcs":
        return role_gcs(args.uri, args.sysid, args.target)
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
