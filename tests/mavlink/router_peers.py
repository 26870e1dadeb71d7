#!/usr/bin/env python3
"""Exercise `ferrolink mavlink router` with pymavlink nodes on loopback.

Usage:
    router_peers.py --router FERROLINK --dialect-dir DIR --workdir DIR [--only NAME]

Every check starts its own router process (with pymavlink's common.xml from the
--dialect-dir), waits for its "ready" line, puts pymavlink nodes (and a few raw
sockets and a pty, where frames must be compared byte for byte) on its UDP, TCP
and serial endpoints, and stops it with SIGTERM, expecting exit
status 0.  One line is printed per check, `ok   NAME` or `FAIL NAME: detail`,
then `N passed, M failed`.  The exit status is 0 when every check passed.

Beyond what each check asserts, every frame any node receives must be a frame
another node sent, byte for byte: nothing echoed, altered, or made of garbage.
Router output goes to DIR/NAME/router.{out,err}.
"""

import argparse
import os
import pty
import random
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import tty
from collections import namedtuple

sys.dont_write_bytecode = True  # keep the source tree clean
os.environ["MAVLINK20"] = "1"  # before mavutil is imported: MAVLink 2 everywhere

from pymavlink import mavutil  # noqa: E402
from pymavlink.generator.mavcrc import x25crc  # noqa: E402
from ports import free_ports  # noqa: E402

mavutil.set_dialect("common")
mavlink = mavutil.mavlink

HOST = "127.0.0.1"
RUN_FOR = 30          # --run-for given to every router; SIGTERM ends it earlier
READY_TIMEOUT = 20.0  # for the router's "ready" line
EXIT_TIMEOUT = 5.0    # for the router to exit after SIGTERM
DELIVERY_TIMEOUT = 3.0
SETTLE = 0.4          # how long to keep listening for frames that must not come
POLL_TICK = 0.005

UNKNOWN_MSGID = 42424  # absent from common.xml
CMD = mavlink.MAV_CMD_USER_1

MAGIC_V1 = 0xFE
MAGIC_V2 = 0xFD
SIGNATURE_LEN = 13


class CheckFailed(Exception):
    pass


# ---------------------------------------------------------------------------
# Frames

def frame_len(buf, i):
    """Length of the frame starting at buf[i], or None if it is incomplete."""
    avail = len(buf) - i
    if buf[i] == MAGIC_V2:
        if avail < 10:
            return None
        n = 10 + buf[i + 1] + 2 + (SIGNATURE_LEN if buf[i + 2] & 0x01 else 0)
    else:
        if avail < 6:
            return None
        n = 6 + buf[i + 1] + 2
    return n if avail >= n else None


def split_frames(buf):
    """Cut a byte stream into frames by their headers (no CRC check).
    Returns (frames, skipped bytes that started no frame, incomplete tail)."""
    frames, skipped, i = [], 0, 0
    while i < len(buf):
        if buf[i] not in (MAGIC_V1, MAGIC_V2):
            skipped += 1
            i += 1
            continue
        n = frame_len(buf, i)
        if n is None:
            break
        frames.append(bytes(buf[i:i + n]))
        i += n
    return frames, skipped, bytes(buf[i:])


def frame_header(frame):
    """(msgid, sysid, compid, seq) from a frame's header."""
    if frame[0] == MAGIC_V2:
        return frame[7] | frame[8] << 8 | frame[9] << 16, frame[5], frame[6], frame[4]
    return frame[5], frame[3], frame[4], frame[2]


def unknown_frame(seq, sysid, compid, payload, msgid=UNKNOWN_MSGID):
    """A MAVLink 2 frame of an id the dialect lacks.  Nobody can check its
    CRC, so any value does; this one is the CRC with a zero CRC_EXTRA."""
    header = struct.pack("<BBBBBBBHB", MAGIC_V2, len(payload), 0, 0, seq & 0xFF,
                         sysid, compid, msgid & 0xFFFF, msgid >> 16)
    crc = x25crc(header[1:] + payload)
    crc.accumulate(b"\x00")
    return header + payload + struct.pack("<H", crc.crc)


def corrupt_crc(frame):
    """The same (unsigned) frame with its CRC broken."""
    return frame[:-1] + bytes([frame[-1] ^ 0x5A])


def garbage(rng, n):
    """Bytes that contain no frame start, so no parser can find a frame in them."""
    return bytes(rng.choice([b for b in range(256) if b not in (MAGIC_V1, MAGIC_V2)])
                 for _ in range(n))


def is_known(msgid):
    return msgid in mavlink.mavlink_map


# Something a node received: pymavlink's type name ("BAD_DATA",
# "UNKNOWN_<id>" included), header fields, the bytes, the decoded message.
Rx = namedtuple("Rx", "type msgid sysid compid raw msg")


def rx_from_frame(decoder, frame):
    try:
        msg = decoder.decode(bytearray(frame))
    except Exception:  # bad CRC, bad length: what pymavlink calls BAD_DATA
        return Rx("BAD_DATA", None, None, None, frame, None)
    msgid, sysid, compid, _ = frame_header(frame)
    return Rx(msg.get_type(), msgid, sysid, compid, frame, msg)


def rx_from_msg(msg):
    raw = bytes(msg.get_msgbuf())
    if msg.get_type() == "BAD_DATA":
        return Rx("BAD_DATA", None, None, None, raw, msg)
    msgid, sysid, compid, _ = frame_header(raw)
    return Rx(msg.get_type(), msgid, sysid, compid, raw, msg)


# ---------------------------------------------------------------------------
# Nodes

