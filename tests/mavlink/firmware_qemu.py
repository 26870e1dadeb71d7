#!/usr/bin/env python3
"""The vehicle firmware (examples/mavlink-vehicle) in QEMU, against MAVSDK and our CLI.

    firmware_qemu.py --ferrolink BIN --firmware-port PORT [--workdir DIR] [--only CHECK,...]

QEMU must already run the firmware with its UART on TCP 127.0.0.1:PORT
(``examples/mavlink-vehicle/run.sh PORT``; ``check.sh`` does all of it). This script starts
``ferrolink mavlink router tcpout://127.0.0.1:PORT udpin://127.0.0.1:UDP`` and talks to the
firmware through it only: MAVSDK, our CLI and pymavlink are UDP peers of the router.

Checks (each prints ``ok``, ``FAIL`` or ``skip``; the last line is ``N passed, M failed``; the
exit status is 1 on any failure; a router that does not connect fails the run at once):

  heartbeat       HEARTBEAT from system 1, component 1: a quadrotor, generic autopilot,
                  MAVLink 2, about 1 Hz against the host's clock (SysTick in QEMU).
  mavsdk_params   MAVSDK's Param plugin lists the parameters (the signed integers and the
                  floats: MAVSDK 4.1 leaves the unsigned types out) exactly as our CLI lists
                  them, sets an INT32 and a REAL32, reads them back; our CLI sees the sets.
  mavsdk_mission  MAVSDK's MissionRaw plugin uploads a 100-item mission and downloads it back
                  item for item; our CLI downloads the same mission.
  mavsdk_arm      MAVSDK's Action plugin arms and disarms; its Telemetry plugin sees both in
                  the HEARTBEAT.
  our_params      ``ferrolink mavlink param list``: 64 parameters in index order, every one of
                  the seven types; ``param set`` and ``get`` of UINT8, INT8, UINT16, INT16,
                  UINT32, INT32 and REAL32 (and back); the read-only SYS_STACK_USED and an
                  out-of-range value refused.
  our_mission     ``ferrolink mavlink mission upload`` of a 100-item WPL file and ``download``
                  back; a geofence and rally points beside it; a 101-item mission refused with
                  the 100-item one kept.
  our_command     ``ferrolink mavlink command``: COMPONENT_ARM_DISARM (the HEARTBEAT shows
                  it), PREFLIGHT_CALIBRATION with its progress (0, 25, 50, 75 %) in about 2 s,
                  an unsupported command, disarm as COMMAND_INT.
  our_ftp         ``ferrolink mavlink ftp ls`` of ``/`` and ``/@PARAM``, ``ftp get`` of
                  ``@PARAM/param.pck``: ArduPilot's packed parameter format, checked byte by
                  byte (header, records, names shared with the previous one, zero padding, no
                  value across a 239-byte block) and holding the 64 values ``param list``
                  gives; ``?withdefaults=1`` with a parameter set away from its default; a
                  ``put`` refused (file protected).
  mavftp_params   pymavlink's ``mavftp`` lists ``/@PARAM`` and its ``getparams`` decodes the
                  64 parameters (values and defaults) with the values ``param list`` gives;
                  MAVProxy's decoder (its parameter module's) reads param.pck the same.
  mavsdk_ftp      MAVSDK's Ftp plugin lists ``/`` and ``/@PARAM`` and downloads param.pck with
                  and without bursts: the bytes our CLI gets (SYS_STACK_USED may differ:
                  it is live); its CRC-32 check agrees with the firmware's.
  stack           SYS_STACK_USED after all of that, within memory.x's stack reserve.

Every check leaves the parameters as it found them.
"""
import argparse
import asyncio
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import time

sys.dont_write_bytecode = True  # keep the source tree clean
os.environ.setdefault("MAVLINK20", "1")  # pymavlink: parse MAVLink 2

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from services_mavsdk import (  # noqa: E402
    CheckFailed, compare_items, f32, mavsdk_gcs, mission_spec, read_wpl, write_wpl)
from ports import free_port  # noqa: E402

HOST = "127.0.0.1"
HERE = os.path.dirname(os.path.abspath(__file__))
MEMORY_X = os.path.join(HERE, "..", "..", "examples", "mavlink-vehicle", "memory.x")

