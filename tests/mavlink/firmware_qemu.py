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
  stack           SYS_STACK_USED after all of that, within memory.x's stack reserve.

Every check leaves the parameters as it found them.
"""
import argparse
import asyncio
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time

sys.dont_write_bytecode = True  # keep the source tree clean
os.environ.setdefault("MAVLINK20", "1")  # pymavlink: parse MAVLink 2

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from services_mavsdk import (  # noqa: E402
    CheckFailed, compare_items, f32, mavsdk_gcs, mission_spec, read_wpl, write_wpl)

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


def free_udp_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind((HOST, 0))
    port = s.getsockname()[1]
    s.close()
    return port


class Context:
    """What the checks share: the CLI, the router's UDP port, a pymavlink peer, a workdir."""

    def __init__(self, args):
        self.ferrolink = args.ferrolink
        self.workdir = args.workdir
        self.udp = free_udp_port()
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

    def heartbeats(self, seconds):
        """The firmware's HEARTBEATs over `seconds`, through a pymavlink peer of the router."""
        from pymavlink import mavutil
        if self.mav is None:
            self.mav = mavutil.mavlink_connection("udpout:%s:%d" % (HOST, self.udp),
                                                  source_system=250, source_component=190)
        # The router learns a UDP peer from what it sends.
        self.mav.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                    mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
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