class Node(object):
    """What every node has: a name, the (sysid, compid) it sends as, the
    bytes of every frame it sent and everything it received."""

    def __init__(self, name, sysid, compid, mav_type):
        self.name = name
        self.sysid = sysid
        self.compid = compid
        self.mav_type = mav_type
        self.sent = []
        self.inbox = []

    def heartbeat_msg(self):
        autopilot = (mavlink.MAV_AUTOPILOT_INVALID
                     if self.mav_type in (mavlink.MAV_TYPE_GCS, mavlink.MAV_TYPE_CAMERA)
                     else mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA)
        return self.encoder.heartbeat_encode(self.mav_type, autopilot, 0, 0,
                                             mavlink.MAV_STATE_ACTIVE)

    def heartbeat(self):
        return self.send(self.heartbeat_msg())

    def command_long(self, target_system, target_component, tag):
        """A COMMAND_LONG told apart from the others by param1 = tag."""
        return self.send(self.encoder.command_long_encode(
            target_system, target_component, CMD, 0, float(tag), 0, 0, 0, 0, 0, 0))

    def received(self, pred):
        return [rx for rx in self.inbox if pred(rx)]


class MavNode(Node):
    """A pymavlink node (mavutil connection)."""

    def __init__(self, name, url, sysid, compid, mav_type):
        Node.__init__(self, name, sysid, compid, mav_type)
        self.conn = mavutil.mavlink_connection(url, source_system=sysid,
                                               source_component=compid, dialect="common")
        self.encoder = self.conn.mav

    def send(self, msg):
        self.conn.mav.send(msg)
        raw = bytes(msg.get_msgbuf())  # as packed, signature included
        self.sent.append(raw)
        return raw

    def send_raw(self, data, frame=True):
        self.conn.write(data)
        if frame:
            self.sent.append(bytes(data))
        return data

    def poll(self):
        while True:
            m = self.conn.recv_msg()
            if m is None:
                return
            self.inbox.append(rx_from_msg(m))

    def junk(self):
        return 0

    def close(self):
        try:
            self.conn.close()
        except Exception:
            pass


class RawNode(Node):
    """A node that moves bytes itself (`write`): frames it sends are encoded with pymavlink,
    what it receives is split into frames byte for byte, and bytes between frames are counted."""

    def __init__(self, name, sysid, compid, mav_type):
        Node.__init__(self, name, sysid, compid, mav_type)
        self.encoder = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        self.decoder = mavlink.MAVLink(None)
        self.skipped = 0

    def send(self, msg):
        raw = bytes(msg.pack(self.encoder))
        self.encoder.seq = (self.encoder.seq + 1) % 256
        return self.send_raw(raw)

    def send_raw(self, data, frame=True):
        self.write(data)
        if frame:
            self.sent.append(bytes(data))
        return data

    def junk(self):
        return self.skipped


class RawUdpNode(RawNode):
    """A plain UDP socket talking to a udpin endpoint."""

    def __init__(self, name, port, sysid, compid, mav_type):
        RawNode.__init__(self, name, sysid, compid, mav_type)
        self.dest = (HOST, port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((HOST, 0))
        self.sock.setblocking(False)
        self.datagrams = []  # (bytes, frames) of each datagram received

    def write(self, data):
        self.sock.sendto(data, self.dest)

    def poll(self):
        while True:
            try:
                data = self.sock.recv(65535)
            except (BlockingIOError, ConnectionRefusedError):
                return
            frames, skipped, tail = split_frames(data)
            self.skipped += skipped + len(tail)
            self.datagrams.append((len(data), len(frames)))
            self.inbox.extend(rx_from_frame(self.decoder, f) for f in frames)

    def close(self):
        self.sock.close()


class PtyNode(RawNode):
    """A device on a serial line: the master side of a pseudo-terminal whose slave the router
    opens as `serial://`."""

    def __init__(self, name, sysid, compid, mav_type):
        RawNode.__init__(self, name, sysid, compid, mav_type)
        self.master, self.slave = pty.openpty()
        tty.setraw(self.master)
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self.slave)
        self.buf = b""

    def write(self, data):
        os.write(self.master, data)

    def poll(self):
        while True:
            try:
                data = os.read(self.master, 65535)
            except (BlockingIOError, OSError):
                break
            if not data:
                break
            self.buf += data
        # A byte stream: whole frames are taken, a partial one waits for the rest.
        frames, skipped, self.buf = split_frames(self.buf)
        self.skipped += skipped
        self.inbox.extend(rx_from_frame(self.decoder, f) for f in frames)

    def close(self):
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


class TcpServer(object):
    """A TCP server for a tcpout endpoint; keeps every byte received, per
    connection, and cuts it into frames."""

    def __init__(self, port=0):
        self.listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.listener.bind((HOST, port))
        self.listener.listen(8)
        self.listener.settimeout(0.05)
        self.port = self.listener.getsockname()[1]
        self.lock = threading.Lock()
        self.streams = []  # one bytearray per accepted connection
        self.conns = []
        self.stopped = False
        self.threads = [threading.Thread(target=self._accept, daemon=True)]
        self.threads[0].start()

    def _accept(self):
        while not self.stopped:
            try:
                conn, _ = self.listener.accept()
            except socket.timeout:
                continue
            except OSError:
                return
            conn.settimeout(0.05)
            stream = bytearray()
            with self.lock:
                self.conns.append(conn)
                self.streams.append(stream)
            t = threading.Thread(target=self._read, args=(conn, stream), daemon=True)
            t.start()
            self.threads.append(t)

    def _read(self, conn, stream):
        while not self.stopped:
            try:
                data = conn.recv(65536)
            except socket.timeout:
                continue
            except OSError:
                return
            if not data:
                return
            with self.lock:
                stream.extend(data)

    def connections(self):
        with self.lock:
            return len(self.streams)

    def frames(self):
        """(complete frames, bytes that started no frame) over all connections."""
        out, skipped = [], 0
        with self.lock:
            streams = [bytes(s) for s in self.streams]
        for s in streams:
            frames, n, _ = split_frames(s)
            out.extend(frames)
            skipped += n
        return out, skipped

    def close(self):
        self.stopped = True
        self.listener.close()
        with self.lock:
            conns = list(self.conns)
        for c in conns:
            try:
                c.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            c.close()
        for t in self.threads:
            t.join(1.0)