# What the firmware is (src/vehicle.rs, src/params.rs).
SYSID, COMPID = 1, 1
MAV_TYPE_QUADROTOR, MAV_AUTOPILOT_GENERIC = 2, 0
MAV_MODE_FLAG_SAFETY_ARMED = 128
PARAM_COUNT = 64
TYPES = {"UINT8", "INT8", "UINT16", "INT16", "UINT32", "INT32", "REAL32"}
SIGNED = {"INT8", "INT16", "INT32"}
# A parameter of each type to set and read back: (name, a value to set it to).
SETS = [("NAV_RCL_ACT", 3), ("CAL_MAG1_ROT", -7), ("PWM_MAIN_MAX", 1950),
        ("PWM_MAIN_TRIM3", -42), ("SER_GPS1_BAUD", 230400), ("COM_FLTMODE1", 7),
        ("MC_PITCH_P", 6.75)]


class CheckSkipped(Exception):
    pass


class Context:
    """What the checks share: the CLI, the router's UDP port, a pymavlink peer, a workdir."""

    def __init__(self, args):
        self.ferrolink = args.ferrolink
        self.workdir = args.workdir
        self.udp = free_port()
        self.uri = "udpout://%s:%d" % (HOST, self.udp)
        self.router = None
        self.mav = None

    def start_router(self, firmware_port):
        out = open(os.path.join(self.workdir, "router.out"), "w")
        err = open(os.path.join(self.workdir, "router.err"), "w")
        self.router = subprocess.Popen(
            [self.ferrolink, "mavlink", "router", "tcpout://%s:%d" % (HOST, firmware_port),
             "udpin://%s:%d" % (HOST, self.udp)],
            stdout=out, stderr=err, stdin=subprocess.DEVNULL)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            if self.router.poll() is not None:
                break
            if "link up: tcpout" in self.router_log():
                return
            time.sleep(0.1)
        raise CheckFailed("the router did not connect to the firmware on port %d: %s"
                          % (firmware_port, self.router_log().strip()[-300:]))

    def router_log(self):
        text = ""
        for name in ("router.out", "router.err"):
            with open(os.path.join(self.workdir, name)) as f:
                text += f.read()
        return text

    def stop(self):
        if self.mav is not None:
            self.mav.close()
        if self.router is not None and self.router.poll() is None:
            self.router.terminate()
            try:
                self.router.wait(5)
            except subprocess.TimeoutExpired:
                self.router.kill()

    def peer(self):
        """A pymavlink peer of the router (system 250), made known to it by a HEARTBEAT."""
        from pymavlink import mavutil
        if self.mav is None:
            self.mav = mavutil.mavlink_connection("udpout:%s:%d" % (HOST, self.udp),
                                                  source_system=250, source_component=190)
        # The router learns a UDP peer from what it sends.
        self.mav.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                    mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        return self.mav

    def heartbeats(self, seconds):
        """The firmware's HEARTBEATs over `seconds`, through a pymavlink peer of the router."""
        self.peer()
        seen = []
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            m = self.mav.recv_match(type="HEARTBEAT", blocking=True,
                                    timeout=max(0.01, end - time.monotonic()))
            if m is not None and m.get_srcSystem() == SYSID:
                seen.append((time.monotonic(), m))
        return seen

    def cli(self, *argv, timeout=60):
        """Runs ``ferrolink mavlink ARGV`` against the router: (status, stdout, stderr)."""
        argv = [a.replace("URI", self.uri) for a in argv]
        try:
            p = subprocess.run([self.ferrolink, "mavlink", *argv], capture_output=True,
                               text=True, timeout=timeout, stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired:
            raise CheckFailed("ferrolink mavlink %s took over %d s" % (" ".join(argv), timeout))
        return p.returncode, p.stdout, p.stderr

    def param_list(self):
        rc, out, err = self.cli("param", "list", "URI", "--timeout", "30")
        if rc != 0:
            raise CheckFailed("param list exited %d: %s" % (rc, err.strip()))
        return [json.loads(line) for line in out.splitlines() if line.strip()]

    def param_set(self, name, value):
        rc, out, err = self.cli("param", "set", "URI", name, repr(value))
        line = json.loads(out) if out.strip() else {}
        return rc, line.get("value"), err.strip()

    def param_get(self, name):
        rc, out, err = self.cli("param", "get", "URI", name)
        if rc != 0:
            raise CheckFailed("param get %s exited %d: %s" % (name, rc, err.strip()))
        return json.loads(out)["value"]


def check_heartbeat(ctx):
    beats = ctx.heartbeats(3.5)
    if len(beats) < 3:
        raise CheckFailed("%d HEARTBEATs from system %d in 3.5 s" % (len(beats), SYSID))
    _, m = beats[-1]
    got = (m.get_srcSystem(), m.get_srcComponent(), m.type, m.autopilot, m.mavlink_version)
    want = (SYSID, COMPID, MAV_TYPE_QUADROTOR, MAV_AUTOPILOT_GENERIC, 3)
    if got != want:
        raise CheckFailed("HEARTBEAT (sys, comp, type, autopilot, version) is %s, not %s"
                          % (got, want))
    if m.get_msgbuf()[0] != 0xFD:
        raise CheckFailed("HEARTBEAT is not MAVLink 2")
    rate = (len(beats) - 1) / (beats[-1][0] - beats[0][0])
    if not 0.8 <= rate <= 1.25:
        raise CheckFailed("HEARTBEAT at %.2f Hz" % rate)
    return "system %d/%d, quadrotor, generic autopilot, MAVLink 2, %.2f Hz" % (
        SYSID, COMPID, rate)


def mavsdk_check(fn):
    """Runs an async MAVSDK check; skips it when MAVSDK is not installed."""
    def run(ctx):
        try:
            import mavsdk  # noqa: F401
        except ImportError:
            raise CheckSkipped("Python package 'mavsdk' is not installed")
        import mavsdk.logging as mlog

        def quiet(level, _message, _file, _line):
            return level < mlog.LogLevel.WARN  # keep warnings and errors
        mlog.log_subscribe(quiet)
        return asyncio.run(fn(ctx))
    return run


async def connect(ctx):
    return await mavsdk_gcs(ctx.uri)


@mavsdk_check
async def check_mavsdk_params(ctx):
    from mavsdk.asyncio.plugins.param import ParamAsync
    listed = {p["name"]: p for p in ctx.param_list()}
    want_i = {n: p["value"] for n, p in listed.items() if p["type"] in SIGNED}
    want_f = {n: f32(p["value"]) for n, p in listed.items() if p["type"] == "REAL32"}
    mavsdk, system = await connect(ctx)
    try:
        param = ParamAsync(system)
        allp = await param.get_all_params()
        got_i = {p.name: p.value for p in allp.int_params}
        got_f = {p.name: p.value for p in allp.float_params}
        if got_i != want_i:
            raise CheckFailed("MAVSDK listed ints %s, our CLI %s" % (got_i, want_i))
        if got_f != want_f:
            raise CheckFailed("MAVSDK listed floats %s, our CLI %s" % (got_f, want_f))
        i_name, i_old = "SYS_AUTOSTART", want_i["SYS_AUTOSTART"]
        f_name, f_old = "MPC_XY_VEL_MAX", want_f["MPC_XY_VEL_MAX"]
        i_new, f_new = i_old + 1, f32(f_old + 0.25)
        await param.set_param_int(i_name, i_new)
        await param.set_param_float(f_name, f_new)
        back = (await param.get_param_int(i_name), await param.get_param_float(f_name))
        if back != (i_new, f_new):
            raise CheckFailed("MAVSDK read back %s after setting %s" % (back, (i_new, f_new)))
        ours = (ctx.param_get(i_name), f32(ctx.param_get(f_name)))
        if ours != (i_new, f_new):
            raise CheckFailed("our CLI read %s after MAVSDK set %s" % (ours, (i_new, f_new)))
        await param.set_param_int(i_name, i_old)
        await param.set_param_float(f_name, f_old)
    finally:
        await mavsdk.__aexit__(None, None, None)
    return "%d ints and %d floats listed as our CLI lists them; INT32 and REAL32 set" % (
        len(got_i), len(got_f))


@mavsdk_check
async def check_mavsdk_mission(ctx):
    from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync, MissionItem
    spec = mission_spec(100)
    mavsdk, system = await connect(ctx)
    try:
        mission = MissionRawAsync(system)
        items = [MissionItem(seq=s, frame=f, command=c, current=cur, autocontinue=ac,
                             param1=p1, param2=p2, param3=p3, param4=p4, x=x, y=y, z=z,
                             mission_type=0)
                 for (s, f, c, cur, ac, p1, p2, p3, p4, x, y, z) in spec]
        t0 = time.monotonic()
        await mission.upload_mission(items)
        t1 = time.monotonic()
        compare_items(spec, await mission.download_mission(), "MAVSDK's download")
        t2 = time.monotonic()
    finally:
        await mavsdk.__aexit__(None, None, None)
    rc, out, err = ctx.cli("mission", "download", "URI")
    if rc != 0:
        raise CheckFailed("mission download exited %d: %s" % (rc, err.strip()))
    compare_items(spec, read_wpl(out), "our download of MAVSDK's upload")
    return "%d items up in %.2f s, down in %.2f s; our download matches" % (
        len(spec), t1 - t0, t2 - t1)


async def wait_armed(telemetry, want, seconds=4):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if await telemetry.armed() == want:
            return
        await asyncio.sleep(0.1)
    raise CheckFailed("MAVSDK's telemetry did not show armed=%s within %d s" % (want, seconds))


@mavsdk_check
async def check_mavsdk_arm(ctx):
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
    mavsdk, system = await connect(ctx)
    try:
        action, telemetry = ActionAsync(system), TelemetryAsync(system)
        await action.arm()
        await wait_armed(telemetry, True)
        await action.disarm()
        await wait_armed(telemetry, False)
    finally:
        await mavsdk.__aexit__(None, None, None)
    return "armed and disarmed, both seen in the HEARTBEAT"


def check_our_params(ctx):
    lines = ctx.param_list()
    if len(lines) != PARAM_COUNT:
        raise CheckFailed("%d parameters listed, not %d" % (len(lines), PARAM_COUNT))
    if [p["index"] for p in lines] != list(range(PARAM_COUNT)):
        raise CheckFailed("not in index order: %s" % [p["index"] for p in lines])
    if len({p["name"] for p in lines}) != PARAM_COUNT:
        raise CheckFailed("names repeat")
    types = {p["type"] for p in lines}
    if types != TYPES:
        raise CheckFailed("types listed: %s" % sorted(types))
    listed = {p["name"]: p for p in lines}
    done = []
    for name, value in SETS:
        old = listed[name]["value"]
        # `param set` exits 0 only when the vehicle answers with exactly the value set.
        rc, got, err = ctx.param_set(name, value)
        if rc != 0 or got != value:
            raise CheckFailed("param set %s %r: exit %d, value %r: %s" % (name, value, rc, got, err))
        if name == SETS[-1][0] and ctx.param_get(name) != value:
            raise CheckFailed("param get %s after setting %r" % (name, value))
        rc, got, err = ctx.param_set(name, old)
        if rc != 0 or got != old:
            raise CheckFailed("param set %s back to %r: exit %d, %s" % (name, old, rc, err))
        done.append(listed[name]["type"])
    # Read-only: the firmware answers with the value it holds, so the CLI reports a mismatch.
    rc, got, err = ctx.param_set("SYS_STACK_USED", 1)
    if rc == 0 or got == 1:
        raise CheckFailed("the read-only SYS_STACK_USED took a set: exit %d, %r" % (rc, got))
    rc, got, err = ctx.param_set("PWM_MAIN_MAX", 70000)
    if rc == 0:
        raise CheckFailed("PWM_MAIN_MAX (UINT16) took 70000")
    return "64 in index order, all seven types; set and read back %s; read-only and out-of-range sets refused" % (
        ", ".join(done))


def fence_spec():
    """A square inclusion fence (MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, 4 vertices)."""
    lat, lon = 473977420, 85455940
    corners = [(0, 0), (0, 20000), (20000, 20000), (20000, 0)]
    return [(i, 0, 5001, 0, 1, 4.0, 0.0, 0.0, 0.0, lat + a, lon + b, 0.0)
            for i, (a, b) in enumerate(corners)]


def rally_spec():
    """Two rally points (MAV_CMD_NAV_RALLY_POINT)."""
    lat, lon = 473977420, 85455940
    return [(i, 3, 5100, 0, 1, 0.0, 0.0, 0.0, 0.0, lat - 5000 * (i + 1), lon, 15.0 + i)
            for i in range(2)]


def upload(ctx, spec, kind, name):
    path = os.path.join(ctx.workdir, name)
    write_wpl(path, spec)
    return ctx.cli("mission", "upload", "URI", path, "--type", kind)


def download(ctx, kind):
    rc, out, err = ctx.cli("mission", "download", "URI", "--type", kind)
    if rc != 0:
        raise CheckFailed("mission download --type %s exited %d: %s" % (kind, rc, err.strip()))
    return read_wpl(out)


def check_our_mission(ctx):
    spec = mission_spec(100)
    t0 = time.monotonic()
    rc, _, err = upload(ctx, spec, "mission", "mission.waypoints")
    t1 = time.monotonic()
    if rc != 0:
        raise CheckFailed("mission upload exited %d: %s" % (rc, err.strip()))
    compare_items(spec, download(ctx, "mission"), "our download")
    t2 = time.monotonic()
    for kind, kspec in (("fence", fence_spec()), ("rally", rally_spec())):
        rc, _, err = upload(ctx, kspec, kind, kind + ".waypoints")
        if rc != 0:
            raise CheckFailed("%s upload exited %d: %s" % (kind, rc, err.strip()))
        compare_items(kspec, download(ctx, kind), "our %s download" % kind)
    # One item too many: refused (MAV_MISSION_NO_SPACE), and the mission held stays.
    big = mission_spec(101)
    rc, _, err = upload(ctx, big, "mission", "big.waypoints")
    if rc == 0:
        raise CheckFailed("a 101-item mission was accepted")
    compare_items(spec, download(ctx, "mission"), "the mission after the refused upload")
    return ("100 items up in %.2f s and back in %.2f s; 4 fence vertices, 2 rally points; "
            "101 items refused, the 100 kept" % (t1 - t0, t2 - t1))


def command(ctx, *argv):
    rc, out, err = ctx.cli("command", "URI", *argv)
    try:
        return rc, json.loads(out)
    except ValueError:
        raise CheckFailed("command %s exited %d: %r %r" % (" ".join(argv), rc, out, err))


def armed_in_heartbeat(ctx):
    beats = ctx.heartbeats(1.5)
    if not beats:
        raise CheckFailed("no HEARTBEAT in 1.5 s")
    return bool(beats[-1][1].base_mode & MAV_MODE_FLAG_SAFETY_ARMED)


def check_our_command(ctx):
    rc, line = command(ctx, "COMPONENT_ARM_DISARM", "1")
    if rc != 0 or line["result"] != "MAV_RESULT_ACCEPTED":
        raise CheckFailed("arm: exit %d, %s" % (rc, line))
    if not armed_in_heartbeat(ctx):
        raise CheckFailed("armed, but the HEARTBEAT says disarmed")
    t0 = time.monotonic()
    rc, line = command(ctx, "PREFLIGHT_CALIBRATION", "1")
    took = time.monotonic() - t0
    if rc != 0 or line["result"] != "MAV_RESULT_ACCEPTED" or line["progress"] != [0, 25, 50, 75]:
        raise CheckFailed("calibration: exit %d, %s" % (rc, line))
    if took < 2.0:
        raise CheckFailed("calibration answered after %.2f s, not 2 s" % took)
    rc, line = command(ctx, "NAV_TAKEOFF")
    if rc != 1 or line["result"] != "MAV_RESULT_UNSUPPORTED":
        raise CheckFailed("NAV_TAKEOFF: exit %d, %s" % (rc, line))
    rc, line = command(ctx, "COMPONENT_ARM_DISARM", "0", "--int")
    if rc != 0 or line["result"] != "MAV_RESULT_ACCEPTED":
        raise CheckFailed("disarm (COMMAND_INT): exit %d, %s" % (rc, line))
    if armed_in_heartbeat(ctx):
        raise CheckFailed("disarmed, but the HEARTBEAT says armed")
    return ("arm ACCEPTED and in the HEARTBEAT; calibration progress [0, 25, 50, 75] then "
            "ACCEPTED in %.2f s; NAV_TAKEOFF UNSUPPORTED; disarm (COMMAND_INT) ACCEPTED" % took)


# param.pck (src/files.rs): ArduPilot's packed parameters. Its four types, and the one each
# MAV_PARAM_TYPE goes to: (code, struct format); the unsigned types widened, UINT32 as its bits.
PCK_TYPES = {1: "<b", 2: "<h", 3: "<i", 4: "<f"}
PCK_TYPE_OF = {"UINT8": 2, "INT8": 1, "UINT16": 3, "INT16": 2, "UINT32": 3, "INT32": 3,
               "REAL32": 4}
PCK_MAGIC, PCK_MAGIC_DEFAULTS = 0x671B, 0x671C
FTP_BLOCK = 239
PCK_PATH = "/@PARAM/param.pck"


def decode_pck(data, with_defaults):
    """param.pck, checked strictly: [(name, type code, value, default, value offset)]."""
    if len(data) < 6:
        raise CheckFailed("param.pck is %d bytes" % len(data))
    magic, count, total = struct.unpack("<HHH", data[:6])
    want = PCK_MAGIC_DEFAULTS if with_defaults else PCK_MAGIC
    if (magic, count, total) != (want, PARAM_COUNT, PARAM_COUNT):
        raise CheckFailed("param.pck header (magic, count, total) is (%#x, %d, %d)"
                          % (magic, count, total))
    out, at, last = [], 6, b""
    while at < len(data):
        if data[at] == 0:  # padding
            at += 1
            continue
        ty, flags, common, rest = data[at] & 15, data[at] >> 4, data[at + 1] & 15, \
            (data[at + 1] >> 4) + 1
        if ty not in PCK_TYPES or flags != (1 if with_defaults else 0) or common > len(last):
            raise CheckFailed("param.pck record at %d: type %d, flags %d, %d name bytes shared"
                              % (at, ty, flags, common))
        name = last[:common] + data[at + 2:at + 2 + rest]
        shared = 0
        while shared < min(len(name) - 1, len(last), 15) and name[shared] == last[shared]:
            shared += 1
        if common != shared:
            raise CheckFailed("param.pck shares %d bytes of %s with %s, not %d"
                              % (common, name, last, shared))
        fmt = PCK_TYPES[ty]
        size = struct.calcsize(fmt)
        start = at + 2 + rest
        end = start + size * (2 if with_defaults else 1)
        if end > len(data):
            raise CheckFailed("param.pck ends inside %s" % name)
        if start // FTP_BLOCK != (end - 1) // FTP_BLOCK:
            raise CheckFailed("%s's value (%d..%d) crosses a %d-byte block"
                              % (name, start, end, FTP_BLOCK))
        value = struct.unpack(fmt, data[start:start + size])[0]
        default = struct.unpack(fmt, data[start + size:end])[0] if with_defaults else None
        out.append((name.decode(), ty, value, default, start))
        last, at = name, end
    if len(out) != PARAM_COUNT:
        raise CheckFailed("param.pck holds %d parameters" % len(out))
    return out


def same_value(listed, ty, value):
    """Whether `value` of packed type `ty` is the value `param list` gave."""
    if PCK_TYPE_OF[listed["type"]] != ty:
        return False
    if listed["type"] == "REAL32":
        return f32(listed["value"]) == value
    return listed["value"] & 0xFFFFFFFF == value & 0xFFFFFFFF


def compare_pck(ctx, records):
    """Fails unless `records` hold what ``param list`` gives, in its order (SYS_STACK_USED
    only within the stack: it is live)."""
    listed = ctx.param_list()
    if [r[0] for r in records] != [p["name"] for p in listed]:
        raise CheckFailed("param.pck's names %s, param list's %s"
                          % ([r[0] for r in records], [p["name"] for p in listed]))
    for (name, ty, value, _, _), p in zip(records, listed):
        if name == "SYS_STACK_USED":
            if not (ty == 3 and 0 < value <= 16384):
                raise CheckFailed("param.pck's SYS_STACK_USED is %d (type %d)" % (value, ty))
        elif not same_value(p, ty, value):
            raise CheckFailed("param.pck has %s = %r (type %d), param list %r (%s)"
                              % (name, value, ty, p["value"], p["type"]))
    return listed


def ftp_ls(ctx, path):
    rc, out, err = ctx.cli("ftp", "ls", "URI", path)
    if rc != 0:
        raise CheckFailed("ftp ls %s exited %d: %s" % (path, rc, err.strip()))
    return [json.loads(line) for line in out.splitlines() if line.strip()]


def ftp_get(ctx, path):
    local = os.path.join(ctx.workdir, "got.pck")
    rc, _, err = ctx.cli("ftp", "get", "URI", path, local)
    if rc != 0:
        raise CheckFailed("ftp get %s exited %d: %s" % (path, rc, err.strip()))
    with open(local, "rb") as f:
        return f.read()


def check_our_ftp(ctx):
    root = ftp_ls(ctx, "/")
    if root != [{"name": "@PARAM", "kind": "dir", "size": 0}]:
        raise CheckFailed("ftp ls / printed %s" % root)
    listing = ftp_ls(ctx, "/@PARAM")
    if len(listing) != 1 or listing[0]["name"] != "param.pck" or listing[0]["kind"] != "file":
        raise CheckFailed("ftp ls /@PARAM printed %s" % listing)
    data = ftp_get(ctx, PCK_PATH)
    if len(data) != listing[0]["size"]:
        raise CheckFailed("param.pck is %d bytes, listed as %d" % (len(data), listing[0]["size"]))
    compare_pck(ctx, decode_pck(data, False))

    # A parameter away from its default, in the file with the defaults.
    name, new = "MC_PITCH_P", 6.75
    old = ctx.param_get(name)
    rc, got, err = ctx.param_set(name, new)
    if rc != 0 or got != new:
        raise CheckFailed("param set %s %s: exit %d, %s (%s)" % (name, new, rc, got, err))
    try:
        with_defaults = ftp_get(ctx, PCK_PATH + "?withdefaults=1")
    finally:
        ctx.param_set(name, old)
    # Every other parameter is at its default (the checks put them back), but SYS_STACK_USED
    # (0 by default).
    for n, _, v, d, _ in decode_pck(with_defaults, True):
        want = {name: (f32(new), f32(old)), "SYS_STACK_USED": (v, 0)}.get(n, (d, d))
        if (v, d) != want:
            raise CheckFailed("with defaults, %s is %r (default %r), not %r (default %r)"
                              % (n, v, d, *want))

    up = os.path.join(ctx.workdir, "up.pck")
    with open(up, "wb") as f:
        f.write(data)
    rc, _, err = ctx.cli("ftp", "put", "URI", up, PCK_PATH)
    if rc == 0 or "file protected" not in err:
        raise CheckFailed("ftp put %s: exit %d, %s" % (PCK_PATH, rc, err.strip()))
    return ("ls / and /@PARAM; param.pck %d B, the 64 values of param list; with defaults "
            "%d B, %s %g (default %g); put refused (file protected)"
            % (len(data), len(with_defaults), name, new, old))


def read_parm(path):
    """A parameter file as pymavlink's getparams writes it (Mission Planner's NAME,VALUE)."""
    out = {}
    with open(path) as f:
        for line in f:
            if line.strip():
                name, value = line.strip().split(",")
                out[name] = value
    return out


def parm_text(value):
    """A value as getparams writes it."""
    return format(value, ".6f").rstrip("0").rstrip(".")


def check_mavftp_params(ctx):
    from pymavlink import mavftp
    ftp = mavftp.MAVFTP(ctx.peer(), SYSID, COMPID)
    ret = ftp.cmd_list(["/@PARAM"])
    listing = [(e.name, e.is_dir) for e in ret.directory_listing if e.name not in (".", "..")]
    if ret.error_code != mavftp.FtpError.Success or listing != [("param.pck", False)]:
        raise CheckFailed("mavftp listed %s (%s)" % (listing, ret.error_code))
    values = os.path.join(ctx.workdir, "values.parm")
    defaults = os.path.join(ctx.workdir, "defaults.parm")
    t0 = time.monotonic()
    ftp.cmd_getparams([values, defaults])
    ret = ftp.process_ftp_reply("OpenFileRO", timeout=30)
    took = time.monotonic() - t0
    if ret.error_code != mavftp.FtpError.Success or ftp.callback_failure is not None:
        raise CheckFailed("getparams: %s %s" % (ret.error_code, ftp.callback_failure))
    got, got_defaults = read_parm(values), read_parm(defaults)
    listed = ctx.param_list()
    want = {p["name"]: parm_text(f32(p["value"]) if p["type"] == "REAL32" else p["value"])
            for p in listed}
    if len(got) != PARAM_COUNT or set(got) != set(want):
        raise CheckFailed("getparams wrote %d parameters: %s" % (len(got), sorted(got)))
    for n, v in want.items():
        if n != "SYS_STACK_USED" and got[n] != v:
            raise CheckFailed("getparams has %s = %s, param list %s" % (n, got[n], v))
        # Every parameter is at its default (the checks restore them), but SYS_STACK_USED.
        d = "0" if n == "SYS_STACK_USED" else v
        if got_defaults.get(n) != d:
            raise CheckFailed("getparams has %s's default %s, not %s"
                              % (n, got_defaults.get(n), d))
    note = "64 values and defaults as param list gives them, in %.2f s (80-byte bursts)" % took
    # MAVProxy's parameter module has a decoder of its own (it fetches param.pck with defaults).
    try:
        from MAVProxy.modules.lib import param_ftp
    except ImportError:
        return note + "; MAVProxy not installed"
    pdata = param_ftp.ftp_param_decode(ftp_get(ctx, PCK_PATH + "?withdefaults=1"))
    if pdata is None or pdata.defaults is None:
        raise CheckFailed("MAVProxy's decoder did not decode param.pck?withdefaults=1")
    for (n, v, _), (dn, d, _) in zip(pdata.params, pdata.defaults):
        n, dn = n.decode(), dn.decode()
        ok = n == dn and n in want and (
            n == "SYS_STACK_USED" or parm_text(v) == want[n] == parm_text(d))
        if not ok:
            raise CheckFailed("MAVProxy decoded %s = %r (default %s %r), param list %s"
                              % (n, v, dn, d, want.get(n)))
    if len(pdata.params) != PARAM_COUNT:
        raise CheckFailed("MAVProxy decoded %d parameters" % len(pdata.params))
    return note + "; MAVProxy's decoder agrees"


async def mavsdk_download(ftp, local_dir, burst):
    async for _result, _progress in ftp.download(PCK_PATH, local_dir, burst):
        pass
    with open(os.path.join(local_dir, "param.pck"), "rb") as f:
        return f.read()


def same_but_stack(a, b):
    """Whether two param.pck downloads are the same bytes but for SYS_STACK_USED's value."""
    if len(a) != len(b):
        return False
    at = {r[0]: r[4] for r in decode_pck(a, False)}["SYS_STACK_USED"]
    return a[:at] == b[:at] and a[at + 4:] == b[at + 4:]


@mavsdk_check
async def check_mavsdk_ftp(ctx):
    from mavsdk.asyncio.plugins.ftp import FtpAsync
    ours = ftp_get(ctx, PCK_PATH)
    mavsdk, system = await connect(ctx)
    notes = []
    try:
        ftp = FtpAsync(system)
        for path, want in (("/", [("@PARAM", 2, 0)]), ("/@PARAM", [("param.pck", 1, len(ours))])):
            listing = await ftp.list_directory(path)
            got = [(e.name, int(e.entry_type), e.size_bytes) for e in listing.entries]
            if got != want:
                raise CheckFailed("MAVSDK listed %s as %s, not %s" % (path, got, want))
            # MAVSDK closes the listing's session after it returns: let the answer come
            # before the next request (a late one draws a warning from MAVSDK).
            await asyncio.sleep(0.2)
        local = os.path.join(ctx.workdir, "mavsdk")
        os.makedirs(local, exist_ok=True)
        for burst in (False, True):
            t0 = time.monotonic()
            got = await mavsdk_download(ftp, local, burst)
            if not same_but_stack(got, ours):
                raise CheckFailed("MAVSDK's download (burst %s) differs from our CLI's: %d and "
                                  "%d bytes" % (burst, len(got), len(ours)))
            notes.append("%s %.2f s" % ("burst" if burst else "read", time.monotonic() - t0))
        # SYS_STACK_USED is refreshed with each HEARTBEAT: once more if it changed between the
        # download and the CRC.
        for attempt in range(2):
            if await ftp.are_files_identical(os.path.join(local, "param.pck"), PCK_PATH):
                break
            if attempt:
                raise CheckFailed("MAVSDK's CRC-32 of param.pck is not the firmware's")
            await mavsdk_download(ftp, local, True)
    finally:
        await mavsdk.__aexit__(None, None, None)
    return ("listings; param.pck (%d B) read as our CLI reads it (%s); CRC-32 the same"
            % (len(ours), ", ".join(notes)))


def stack_reserve():
    with open(MEMORY_X) as f:
        m = re.search(r"_stack_reserve\s*=\s*(\d+)([KM]?)\s*;", f.read())
    if not m:
        raise CheckFailed("no _stack_reserve in %s" % MEMORY_X)
    return int(m.group(1)) * {"": 1, "K": 1024, "M": 1 << 20}[m.group(2)]


def check_stack(ctx):
    # The figure is refreshed with each HEARTBEAT: wait for one after the other checks.
    time.sleep(1.1)
    used = ctx.param_get("SYS_STACK_USED")
    reserve = stack_reserve()
    if not 0 < used <= reserve:
        raise CheckFailed("SYS_STACK_USED is %d B, the reserve %d B" % (used, reserve))
    return "%d B of stack used at most, of memory.x's %d B reserve" % (used, reserve)


CHECKS = {
    "heartbeat": check_heartbeat,
    "mavsdk_params": check_mavsdk_params,
    "mavsdk_mission": check_mavsdk_mission,
    "mavsdk_arm": check_mavsdk_arm,
    "our_params": check_our_params,
    "our_mission": check_our_mission,
    "our_command": check_our_command,
    "our_ftp": check_our_ftp,
    "mavftp_params": check_mavftp_params,
    "mavsdk_ftp": check_mavsdk_ftp,
    "stack": check_stack,
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ferrolink", required=True)
    ap.add_argument("--firmware-port", type=int, required=True)
    ap.add_argument("--workdir")
    ap.add_argument("--only", action="append", default=[])
    args = ap.parse_args()
    args.ferrolink = os.path.abspath(args.ferrolink)
    own_workdir = args.workdir is None
    if own_workdir:
        args.workdir = tempfile.mkdtemp(prefix="firmware_qemu.")
    os.makedirs(args.workdir, exist_ok=True)
    only = [n for item in args.only for n in item.split(",") if n]
    ctx = Context(args)
    passed = failed = 0
    try:
        try:
            ctx.start_router(args.firmware_port)
        except CheckFailed as e:
            print("FAIL router: %s" % e, flush=True)
            print("0 passed, 1 failed", flush=True)
            return 1
        for name, check in CHECKS.items():
            if only and name not in only:
                continue
            t0 = time.monotonic()
            try:
                note = check(ctx)
            except CheckSkipped as e:
                print("skip %s: %s" % (name, e), flush=True)
                continue
            except CheckFailed as e:
                failed += 1
                print("FAIL %s: %s" % (name, e), flush=True)
                continue
            except Exception as e:  # a bug in the driver is a failure, not a crash
                failed += 1
                print("FAIL %s: %s: %s" % (name, type(e).__name__, e), flush=True)
                continue
            passed += 1
            print("ok   %s (%.1f s): %s" % (name, time.monotonic() - t0, note), flush=True)
    finally:
        ctx.stop()
        if own_workdir:
            shutil.rmtree(args.workdir, ignore_errors=True)
    print("%d passed, %d failed" % (passed, failed), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
