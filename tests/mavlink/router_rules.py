#!/usr/bin/env python3
"""The MAVLink routing rules as a table of checks, with pymavlink nodes on loopback.

Usage:
    router_rules.py --router BIN --dialect-dir DIR --workdir DIR [--only NAME]...

Every check starts its own `ferrolink mavlink router` (with common.xml, a tlog and statistics
in --workdir), drives it with pymavlink-built frames over UDP, TCP or a pty, and stops it with
SIGTERM, which must end it with status 0. Frames are compared byte for byte: the router
forwards frames unchanged. Each check prints `ok   NAME` or `FAIL NAME: detail`; the last
line is `N passed, M failed`; the exit status is 0 only if nothing failed.
"""

import argparse
import os
import pty
import select
import socket
import sys
import threading
import time
import tty

os.environ.setdefault("MAVLINK20", "1")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from pymavlink.dialects.v20 import common  # noqa: E402

from router_gcs import CheckFailed, Router, free_port  # noqa: E402

HOST = "127.0.0.1"
WAIT = 0.4  # how long to listen for frames that should (or should not) arrive


def mav(sysid, compid):
    m = common.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    m.robust_parsing = True
    return m


def heartbeat(sysid, compid=1):
    return bytes(common.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3).pack(mav(sysid, compid)))


def command(sysid, compid, target, target_comp, cmd=400):
    msg = common.MAVLink_command_long_message(target, target_comp, cmd, 0, 1, 0, 0, 0, 0, 0, 0)
    return bytes(msg.pack(mav(sysid, compid)))


def unpack(frame):
    return mav(0, 0).decode(bytearray(frame))


class Udp:
    """A node sending to one of the router's udpin ports from its own socket."""

    def __init__(self, port, sysid, compid=1):
        self.sysid, self.compid = sysid, compid
        self.s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.s.bind((HOST, 0))
        self.s.connect((HOST, port))

    def send(self, frame):
        self.s.send(frame)

    def hello(self):
        self.send(heartbeat(self.sysid, self.compid))

    def frames(self, wait=WAIT):
        out, end = [], time.time() + wait
        while True:
            left = end - time.time()
            if left <= 0:
                return out
            self.s.settimeout(left)
            try:
                out.append(self.s.recv(65536))
            except (socket.timeout, ConnectionRefusedError):
                pass

    def drain(self):
        self.frames(0.15)


class Tcp:
    """A TCP client of the router's tcpin endpoint."""

    def __init__(self, port, sysid, compid=190):
        self.sysid, self.compid = sysid, compid
        self.s = socket.create_connection((HOST, port), timeout=5)
        self.parser = mav(0, 0)

    def send(self, frame):
        self.s.sendall(frame)

    def hello(self):
        self.send(heartbeat(self.sysid, self.compid))

    def frames(self, wait=WAIT):
        out, end = [], time.time() + wait
        while True:
            left = end - time.time()
            if left <= 0:
                return out
            self.s.settimeout(left)
            try:
                data = self.s.recv(65536)
            except socket.timeout:
                continue
            if not data:
                return out
            for m in self.parser.parse_buffer(data) or []:
                out.append(bytes(m.get_msgbuf()))


def expect(cond, what):
    if not cond:
        raise CheckFailed(what)


def settle(*nodes):
    """Every node says hello, and the router has learnt them all."""
    for n in nodes:
        n.hello()
    time.sleep(0.2)
    for n in nodes:
        n.drain() if isinstance(n, Udp) else n.frames(0.15)


class Run:
    def __init__(self, args, name, *endpoints):
        self.router = Router(args, name, "common.xml", endpoints)

    def __enter__(self):
        self.router.start()
        return self.router

    def __exit__(self, kind, value, tb):
        if kind is None:
            self.router.stop()
        else:
            self.router.kill()
        return False


def check_broadcast(args):
    p = free_port(socket.SOCK_DGRAM)
    with Run(args, "broadcast", "udpin://%s:%d" % (HOST, p)):
        nodes = [Udp(p, 1), Udp(p, 255, 190), Udp(p, 2)]
        settle(*nodes)
        hbs = [heartbeat(n.sysid, n.compid) for n in nodes]
        for n, hb in zip(nodes, hbs):
            n.send(hb)
        for n, hb in zip(nodes, hbs):
            got = n.frames()
            others = [h for h in hbs if h != hb]
            expect(sorted(got) == sorted(others),
                   "node %d got %d frames, expected the %d others'" % (n.sysid, len(got), len(others)))
            expect(hb not in got, "node %d got its own frame back" % n.sysid)


def check_targeted(args):
    a, b, c = (free_port(socket.SOCK_DGRAM) for _ in range(3))
    with Run(args, "targeted", *("udpin://%s:%d" % (HOST, p) for p in (a, b, c))):
        v1, v2, gcs = Udp(a, 1), Udp(b, 2), Udp(c, 255, 190)
        settle(v1, v2, gcs)
        to2 = command(255, 190, 2, 1)
        gcs.send(to2)
        expect(v2.frames() == [to2], "vehicle 2 did not get its command once, unchanged")
        expect(v1.frames() == [], "vehicle 1 got a command for vehicle 2")
        to1 = command(255, 190, 1, 0)
        gcs.send(to1)
        expect(v1.frames() == [to1], "vehicle 1 did not get its command")
        expect(v2.frames() == [], "vehicle 2 got a command for vehicle 1")