# ---------------------------------------------------------------------------
# Router process

class Router(object):
    def __init__(self, binary, dialect, workdir, endpoints, extra=()):
        # No dialect: the router's default, every standard dialect built into it.
        dialect_args = ["--dialect", dialect] if dialect else []
        self.cmd = ([binary, "mavlink", "router"] + dialect_args +
                    ["--run-for", str(RUN_FOR)] + list(extra) + list(endpoints))
        self.err_path = os.path.join(workdir, "router.err")
        self.out_path = os.path.join(workdir, "router.out")
        self.ready = threading.Event()
        self.status = None
        self.err = open(self.err_path, "wb")
        try:
            self.proc = subprocess.Popen(self.cmd, stdin=subprocess.DEVNULL,
                                         stdout=subprocess.PIPE, stderr=self.err)
        except OSError:
            self.err.close()
            raise
        self.reader = threading.Thread(target=self._read_stdout, daemon=True)
        self.reader.start()

    def _read_stdout(self):
        with open(self.out_path, "wb") as out:
            for line in self.proc.stdout:
                out.write(line)
                out.flush()
                if b"ready" in line:
                    self.ready.set()

    def stderr_tail(self):
        """': ' and the last lines of the router's stderr, if it wrote any."""
        try:
            with open(self.err_path, "rb") as f:
                lines = f.read().decode(errors="replace").strip().splitlines()
        except OSError:
            return ""
        return ": " + " | ".join(lines[-3:]) if lines else ""

    def wait_ready(self):
        deadline = time.monotonic() + READY_TIMEOUT
        while not self.ready.wait(0.05):
            if self.proc.poll() is not None:
                raise CheckFailed("router exited with status %s before ready%s"
                                  % (self.proc.returncode, self.stderr_tail()))
            if time.monotonic() > deadline:
                raise CheckFailed("router printed no 'ready' line within %.0f s"
                                  % READY_TIMEOUT)

    def stop(self):
        """SIGTERM; the router must exit 0.  Raises CheckFailed otherwise."""
        if self.status is not None:
            return
        rc = self.proc.poll()
        if rc is not None:
            self.status = rc
            self._close()
            raise CheckFailed("router exited early with status %s%s"
                              % (rc, self.stderr_tail()))
        self.proc.send_signal(signal.SIGTERM)
        try:
            self.status = self.proc.wait(EXIT_TIMEOUT)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.status = self.proc.wait()
            self._close()
            raise CheckFailed("router still running %.0f s after SIGTERM" % EXIT_TIMEOUT)
        self._close()
        if self.status != 0:
            raise CheckFailed("router exited with status %s after SIGTERM%s"
                              % (self.status, self.stderr_tail()))

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self._close()

    def _close(self):
        self.reader.join(1.0)
        self.proc.stdout.close()
        self.err.close()


# ---------------------------------------------------------------------------
# Harness

class Harness(object):
    """What one check owns: its router, its nodes, its scratch directory."""

    def __init__(self, args, name):
        self.args = args
        self.dir = os.path.join(args.workdir, name)
        os.makedirs(self.dir, exist_ok=True)
        self.router = None
        self.nodes = []
        self.servers = []
        self.tag = 1000

    def start_router(self, endpoints, extra=(), dialect=True):
        dialect = self.args.dialect if dialect else None
        self.router = Router(self.args.router, dialect, self.dir, endpoints, extra)
        self.router.wait_ready()
        return self.router

    def mav(self, name, url, sysid, compid, mav_type=mavlink.MAV_TYPE_QUADROTOR):
        node = MavNode(name, url, sysid, compid, mav_type)
        self.nodes.append(node)
        return node

    def raw(self, name, port, sysid, compid, mav_type=mavlink.MAV_TYPE_GCS):
        node = RawUdpNode(name, port, sysid, compid, mav_type)
        self.nodes.append(node)
        return node

    def server(self, port=0):
        srv = TcpServer(port)
        self.servers.append(srv)
        return srv

    def next_tag(self):
        self.tag += 1
        return self.tag

    def poll(self, seconds):
        end = time.monotonic() + seconds
        while True:
            for n in self.nodes:
                n.poll()
            if time.monotonic() >= end:
                return
            time.sleep(POLL_TICK)

    def wait(self, cond, timeout, every=None, action=None):
        """Polls every node until cond() holds; calls action() every `every`
        seconds meanwhile.  Returns whether cond() came true."""
        deadline = time.monotonic() + timeout
        next_action = time.monotonic()
        while True:
            if action is not None and time.monotonic() >= next_action:
                action()
                next_action = time.monotonic() + every
            for n in self.nodes:
                n.poll()
            if cond():
                return True
            if time.monotonic() >= deadline:
                return False
            time.sleep(POLL_TICK)

    def mesh(self, nodes, timeout=5.0):
        """Heartbeats from every node until each has heard every other one:
        the router then knows every node's address and ids."""
        def missing():
            return ["%s -> %s" % (b.name, a.name)
                    for a in nodes for b in nodes
                    if a is not b and not a.received(
                        lambda rx, b=b: rx.type == "HEARTBEAT"
                        and (rx.sysid, rx.compid) == (b.sysid, b.compid))]

        def beat():
            for n in nodes:
                n.heartbeat()

        if not self.wait(lambda: not missing(), timeout, every=0.1, action=beat):
            raise CheckFailed("heartbeats not delivered within %.0f s: %s"
                              % (timeout, ", ".join(missing())))

    def deliver(self, what, pred, expect, timeout=DELIVERY_TIMEOUT):
        """After a frame matching pred was sent: waits until every node of
        `expect` has it, listens SETTLE s more, and fails if a node outside
        `expect` got it too (or a node of `expect` never did)."""
        expect = list(expect)
        self.wait(lambda: all(n.received(pred) for n in expect), timeout)
        self.poll(SETTLE)
        missing = [n.name for n in expect if not n.received(pred)]
        extra = [n.name for n in self.nodes
                 if n not in expect and n.received(pred)]
        problems = []
        if missing:
            problems.append("missing at " + ", ".join(missing))
        if extra:
            problems.append("unexpected at " + ", ".join(extra))
        if problems:
            raise CheckFailed("%s: %s" % (what, "; ".join(problems)))

    def check_integrity(self):
        """Everything received is a whole frame another node sent, byte for
        byte; no node got its own frame back."""
        sent_by = {}
        for n in self.nodes:
            for raw in n.sent:
                sent_by.setdefault(raw, set()).add(n.name)
        for n in self.nodes:
            n.poll()
            if n.junk():
                raise CheckFailed("%s received %d bytes that are no frame" % (n.name, n.junk()))
            for rx in n.inbox:
                if rx.type == "BAD_DATA":
                    raise CheckFailed("%s received bad data: %s" % (n.name, rx.raw.hex()))
                senders = sent_by.get(rx.raw)
                if senders is None:
                    raise CheckFailed("%s received a %s from %s/%s that no node sent "
                                      "byte for byte: %s"
                                      % (n.name, rx.type, rx.sysid, rx.compid, rx.raw.hex()))
                if n.name in senders:
                    raise CheckFailed("%s received its own %s back" % (n.name, rx.type))

    def finish(self):
        self.check_integrity()
        if self.router is not None:
            self.router.stop()

    def cleanup(self):
        for n in self.nodes:
            n.close()
        for s in self.servers:
            s.close()
        if self.router is not None:
            self.router.kill()


def is_command(tag):
    return lambda rx: rx.type == "COMMAND_LONG" and rx.msg.param1 == float(tag)


def udpin(port):
    return "udpin://%s:%d" % (HOST, port)


def udp_peer(port):
    """pymavlink URL of a node talking to a router's udpin endpoint."""
    return "udpout:%s:%d" % (HOST, port)


# ---------------------------------------------------------------------------
# Checks

def check_broadcast(h):
    (port,) = free_ports(1)
    h.start_router([udpin(port)])
    v1 = h.mav("vehicle1", udp_peer(port), 1, 1)
    gcs = h.mav("gcs", udp_peer(port), 255, 190, mavlink.MAV_TYPE_GCS)
    v2 = h.mav("vehicle2", udp_peer(port), 2, 1)
    h.mesh([v1, gcs, v2])
    # A broadcast COMMAND_LONG (target 0) goes to every other node too.
    tag = h.next_tag()
    gcs.command_long(0, 0, tag)
    h.deliver("COMMAND_LONG to 0/0", is_command(tag), [v1, v2])


def check_targeted(h):
    port, v2_port = free_ports(2)
    # Vehicle 2 sits behind a udpout endpoint: the router sends to it first.
    v2 = h.mav("vehicle2", "udpin:%s:%d" % (HOST, v2_port), 2, 1)
    h.start_router([udpin(port), "udpout://%s:%d" % (HOST, v2_port)])
    gcs = h.mav("gcs", udp_peer(port), 255, 190, mavlink.MAV_TYPE_GCS)
    v1 = h.mav("vehicle1", udp_peer(port), 1, 1)
    h.mesh([gcs, v1, v2])
    for target, node in ((2, v2), (1, v1), (2, v2)):
        tag = h.next_tag()
        gcs.command_long(target, 1, tag)
        h.deliver("COMMAND_LONG to %d/1" % target, is_command(tag), [node])
    # Replies from the udpout side find their way back too.
    tag = h.next_tag()
    v2.command_long(255, 190, tag)
    h.deliver("COMMAND_LONG from vehicle2 to 255/190", is_command(tag), [gcs])


def check_component(h):
    port, cam_port = free_ports(2)
    h.start_router([udpin(port), udpin(cam_port)])
    gcs = h.mav("gcs", udp_peer(port), 255, 190, mavlink.MAV_TYPE_GCS)
    autopilot = h.mav("autopilot", udp_peer(port), 1, 1)
    camera = h.mav("camera", udp_peer(cam_port), 1, 100, mavlink.MAV_TYPE_CAMERA)
    h.mesh([gcs, autopilot, camera])
    tag = h.next_tag()
    gcs.command_long(1, 100, tag)
    h.deliver("COMMAND_LONG to 1/100", is_command(tag), [camera])
    tag = h.next_tag()
    gcs.command_long(1, 1, tag)
    h.deliver("COMMAND_LONG to 1/1", is_command(tag), [autopilot])
    # Component never seen: every link where system 1 was seen.
    tag = h.next_tag()
    gcs.command_long(1, 154, tag)
    h.deliver("COMMAND_LONG to 1/154", is_command(tag), [autopilot, camera])
    # Component 0: the whole system.
    tag = h.next_tag()
    gcs.command_long(1, 0, tag)
    h.deliver("COMMAND_LONG to 1/0", is_command(tag), [autopilot, camera])