def check_component(args):
    a, b, c = (free_port(socket.SOCK_DGRAM) for _ in range(3))
    with Run(args, "component", *("udpin://%s:%d" % (HOST, p) for p in (a, b, c))):
        autopilot, camera, gcs = Udp(a, 1, 1), Udp(b, 1, 100), Udp(c, 255, 190)
        settle(autopilot, camera, gcs)
        to_camera = command(255, 190, 1, 100)
        gcs.send(to_camera)
        expect(camera.frames() == [to_camera], "the camera did not get its command")
        expect(autopilot.frames() == [], "the autopilot got the camera's command")
        to_gimbal = command(255, 190, 1, 154)
        gcs.send(to_gimbal)
        expect(camera.frames() == [to_gimbal] and autopilot.frames() == [to_gimbal],
               "a command for an unseen component of system 1 must reach every link of system 1")


def check_unknown_target(args):
    a, b = (free_port(socket.SOCK_DGRAM) for _ in range(2))
    with Run(args, "unknown_target", "udpin://%s:%d" % (HOST, a), "udpin://%s:%d" % (HOST, b)):
        v1, gcs = Udp(a, 1), Udp(b, 255, 190)
        settle(v1, gcs)
        gcs.send(command(255, 190, 9, 1))
        expect(v1.frames() == [], "a command for a system seen nowhere was forwarded")


def unknown_id_frame():
    """A MAVLink 2 frame of id 42424 (in no dialect), with an arbitrary checksum."""
    payload = bytes(range(1, 13))
    header = bytes([0xFD, len(payload), 0, 0, 7, 1, 1]) + (42424).to_bytes(3, "little")
    return header + payload + b"\x12\x34"


def check_unknown_id_and_signed(args):
    a, b = (free_port(socket.SOCK_DGRAM) for _ in range(2))
    with Run(args, "unknown_id_and_signed", "udpin://%s:%d" % (HOST, a), "udpin://%s:%d" % (HOST, b)):
        src, dst = Udp(a, 1), Udp(b, 255, 190)
        settle(src, dst)
        signer = mav(1, 1)
        signer.signing.secret_key = bytes(range(32))
        signer.signing.link_id = 3
        signer.signing.timestamp = int((time.time() - 1420070400) * 100000)
        signer.signing.sign_outgoing = True
        signed = bytes(common.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3).pack(signer))
        expect(signed[2] & 1 == 1, "pymavlink did not sign the frame")
        unknown = unknown_id_frame()
        src.send(unknown)
        src.send(signed)
        got = dst.frames()
        expect(unknown in got, "the unknown id was not forwarded byte for byte")
        expect(signed in got, "the signed frame was not forwarded byte for byte")


def check_garbage_teaches_nothing(args):
    a, b = (free_port(socket.SOCK_DGRAM) for _ in range(2))
    with Run(args, "garbage", "udpin://%s:%d" % (HOST, a), "udpin://%s:%d" % (HOST, b)):
        noisy, gcs = Udp(a, 3), Udp(b, 255, 190)
        settle(noisy, gcs)
        bad = bytearray(heartbeat(7))
        bad[-1] ^= 0xFF
        noisy.send(b"\x00\xfd\x01\xfe\x55garbage" + bytes(bad))
        expect(gcs.frames() == [], "garbage or a bad-CRC frame was forwarded")
        gcs.send(command(255, 190, 7, 1))
        expect(noisy.frames() == [], "a bad-CRC frame taught a route to system 7")


def check_two_gcs_one_port(args):
    p, q = (free_port(socket.SOCK_DGRAM) for _ in range(2))
    with Run(args, "two_gcs_one_port", "udpin://%s:%d" % (HOST, p), "udpin://%s:%d" % (HOST, q)):
        gcs1, gcs2, vehicle = Udp(p, 255, 190), Udp(p, 254, 190), Udp(q, 1, 1)
        settle(gcs1, gcs2, vehicle)
        hb = heartbeat(1)
        vehicle.send(hb)
        expect(hb in gcs1.frames() and hb in gcs2.frames(), "the vehicle's heartbeat missed a GCS")
        req = bytes(common.MAVLink_param_request_list_message(1, 1).pack(mav(254, 190)))
        gcs2.send(req)
        expect(vehicle.frames() == [req], "the vehicle did not get GCS 254's request")
        expect(gcs1.frames() == [], "GCS 255 got GCS 254's request")
        ack = bytes(common.MAVLink_command_ack_message(400, 0, 0, 0, 254, 190).pack(mav(1, 1)))
        vehicle.send(ack)
        expect(gcs2.frames() == [ack], "GCS 254 did not get its ACK")
        expect(gcs1.frames() == [], "GCS 255 got GCS 254's ACK")