def check_unknown_target(h):
    port, port2 = free_ports(2)
    h.start_router([udpin(port), udpin(port2)])
    gcs = h.mav("gcs", udp_peer(port), 255, 190, mavlink.MAV_TYPE_GCS)
    v1 = h.mav("vehicle1", udp_peer(port), 1, 1)
    v2 = h.mav("vehicle2", udp_peer(port2), 2, 1)
    h.mesh([gcs, v1, v2])
    tag = h.next_tag()
    gcs.command_long(9, 1, tag)
    # A targeted frame sent after it that does arrive shows the router has
    # handled the first one.
    control = h.next_tag()
    gcs.command_long(1, 1, control)
    h.deliver("COMMAND_LONG to 1/1 (sent after the one to 9/1)", is_command(control), [v1])
    h.deliver("COMMAND_LONG to 9/1", is_command(tag), [])


def check_built_in_dialect(h):
    """Without --dialect the router knows the standard dialects: the services' messages go
    to their target only, not to every link as unchecked broadcasts."""
    port, port2 = free_ports(2)
    h.start_router([udpin(port), udpin(port2)], dialect=False)
    gcs = h.mav("gcs", udp_peer(port), 255, 190, mavlink.MAV_TYPE_GCS)
    v1 = h.mav("vehicle1", udp_peer(port), 1, 1)
    v2 = h.mav("vehicle2", udp_peer(port2), 2, 1)
    h.mesh([gcs, v1, v2])
    for target, node in ((2, v2), (1, v1)):
        tag = h.next_tag()
        gcs.send(gcs.encoder.param_request_read_encode(target, 1, b"", tag))
        h.deliver("PARAM_REQUEST_READ to %d/1" % target,
                  lambda rx, tag=tag: rx.type == "PARAM_REQUEST_READ" and rx.msg.param_index == tag,
                  [node])
        tag = h.next_tag() % 256
        gcs.send(gcs.encoder.mission_request_list_encode(target, 1, tag))
        h.deliver("MISSION_REQUEST_LIST to %d/1" % target,
                  lambda rx, tag=tag: rx.type == "MISSION_REQUEST_LIST" and rx.msg.mission_type == tag,
                  [node])


def check_unknown_id_and_signed(h):
    (port,) = free_ports(1)
    h.start_router([udpin(port)])
    # The receiver is a raw socket, so what arrives is compared byte for byte.
    rx = h.raw("receiver", port, 255, 190)
    tx = h.mav("signer", udp_peer(port), 1, 1)
    tx.conn.setup_signing(bytes(range(32)), sign_outgoing=True,
                          allow_unsigned_callback=lambda mav, msgid: True)
    h.mesh([rx, tx])
    signed = [r for r in rx.received(lambda r: r.type == "HEARTBEAT" and r.sysid == 1)]
    if not signed:
        raise CheckFailed("no signed HEARTBEAT arrived")
    for r in signed:
        if not r.raw[2] & 0x01:
            raise CheckFailed("HEARTBEAT arrived without its signature: %s" % r.raw.hex())
        if r.raw not in tx.sent:
            raise CheckFailed("signed HEARTBEAT altered: %s" % r.raw.hex())
    frames = [tx.send_raw(unknown_frame(200 + i, 1, 1, bytes([i + 1, 0x55, 0xAA, 7])))
              for i in range(3)]

    def is_unknown(r):
        return r.msgid == UNKNOWN_MSGID

    h.wait(lambda: len(rx.received(is_unknown)) >= len(frames), DELIVERY_TIMEOUT)
    h.poll(SETTLE)
    got = [r.raw for r in rx.received(is_unknown)]
    if sorted(got) != sorted(frames):
        raise CheckFailed("frames of unknown id %d: sent %s, received %s"
                          % (UNKNOWN_MSGID, [f.hex() for f in frames], [g.hex() for g in got]))
    # And the other way, unsigned, from the raw node to the pymavlink one.
    back = rx.send_raw(unknown_frame(7, 255, 190, b"\x01\x02\x03"))
    if not h.wait(lambda: tx.received(lambda r: r.raw == back), DELIVERY_TIMEOUT):
        raise CheckFailed("frame of unknown id %d not delivered to the signer" % UNKNOWN_MSGID)


def check_garbage_teaches_nothing(h):
    (port,) = free_ports(1)
    h.start_router([udpin(port)])
    gcs = h.mav("gcs", udp_peer(port), 255, 190, mavlink.MAV_TYPE_GCS)
    v1 = h.mav("vehicle1", udp_peer(port), 1, 1)
    # The noisy node also listens: a route wrongly learned for system 7 would
    # send the GCS's command to it.
    noisy = h.raw("noisy", port, 8, 1, mavlink.MAV_TYPE_QUADROTOR)
    h.mesh([gcs, v1, noisy])
    rng = random.Random(7)
    enc7 = mavlink.MAVLink(None, srcSystem=7, srcComponent=1)
    bad = corrupt_crc(bytes(noisy.heartbeat_msg().pack(enc7)))
    noisy.send_raw(garbage(rng, 50), frame=False)
    noisy.send_raw(bad)
    noisy.send_raw(garbage(rng, 20) + bad + garbage(rng, 20), frame=False)
    # A good frame after the bad ones: once it is through, they were handled.
    marker = noisy.heartbeat()
    if not h.wait(lambda: gcs.received(lambda r: r.raw == marker)
                  and v1.received(lambda r: r.raw == marker), DELIVERY_TIMEOUT):
        raise CheckFailed("HEARTBEAT sent after the garbage was not delivered")
    tag = h.next_tag()
    gcs.command_long(7, 1, tag)
    control = h.next_tag()
    gcs.command_long(1, 1, control)
    h.deliver("COMMAND_LONG to 1/1", is_command(control), [v1])
    h.deliver("COMMAND_LONG to 7/1 (only a corrupted frame came from 7)", is_command(tag), [])
    for n in (gcs, v1):
        if n.received(lambda r: r.raw == bad or r.sysid == 7):
            raise CheckFailed("the corrupted HEARTBEAT of system 7 reached %s" % n.name)


def check_two_gcs_one_port(h):
    port, v_port = free_ports(2)
    h.start_router([udpin(port), udpin(v_port)])
    gcs_a = h.mav("gcs255", udp_peer(port), 255, 190, mavlink.MAV_TYPE_GCS)
    gcs_b = h.mav("gcs254", udp_peer(port), 254, 190, mavlink.MAV_TYPE_GCS)
    vehicle = h.mav("vehicle", udp_peer(v_port), 1, 1)
    h.mesh([gcs_a, gcs_b, vehicle])
    for gcs in (gcs_a, gcs_b):
        raw = gcs.send(gcs.encoder.param_request_list_encode(1, 1))
        h.deliver("PARAM_REQUEST_LIST from %s" % gcs.name,
                  lambda r, raw=raw: r.raw == raw, [vehicle])
    for n, gcs in enumerate((gcs_a, gcs_b, gcs_a)):
        command = 500 + n  # tells the replies apart
        vehicle.send(vehicle.encoder.command_ack_encode(
            command, mavlink.MAV_RESULT_ACCEPTED, 0, 0, gcs.sysid, gcs.compid))
        h.deliver("COMMAND_ACK to %d/%d" % (gcs.sysid, gcs.compid),
                  lambda r, c=command: r.type == "COMMAND_ACK" and r.msg.command == c, [gcs])


def check_tcpout_reconnect(h):
    (port,) = free_ports(1)
    srv = h.server()
    tcp_port = srv.port
    h.start_router([udpin(port), "tcpout://%s:%d" % (HOST, tcp_port)])
    peer = h.mav("vehicle1", udp_peer(port), 1, 1)

    def heartbeats(server):
        frames, skipped = server.frames()
        if skipped:
            raise CheckFailed("TCP server received %d bytes that are no frame" % skipped)
        for f in frames:
            if f not in peer.sent:
                raise CheckFailed("TCP server received a frame nobody sent: %s" % f.hex())
        return [f for f in frames if frame_header(f)[:2] == (0, 1)]

    if not h.wait(lambda: heartbeats(srv), 5.0, every=0.1, action=peer.heartbeat):
        raise CheckFailed("no HEARTBEAT reached the TCP server within 5 s (%d connections)"
                          % srv.connections())
    srv.close()
    h.servers.remove(srv)
    h.poll(0.5)
    srv2 = h.server(tcp_port)
    if not h.wait(lambda: heartbeats(srv2), 5.0, every=0.1, action=peer.heartbeat):
        raise CheckFailed("no HEARTBEAT within 5 s after the TCP server came back "
                          "(%d connections)" % srv2.connections())


def check_tcpin_many(h):
    (port,) = free_ports(1)
    (tcp_port,) = free_ports(1)
    h.start_router([udpin(port), "tcpin://%s:%d" % (HOST, tcp_port)])
    tcp_url = "tcp:%s:%d" % (HOST, tcp_port)
    a = h.mav("tcp255", tcp_url, 255, 190, mavlink.MAV_TYPE_GCS)
    b = h.mav("tcp254", tcp_url, 254, 190, mavlink.MAV_TYPE_GCS)
    peer = h.mav("udp1", udp_peer(port), 1, 1)
    h.mesh([a, b, peer])
    tag = h.next_tag()
    peer.command_long(254, 190, tag)
    h.deliver("COMMAND_LONG to 254/190", is_command(tag), [b])