def check_several_frames_in_one_datagram(args):
    a, b = (free_port(socket.SOCK_DGRAM) for _ in range(2))
    with Run(args, "several_frames", "udpin://%s:%d" % (HOST, a), "udpin://%s:%d" % (HOST, b)):
        src, dst = Udp(a, 1), Udp(b, 255, 190)
        settle(src, dst)
        frames = [heartbeat(1), command(1, 1, 0, 0), heartbeat(1, 100)]
        src.send(b"".join(frames))
        got = dst.frames()
        expect(got == frames, "%d of 3 frames of one datagram were forwarded" % len(got))


def check_tcpin_many(args):
    t, u = free_port(socket.SOCK_STREAM), free_port(socket.SOCK_DGRAM)
    with Run(args, "tcpin_many", "tcpin://%s:%d" % (HOST, t), "udpin://%s:%d" % (HOST, u)):
        c1, c2, vehicle = Tcp(t, 255), Tcp(t, 254), Udp(u, 1)
        time.sleep(0.2)
        settle(c1, c2, vehicle)
        hb = heartbeat(1)
        vehicle.send(hb)
        expect(hb in c1.frames() and hb in c2.frames(), "a TCP client missed the heartbeat")
        mine = heartbeat(254, 190)
        c2.send(mine)
        got = vehicle.frames()
        expect(mine in got, "a TCP client's heartbeat did not reach the vehicle")
        expect(mine in c1.frames(), "the other TCP client is a link of its own and gets it too")


def check_tcpout_reconnect(args):
    t, u = free_port(socket.SOCK_STREAM), free_port(socket.SOCK_DGRAM)
    received = {"bytes": b""}
    lock = threading.Lock()

    def serve(stop):
        srv = socket.socket()
        srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        srv.bind((HOST, t))
        srv.listen()
        srv.settimeout(0.1)
        conns = []
        while not stop.is_set():
            try:
                c, _ = srv.accept()
                c.settimeout(0.05)
                conns.append(c)
            except socket.timeout:
                pass
            for c in conns:
                try:
                    data = c.recv(4096)
                    with lock:
                        received["bytes"] += data
                except socket.timeout:
                    pass
        for c in conns:
            c.close()
        srv.close()

    def wait_for(needle, timeout):
        end = time.time() + timeout
        while time.time() < end:
            vehicle.send(needle)
            with lock:
                if needle in received["bytes"]:
                    return True
            time.sleep(0.1)
        return False

    stop = threading.Event()
    server = threading.Thread(target=serve, args=(stop,))
    server.start()
    try:
        with Run(args, "tcpout_reconnect", "tcpout://%s:%d" % (HOST, t), "udpin://%s:%d" % (HOST, u)):
            vehicle = Udp(u, 1)
            expect(wait_for(heartbeat(1), 5), "the TCP server got nothing")
            stop.set()
            server.join()
            time.sleep(0.5)
            with lock:
                received["bytes"] = b""
            stop = threading.Event()
            server = threading.Thread(target=serve, args=(stop,))
            server.start()
            expect(wait_for(heartbeat(1, 2), 5), "the router did not reconnect within 5 s")
    finally:
        stop.set()
        server.join()


def check_serial(args):
    master, slave = pty.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    path = os.ttyname(slave)
    u = free_port(socket.SOCK_DGRAM)
    try:
        with Run(args, "serial", "serial://%s:57600" % path, "udpin://%s:%d" % (HOST, u)):
            gcs = Udp(u, 255, 190)
            time.sleep(1.2)  # the serial endpoint opens the device in the background
            settle(gcs)
            hb = heartbeat(1)
            os.write(master, hb)
            expect(gcs.frames() == [hb], "the serial device's heartbeat did not reach the GCS")
            gcs.send(heartbeat(255, 190))
            data, end = b"", time.time() + 2
            while heartbeat(255, 190) not in data and time.time() < end:
                if select.select([master], [], [], 0.1)[0]:
                    data += os.read(master, 4096)
            expect(heartbeat(255, 190) in data, "the GCS's heartbeat did not reach the device")
    finally:
        os.close(master)
        os.close(slave)


CHECKS = [
    ("broadcast", check_broadcast),
    ("targeted", check_targeted),
    ("component", check_component),
    ("unknown_target", check_unknown_target),
    ("unknown_id_and_signed", check_unknown_id_and_signed),
    ("garbage_teaches_nothing", check_garbage_teaches_nothing),
    ("two_gcs_one_port", check_two_gcs_one_port),
    ("several_frames_in_one_datagram", check_several_frames_in_one_datagram),
    ("tcpin_many", check_tcpin_many),
    ("tcpout_reconnect", check_tcpout_reconnect),
    ("serial", check_serial),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    ap.add_argument("--router", required=True)
    ap.add_argument("--dialect-dir", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--only", action="append", default=[])
    args = ap.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    passed = failed = 0
    for name, check in CHECKS:
        if args.only and name not in args.only:
            continue
        try:
            check(args)
            print("ok   %s" % name, flush=True)
            passed += 1
        except Exception as e:  # a check's own failure or anything unexpected
            print("FAIL %s: %s" % (name, e), flush=True)
            failed += 1
    print("%d passed, %d failed" % (passed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