def check_tlog(h):
    (port,) = free_ports(1)
    tlog = os.path.join(h.dir, "x.tlog")
    t_start = time.time()
    router = h.start_router([udpin(port)], ["--tlog", tlog])
    gcs = h.mav("gcs", udp_peer(port), 255, 190, mavlink.MAV_TYPE_GCS)
    vehicle = h.mav("vehicle", udp_peer(port), 1, 1)
    h.mesh([gcs, vehicle])
    enc = vehicle.encoder
    for i in range(30):
        if i % 3 == 0:
            vehicle.send(enc.attitude_encode(i * 10, 0.1 * i, -0.2, 0.3, 0.01, 0.02, 0.03))
        elif i % 3 == 1:
            vehicle.send(enc.sys_status_encode(1, 1, 1, 500, 12000 + i, 100, 90,
                                               0, 0, 0, 0, 0, 0))
        else:
            vehicle.send(enc.named_value_int_encode(i, b"n%d" % i, i * 7))
    unknown = [gcs.send_raw(unknown_frame(i, 255, 190, bytes([i, 1, 2, 3 + i])))
               for i in range(4)]
    # A heartbeat with a broken CRC must not be logged.
    bad = corrupt_crc(bytes(vehicle.heartbeat_msg().pack(enc)))
    vehicle.send_raw(bad, frame=False)
    last = gcs.heartbeat()
    last_v = vehicle.heartbeat()
    # Wait until the last frames went through, so the router has read them all.
    if not h.wait(lambda: vehicle.received(lambda r: r.raw == last)
                  and gcs.received(lambda r: r.raw == last_v), DELIVERY_TIMEOUT):
        raise CheckFailed("the last frames sent were not delivered")
    h.check_integrity()
    router.stop()
    t_end = time.time()

    with open(tlog, "rb") as f:
        data = f.read()
    records, i = [], 0
    while i < len(data):
        if len(data) - i < 9 or data[i + 8] not in (MAGIC_V1, MAGIC_V2):
            raise CheckFailed("tlog record at offset %d is not a timestamp and a frame" % i)
        (usec,) = struct.unpack(">Q", data[i:i + 8])
        n = frame_len(data, i + 8)
        if n is None:
            raise CheckFailed("tlog ends with a partial frame at offset %d" % i)
        records.append((usec, data[i + 8:i + 8 + n]))
        i += 8 + n

    sent = set(gcs.sent) | set(vehicle.sent)
    logged = [frame for _, frame in records]
    for usec, frame in records:
        if frame not in sent:
            what = "the corrupted frame" if frame == bad else "a frame nobody sent"
            raise CheckFailed("tlog holds %s: %s" % (what, frame.hex()))
    stamps = [usec for usec, _ in records]
    if any(b < a for a, b in zip(stamps, stamps[1:])):
        raise CheckFailed("tlog timestamps go backwards")
    if stamps and not (t_start - 5 <= stamps[0] / 1e6 and stamps[-1] / 1e6 <= t_end + 5):
        raise CheckFailed("tlog timestamps %d..%d are not the run's time (%.0f..%.0f s)"
                          % (stamps[0], stamps[-1], t_start, t_end))
    if len(set(logged)) != len(logged):
        raise CheckFailed("tlog holds a frame twice")
    known_sent = {f for f in sent if is_known(frame_header(f)[0])}
    known_logged = {f for f in logged if is_known(frame_header(f)[0])}
    if known_logged != known_sent:
        raise CheckFailed("tlog lacks %d of the %d known frames sent"
                          % (len(known_sent - known_logged), len(known_sent)))
    if set(unknown) - set(logged):
        raise CheckFailed("tlog lacks %d of the %d unknown-id frames sent"
                          % (len(set(unknown) - set(logged)), len(unknown)))

    # pymavlink reads it back to the same frames.
    log = mavutil.mavlink_connection(tlog, dialect="common")
    decoded = []
    try:
        while True:
            m = log.recv_msg()
            if m is None:
                break
            decoded.append((m.get_type(), bytes(m.get_msgbuf())))
    finally:
        log.close()
    bad_data = [raw for t, raw in decoded if t == "BAD_DATA"]
    if bad_data:
        raise CheckFailed("pymavlink finds %d pieces of bad data in the tlog" % len(bad_data))
    if [raw for _, raw in decoded] != logged:
        raise CheckFailed("pymavlink reads %d frames from the tlog, expected %d"
                          % (len(decoded), len(logged)))
    n_unknown = sum(1 for t, _ in decoded if t.startswith("UNKNOWN_"))
    if n_unknown != len(unknown):
        raise CheckFailed("pymavlink finds %d unknown-id frames in the tlog, expected %d"
                          % (n_unknown, len(unknown)))
    # And the tool people use on tlogs, mavlogdump.py, prints one line per frame.
    tool = os.path.join(os.path.dirname(sys.executable), "mavlogdump.py")
    if os.path.exists(tool):
        out = subprocess.run([sys.executable, tool, "--dialect", "common", tlog],
                             capture_output=True, text=True, timeout=60)
        lines = [l for l in out.stdout.splitlines() if l.strip()]
        if out.returncode != 0 or len(lines) != len(logged):
            raise CheckFailed("mavlogdump.py printed %d lines (status %d) for %d frames: %s"
                              % (len(lines), out.returncode, len(logged), out.stderr[-300:]))


def check_several_frames_in_one_datagram(h):
    """mavp2p once read only the first frame of a datagram (gomavlib#245)."""
    a, b = free_ports(2)
    h.start_router([udpin(a), udpin(b)])
    src = h.raw("source", a, 1, 1, mavlink.MAV_TYPE_QUADROTOR)
    gcs = h.mav("gcs", udp_peer(b), 255, 190, mavlink.MAV_TYPE_GCS)
    h.mesh([src, gcs])
    tags = [h.next_tag() for _ in range(3)]
    frames = []
    for tag in tags:
        msg = src.encoder.command_long_encode(0, 0, CMD, 0, float(tag), 0, 0, 0, 0, 0, 0)
        frames.append(bytes(msg.pack(src.encoder)))
        src.encoder.seq = (src.encoder.seq + 1) % 256
    src.send_raw(b"".join(frames), frame=False)
    src.sent.extend(frames)
    for tag in tags:
        h.deliver("COMMAND_LONG %d of one datagram" % tag, is_command(tag), [gcs])


def check_a_datagram_is_a_boundary(h):
    """A frame cut in two by datagrams is dropped, not joined with the next datagram."""
    a, b = free_ports(2)
    h.start_router([udpin(a), udpin(b)])
    src = h.raw("source", a, 1, 1, mavlink.MAV_TYPE_QUADROTOR)
    gcs = h.mav("gcs", udp_peer(b), 255, 190, mavlink.MAV_TYPE_GCS)
    h.mesh([src, gcs])
    cut, whole = h.next_tag(), h.next_tag()
    frames = []
    for tag in (cut, whole):
        msg = src.encoder.command_long_encode(0, 0, CMD, 0, float(tag), 0, 0, 0, 0, 0, 0)
        frames.append(bytes(msg.pack(src.encoder)))
        src.encoder.seq = (src.encoder.seq + 1) % 256
    half = len(frames[0]) // 2
    src.send_raw(frames[0][:half], frame=False)
    src.send_raw(frames[0][half:] + frames[1], frame=False)
    src.sent.append(frames[1])
    h.deliver("COMMAND_LONG %d after a cut one" % whole, is_command(whole), [gcs])
    h.deliver("COMMAND_LONG %d cut across two datagrams" % cut, is_command(cut), [])


def burst_through(h, extra):
    """40 COMMAND_LONGs in one datagram into endpoint A; a raw socket on B and pymavlink on C
    must each get all of them, in order.  Returns B's datagrams since the burst, (bytes, frames)
    each."""
    a, b, c = free_ports(3)
    h.start_router([udpin(a), udpin(b), udpin(c)], extra)
    src = h.raw("source", a, 1, 1, mavlink.MAV_TYPE_QUADROTOR)
    raw = h.raw("raw_gcs", b, 255, 190, mavlink.MAV_TYPE_GCS)
    pym = h.mav("pymavlink_gcs", udp_peer(c), 254, 190, mavlink.MAV_TYPE_GCS)
    h.mesh([src, raw, pym])
    tags = [h.next_tag() for _ in range(40)]
    frames = []
    for tag in tags:
        msg = src.encoder.command_long_encode(0, 0, CMD, 0, float(tag), 0, 0, 0, 0, 0, 0)
        frames.append(bytes(msg.pack(src.encoder)))
        src.encoder.seq = (src.encoder.seq + 1) % 256
    raw.poll()
    before = len(raw.datagrams)
    src.send_raw(b"".join(frames), frame=False)
    src.sent.extend(frames)
    for tag in tags:
        h.deliver("COMMAND_LONG %d of a burst" % tag, is_command(tag), [raw, pym])
    for node in (raw, pym):
        got = [int(rx.msg.param1) for rx in node.received(
            lambda rx: rx.type == "COMMAND_LONG" and int(rx.msg.param1) in tags)]
        if got != tags:
            raise CheckFailed("%s got the burst as %s" % (node.name, got))
    return [d for d in raw.datagrams[before:] if d[1] > 0], sum(map(len, frames))


def check_frames_that_leave_together_share_datagrams(h):
    """Frames a read sends to one UDP peer go out in as few datagrams of at most 1200 bytes
    as hold them, each frame whole (the checks above fail on any cut frame); pymavlink reads
    them all."""
    datagrams, total = burst_through(h, [])
    want = -(-total // 1200)
    if any(n > 1200 for n, _ in datagrams) or not want <= len(datagrams) <= want + 1:
        raise CheckFailed("%d bytes of frames came in datagrams of %s (bytes, frames), want %d "
                          "of at most 1200 bytes" % (total, datagrams, want))


def check_one_frame_per_datagram(h):
    """--one-frame-per-datagram: each frame in a datagram of its own."""
    datagrams, _ = burst_through(h, ["--one-frame-per-datagram"])
    if len(datagrams) != 40 or any(f != 1 for _, f in datagrams):
        raise CheckFailed("40 frames came in datagrams of %s (bytes, frames)" % datagrams)


def check_serial(h):
    """A device on a serial line (a pty) and a GCS on UDP, both ways."""
    (port,) = free_ports(1)
    device = PtyNode("device", 1, 1, mavlink.MAV_TYPE_QUADROTOR)
    h.nodes.append(device)
    h.start_router(["serial://%s:57600" % device.path, udpin(port)])
    gcs = h.mav("gcs", udp_peer(port), 255, 190, mavlink.MAV_TYPE_GCS)
    # The serial endpoint opens the device in the background.
    h.mesh([device, gcs], timeout=8.0)
    tag = h.next_tag()
    gcs.command_long(1, 1, tag)
    h.deliver("COMMAND_LONG to the serial device", is_command(tag), [device])


CHECKS = [
    ("broadcast", check_broadcast),
    ("targeted", check_targeted),
    ("component", check_component),
    ("unknown_target", check_unknown_target),
    ("built_in_dialect", check_built_in_dialect),
    ("unknown_id_and_signed", check_unknown_id_and_signed),
    ("garbage_teaches_nothing", check_garbage_teaches_nothing),
    ("two_gcs_one_port", check_two_gcs_one_port),
    ("tcpout_reconnect", check_tcpout_reconnect),
    ("tcpin_many", check_tcpin_many),
    ("several_frames_in_one_datagram", check_several_frames_in_one_datagram),
    ("a_datagram_is_a_boundary", check_a_datagram_is_a_boundary),
    ("frames_that_leave_together_share_datagrams",
     check_frames_that_leave_together_share_datagrams),
    ("one_frame_per_datagram", check_one_frame_per_datagram),
    ("serial", check_serial),
    ("tlog", check_tlog),
]


def run_check(args, name, func):
    """Returns None if the check passed, else what went wrong."""
    h = Harness(args, name)
    try:
        func(h)
        h.finish()
        return None
    except CheckFailed as e:
        detail = str(e)
    except Exception as e:  # a broken socket, a pymavlink error: still a failure
        detail = "%s: %s" % (type(e).__name__, e)
    finally:
        h.cleanup()
    if h.router is not None:
        detail += " (router log: %s)" % h.router.err_path
    return detail


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--router", required=True, help="the ferrolink binary")
    ap.add_argument("--dialect-dir", required=True,
                    help="pymavlink's dialects/v20 folder; its common.xml is given to the router")
    ap.add_argument("--workdir", required=True, help="scratch directory")
    ap.add_argument("--only", choices=[name for name, _ in CHECKS], help="run one check")
    args = ap.parse_args(argv)
    args.dialect = os.path.join(args.dialect_dir, "common.xml")
    os.makedirs(args.workdir, exist_ok=True)

    passed = failed = 0
    for name, func in CHECKS:
        if args.only and name != args.only:
            continue
        detail = run_check(args, name, func)
        if detail is None:
            passed += 1
            print("ok   %s" % name, flush=True)
        else:
            failed += 1
            print("FAIL %s: %s" % (name, detail), flush=True)
    print("%d passed, %d failed" % (passed, failed), flush=True)
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
