#!/usr/bin/env python3
"""Drive `ferrolink mavlink router` with real ground-station software.

Usage:
    router_gcs.py --router BIN --dialect-dir DIR --workdir DIR [--only NAME]...

DIR for --dialect-dir holds pymavlink's MAVLink 2 dialect XMLs (common.xml,
ardupilotmega.xml), e.g. .venv/lib/python3.11/site-packages/pymavlink/dialects/v20.

Checks (each prints `ok   NAME`, `FAIL NAME: detail` or `skip NAME: why`; the
last line is `N passed, M failed`; the exit status is 0 only if nothing failed):

  mavsdk        A vehicle built from MAVSDK's server plugins (ParamServer,
                MissionRawServer, TelemetryServer) runs as an autopilot (sysid 1,
                compid 1) behind the router; a MAVSDK ground station on another
                router endpoint lists the parameters, sets an int and a float one,
                uploads a mission and downloads it back (MissionRaw), and reads the
                position and battery the vehicle publishes.  The vehicle talks to
                the router's udpin endpoint, the router's udpout endpoint talks to
                the ground station.  Needs the `mavsdk` package, version 4 or later:
                the native binding that embeds the MAVSDK C++ core in-process (it has
                no mavsdk_server and no gRPC).  Vehicle and ground station are two
                MAVSDK instances in two processes, configured with
                ComponentType.AUTOPILOT (sysid 1, compid 1, set explicitly) and
                ComponentType.GROUND_STATION (MAVSDK's 245/190).
  mavproxy      MAVProxy connects over TCP (router tcpin) and fetches the parameters
                of a small pymavlink vehicle (sysid 1, compid 1, on the router's
                udpin) that serves 20 parameters.  The vehicle leaves one parameter
                out of its answer to PARAM_REQUEST_LIST, so MAVProxy has to ask for
                it by index with PARAM_REQUEST_READ; it answers MAVProxy's MAVLink
                FTP parameter download with a NAK so MAVProxy falls back to the
                parameter protocol.  Passes when MAVProxy reports and saves all 20
                parameters with the vehicle's values.  Needs the `MAVProxy` package.
  tlog_matches  The router tlog of every check above that ran (run alone, those an
                earlier run left in --workdir): every record is an
                8-byte big-endian timestamp and one well-formed MAVLink frame (CRC
                checked for the ids the dialect knows), timestamps never go back and
                lie within the router's lifetime, pymavlink
                (mavlink_connection(path, dialect="common")) decodes the file to
                exactly the same frames, and the router's final --stats-json line
                counts as many received frames as the tlog holds.

Every check starts its own router, with its tlog in --workdir, and stops it with
SIGTERM, which must end it with status 0.  A check whose package is missing
prints `skip` and does not count as failed.

--workdir gets NAME.tlog, NAME.stats.jsonl and NAME.router.log per check, and
NAME/ with the helpers' logs (MAVProxy's own state, mav.parm and mav.tlog, in
mavproxy/state/).

The script also runs its own helper processes (vehicles, the MAVSDK ground
station): `router_gcs.py --role ROLE ...`.  They are internal.
"""

import argparse
import asyncio
import importlib.util
import json
import math
import os
import re
import signal
import struct
import subprocess
import sys
import threading
import time

sys.dont_write_bytecode = True  # keep the source tree clean
from ports import free_port  # noqa: E402

# pymavlink picks its MAVLink 1 or 2 module when mavutil is imported.
os.environ["MAVLINK20"] = "1"

CHECKS = ("mavsdk", "mavproxy", "tlog_matches")
HOST = "127.0.0.1"

# The MAVSDK vehicle's parameters, and what the ground station sets.
MAVSDK_INT_PARAMS = {"FL_MODE": 3, "FL_ARM_CHECK": 1, "FL_BATT_CELLS": 4}
MAVSDK_FLOAT_PARAMS = {"FL_ROLL_P": 0.15, "FL_PITCH_P": 0.125, "FL_WP_SPEED": 5.5}
MAVSDK_SET_INT = ("FL_BATT_CELLS", 6)
MAVSDK_SET_FLOAT = ("FL_ROLL_P", 0.25)
# What the MAVSDK vehicle publishes.
TEL_LAT, TEL_LON, TEL_ALT_ABS, TEL_ALT_REL = 47.397742, 8.545594, 488.25, 12.5
TEL_BATT_V = 15.25
TEL_BATT_FRACTION = 0.66  # TelemetryServer takes 0..1, Telemetry reports percent

# The pymavlink vehicle's parameters: 20, ints and floats, MAVProxy must get all.
PARAM_VEHICLE_GAP = 7  # left out of the answer to PARAM_REQUEST_LIST


def param_vehicle_table():
    names = ["SYSID_THISMAV", "FRAME_CLASS", "FRAME_TYPE", "ARMING_CHECK",
             "BATT_CAPACITY", "BATT_LOW_VOLT", "BATT_CRT_VOLT", "ATC_RAT_RLL_P",
             "ATC_RAT_RLL_I", "ATC_RAT_PIT_P", "ATC_RAT_PIT_I", "ATC_RAT_YAW_P",
             "WPNAV_SPEED", "WPNAV_RADIUS", "RTL_ALT", "FENCE_ENABLE",
             "FENCE_RADIUS", "LOG_BITMASK", "SERIAL0_BAUD", "INS_GYRO_FILTER"]
    ints = {"SYSID_THISMAV": 1, "FRAME_CLASS": 1, "FRAME_TYPE": 1,
            "ARMING_CHECK": 1, "BATT_CAPACITY": 5200, "FENCE_ENABLE": 0,
            "LOG_BITMASK": 176126, "SERIAL0_BAUD": 115, "RTL_ALT": 1500}
    floats = {"BATT_LOW_VOLT": 10.5, "BATT_CRT_VOLT": 9.75,
              "ATC_RAT_RLL_P": 0.135, "ATC_RAT_RLL_I": 0.135,
              "ATC_RAT_PIT_P": 0.135, "ATC_RAT_PIT_I": 0.135,
              "ATC_RAT_YAW_P": 0.18, "WPNAV_SPEED": 1000.0, "WPNAV_RADIUS": 200.0,
              "FENCE_RADIUS": 300.0, "INS_GYRO_FILTER": 20.0}
    table = []
    for name in names:
        if name in ints:
            table.append((name, float(ints[name]), 6))  # MAV_PARAM_TYPE_INT32
        else:
            # store the float32 value, which is what goes over the wire
            v = struct.unpack("<f", struct.pack("<f", floats[name]))[0]
            table.append((name, v, 9))  # MAV_PARAM_TYPE_REAL32
    return table


def mission_items_spec():
    """(seq, frame, command, current, autocontinue, p1, p2, p3, p4, x, y, z)."""
    nan = float("nan")
    lat, lon = int(47.397742e7), int(8.545594e7)
    return [
        (0, 6, 22, 1, 1, 0.0, 0.0, 0.0, nan, lat, lon, 10.0),          # TAKEOFF
        (1, 6, 16, 0, 1, 0.0, 2.0, 0.0, nan, lat + 1500, lon, 20.0),   # WAYPOINT
        (2, 6, 16, 0, 1, 3.0, 2.0, 0.0, 90.0, lat + 1500, lon + 2200, 25.0),
        (3, 6, 16, 0, 1, 0.0, 2.0, 0.0, nan, lat, lon + 2200, 15.5),
        (4, 2, 20, 0, 1, 0.0, 0.0, 0.0, 0.0, 0, 0, 0.0),               # RTL
    ]


# --------------------------------------------------------------------------
# Small helpers
# --------------------------------------------------------------------------

class CheckFailed(Exception):
    pass


class CheckSkipped(Exception):
    pass


def now_us():
    return int(time.time() * 1e6)


def read_text(path, limit=None):
    try:
        with open(path, "r", errors="replace") as f:
            text = f.read()
    except OSError:
        return ""
    if limit is not None and len(text) > limit:
        text = "..." + text[-limit:]
    return text


ANSI = re.compile(r"\x1b\[[0-9;]*m")


def tail(path, n=8):
    """The last lines of a log, on one line, without terminal colours."""
    lines = ANSI.sub("", read_text(path)).strip().splitlines()
    return " | ".join(line.strip() for line in lines[-n:])


def read_json_lines(path):
    out = []
    for line in read_text(path).splitlines():
        line = line.strip()
        if line:
            try:
                out.append(json.loads(line))
            except ValueError:
                pass
    return out


def same_float(a, b, rel=1e-6, abs_tol=1e-6):
    if a is None or b is None:
        return a is b
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return math.isclose(a, b, rel_tol=rel, abs_tol=abs_tol)


def script_cmd(role, *args):
    return [sys.executable, os.path.abspath(__file__), "--role", role] + list(args)


class Proc:
    """A helper process we started, in its own session, output to a file."""

    def __init__(self, name, cmd, log_path, env=None, cwd=None):
        self.name = name
        self.log_path = log_path
        self.log = open(log_path, "wb")
        self.p = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=self.log,
                                  stderr=subprocess.STDOUT, env=env, cwd=cwd,
                                  start_new_session=True)

    def alive(self):
        return self.p.poll() is None

    def stop(self, sig=signal.SIGTERM, timeout=10.0):
        """Signal the process; kill its process group if it does not end in time.
        Returns (exit status, True if it ended by itself after the signal)."""
        clean = True
        if self.p.poll() is None:
            try:
                self.p.send_signal(sig)
            except ProcessLookupError:
                pass
            try:
                self.p.wait(timeout)
            except subprocess.TimeoutExpired:
                clean = False
        if self.p.poll() is None or not clean:
            try:
                os.killpg(self.p.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            self.p.wait(5)
        self.log.close()
        return self.p.returncode, clean


class Router:
    """One `ferrolink mavlink router` run for one check."""

    def __init__(self, args, name, dialect, endpoints):
        self.name = name
        self.tlog = os.path.join(args.workdir, name + ".tlog")
        self.stats = os.path.join(args.workdir, name + ".stats.jsonl")
        self.out_path = os.path.join(args.workdir, name + ".router.log")
        self.run_path = os.path.join(args.workdir, name + ".run.json")
        for path in (self.tlog, self.stats, self.run_path):
            if os.path.exists(path):
                os.remove(path)
        self.dialect = os.path.join(args.dialect_dir, dialect)
        self.cmd = [args.router, "mavlink", "router", "--dialect", self.dialect,
                    "--tlog", self.tlog, "--stats-json", self.stats,
                    # a safety net only: the check stops it with SIGTERM long before
                    "--run-for", "180"] + list(endpoints)
        self.lines = []
        self.ready = threading.Event()
        self.p = None
        self.t_start_us = self.t_stop_us = None
        self.stopped = False

    def start(self, timeout=10.0):
        if not os.path.isfile(self.dialect):
            raise CheckFailed("no dialect file %s" % self.dialect)
        self.t_start_us = now_us()
        self.p = subprocess.Popen(self.cmd, stdin=subprocess.DEVNULL,
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                  start_new_session=True)
        threading.Thread(target=self._reader, daemon=True).start()
        if not self.ready.wait(timeout) or self.p.poll() is not None:
            self.kill()
            raise CheckFailed("router did not print 'ready' within %.0f s: %s"
                              % (timeout, " | ".join(self.lines[-5:])))

    def _reader(self):
        with open(self.out_path, "w") as log:
            for raw in self.p.stdout:
                line = raw.decode(errors="replace").rstrip("\n")
                self.lines.append(line)
                log.write(line + "\n")
                log.flush()
                if "ready" in line:
                    self.ready.set()

    def stop(self, timeout=10.0):
        """SIGTERM; the router must end with status 0."""
        if self.stopped or self.p is None:
            return
        self.stopped = True
        if self.p.poll() is not None:
            raise CheckFailed("router ended by itself with status %s before SIGTERM: %s"
                              % (self.p.returncode, " | ".join(self.lines[-5:])))
        self.p.send_signal(signal.SIGTERM)
        try:
            rc = self.p.wait(timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise CheckFailed("router still running %.0f s after SIGTERM" % timeout)
        finally:
            self.t_stop_us = now_us()
            self.save_run()
        if rc != 0:
            raise CheckFailed("router exited with status %s after SIGTERM: %s"
                              % (rc, " | ".join(self.lines[-5:])))

    def kill(self):
        self.stopped = True
        if self.p is not None and self.p.poll() is None:
            try:
                os.killpg(self.p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self.p.wait(5)
        if self.t_stop_us is None:
            self.t_stop_us = now_us()
            self.save_run()

    def save_run(self):
        """What tlog_matches needs to check this tlog in a later invocation."""
        with open(self.run_path, "w") as f:
            json.dump({"name": self.name, "tlog": self.tlog, "stats": self.stats,
                       "dialect": self.dialect, "t_start_us": self.t_start_us,
                       "t_stop_us": self.t_stop_us}, f)


def wait_for_file_text(path, needles, timeout, procs=()):
    """Wait until the file contains one of `needles`; returns the needle or None.
    Gives up early when one of `procs` has ended."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        text = read_text(path)
        for needle in needles:
            if needle in text:
                return needle
        if any(not p.alive() for p in procs):
            return None
        time.sleep(0.1)
    return None


# --------------------------------------------------------------------------
# Check: mavsdk
# --------------------------------------------------------------------------

def mavsdk_available():
    if importlib.util.find_spec("mavsdk") is None:
        raise CheckSkipped("Python package 'mavsdk' is not installed (pip install 'mavsdk>=4')")
    try:
        from importlib.metadata import version
        ver = version("mavsdk")
    except Exception:
        ver = "?"
    try:
        major = int(ver.split(".")[0])
    except ValueError:
        major = 0
    if major < 4 or importlib.util.find_spec("mavsdk.asyncio") is None:
        raise CheckSkipped("mavsdk %s is the old gRPC wrapper; this check drives the native "
                           "MAVSDK binding, mavsdk>=4" % ver)
    return ver


def check_mavsdk(args):
    mavsdk_available()
    wd = os.path.join(args.workdir, "mavsdk")
    os.makedirs(wd, exist_ok=True)
    p_vehicle = free_port()
    p_gcs = free_port()
    router = Router(args, "mavsdk", "common.xml",
                    ["udpin://%s:%d" % (HOST, p_vehicle), "udpout://%s:%d" % (HOST, p_gcs)])
    vehicle_events = os.path.join(wd, "vehicle.jsonl")
    gcs_result = os.path.join(wd, "gcs.json")
    for path in (vehicle_events, gcs_result):
        if os.path.exists(path):
            os.remove(path)
    vehicle = gcs = None
    router.start()
    args.tlogs.append(router)
    try:
        vehicle = Proc("vehicle", script_cmd("mavsdk-vehicle", "--url", "udpout://%s:%d" % (HOST, p_vehicle),
                                             "--out", vehicle_events, "--duration", "55"),
                       os.path.join(wd, "vehicle.log"))
        if not wait_for_file_text(vehicle_events, ['"event": "ready"'], 10, [vehicle]):
            raise CheckFailed("MAVSDK vehicle did not come up: %s" % tail(vehicle.log_path))
        gcs = Proc("gcs", script_cmd("mavsdk-gcs", "--url", "udpin://%s:%d" % (HOST, p_gcs),
                                     "--out", gcs_result, "--duration", "35"),
                   os.path.join(wd, "gcs.log"))
        try:
            gcs.p.wait(45)
        except subprocess.TimeoutExpired:
            pass
        gcs_rc, _ = gcs.stop(signal.SIGTERM, 5)
        _, vehicle_clean = vehicle.stop(signal.SIGTERM, 10)
        router.stop()

        failures = []
        result = read_json_lines(gcs_result)
        result = result[-1] if result else None
        if result is None:
            raise CheckFailed("MAVSDK ground station wrote no result (status %s): %s"
                              % (gcs_rc, tail(gcs.log_path)))
        failures += result.get("failures", [])
        if not result.get("finished"):
            failures.append("ground station did not finish (status %s): %s"
                            % (gcs_rc, tail(gcs.log_path, 4)))

        events = read_json_lines(vehicle_events)
        cfg = [e for e in events if e.get("event") == "config"]
        if not cfg or (cfg[0]["sysid"], cfg[0]["compid"]) != (1, 1):
            failures.append("vehicle configuration is not sysid 1 compid 1: %s" % cfg)
        changed = {(e["name"], e["value"]) for e in events if e.get("event") == "param_changed"}
        if (MAVSDK_SET_INT[0], MAVSDK_SET_INT[1]) not in changed:
            failures.append("vehicle's ParamServer never saw %s set to %s (saw %s)"
                            % (MAVSDK_SET_INT[0], MAVSDK_SET_INT[1], sorted(changed)))
        if not any(n == MAVSDK_SET_FLOAT[0] and same_float(v, MAVSDK_SET_FLOAT[1], 1e-6)
                   for n, v in changed):
            failures.append("vehicle's ParamServer never saw %s set to %s (saw %s)"
                            % (MAVSDK_SET_FLOAT[0], MAVSDK_SET_FLOAT[1], sorted(changed)))
        incoming = [e for e in events if e.get("event") == "incoming_mission"]
        if not incoming:
            failures.append("vehicle's MissionRawServer never received the mission")
        else:
            diff = compare_mission(incoming[-1]["items"])
            if diff:
                failures.append("mission as the vehicle received it: " + diff)
        if not vehicle_clean:
            failures.append("MAVSDK vehicle did not end within 10 s of SIGTERM")
        if failures:
            raise CheckFailed("; ".join(failures))
        return "discovered sysid %s compids %s; %s" % (
            result.get("sysid"), result.get("component_ids"), result.get("summary", ""))
    finally:
        for p in (gcs, vehicle):
            if p is not None and p.alive():
                p.stop(signal.SIGKILL, 5)
        router.kill()


def compare_mission(items):
    """items: list of dicts as written by item_to_dict; '' when they match the spec."""
    spec = mission_items_spec()
    if len(items) != len(spec):
        return "%d items instead of %d" % (len(items), len(spec))
    keys = ("seq", "frame", "command", "current", "autocontinue", "param1", "param2",
            "param3", "param4", "x", "y", "z")
    for want, got in zip(spec, items):
        for k, w in zip(keys, want):
            g = got.get(k)
            if isinstance(w, float):
                ok = same_float(float("nan") if g is None else g, w, 1e-6)
            else:
                ok = g == w
            if not ok:
                return "item %d: %s is %r, uploaded %r" % (want[0], k, g, w)
    return ""


def item_to_dict(item):
    d = {}
    for k in ("seq", "frame", "command", "current", "autocontinue", "param1", "param2",
              "param3", "param4", "x", "y", "z", "mission_type"):
        v = getattr(item, k)
        if isinstance(v, float) and not math.isfinite(v):
            v = None  # strict JSON; NaN is the only non-finite value we use
        d[k] = v
    return d


class JsonOut:
    def __init__(self, path):
        self.f = open(path, "w")

    def write(self, obj):
        self.f.write(json.dumps(obj, sort_keys=True) + "\n")
        self.f.flush()


async def role_mavsdk_vehicle(a):
    from mavsdk.asyncio import Mavsdk, Configuration, ComponentType
    from mavsdk.asyncio.plugins.param_server import ParamServerAsync
    from mavsdk.asyncio.plugins.mission_raw_server import MissionRawServerAsync
    from mavsdk.asyncio.plugins.telemetry_server import TelemetryServerAsync
    from mavsdk.plugins import telemetry_server as ts

    out = JsonOut(a.out)
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    loop.add_signal_handler(signal.SIGTERM, stop.set)
    loop.add_signal_handler(signal.SIGINT, stop.set)

    # An autopilot component: MAVSDK then sends HEARTBEATs as MAV_TYPE_GENERIC /
    # MAV_AUTOPILOT_GENERIC from the start and its server plugins answer requests.
    cfg = Configuration.create_with_component_type(ComponentType.AUTOPILOT)
    cfg.system_id = 1
    cfg.component_id = 1
    out.write({"event": "config", "sysid": cfg.system_id, "compid": cfg.component_id})
    async with Mavsdk(cfg) as mavsdk:
        await mavsdk.add_any_connection(a.url)
        component = await mavsdk.server_component()
        params = ParamServerAsync(component)
        for name, value in MAVSDK_INT_PARAMS.items():
            await params.provide_param_int(name, value)
        for name, value in MAVSDK_FLOAT_PARAMS.items():
            await params.provide_param_float(name, value)
        mission = MissionRawServerAsync(component)
        telemetry = TelemetryServerAsync(component)

        async def watch_ints():
            async for p in params.subscribe_changed_param_int():
                out.write({"event": "param_changed", "name": p.name, "value": p.value})

        async def watch_floats():
            async for p in params.subscribe_changed_param_float():
                out.write({"event": "param_changed", "name": p.name, "value": p.value})

        async def watch_mission():
            async for result, plan in mission.subscribe_incoming_mission():
                out.write({"event": "incoming_mission", "result": str(result),
                           "items": [item_to_dict(i) for i in plan.mission_items]})

        async def publish():
            position = ts.Position(latitude_deg=TEL_LAT, longitude_deg=TEL_LON,
                                   absolute_altitude_m=TEL_ALT_ABS,
                                   relative_altitude_m=TEL_ALT_REL)
            velocity = ts.VelocityNed(north_m_s=0.0, east_m_s=0.0, down_m_s=0.0)
            heading = ts.Heading(heading_deg=90.0)
            battery = ts.Battery(voltage_v=TEL_BATT_V, remaining_percent=TEL_BATT_FRACTION)
            while True:
                await telemetry.publish_position(position, velocity, heading)
                await telemetry.publish_battery(battery)
                await asyncio.sleep(0.2)

        tasks = [asyncio.ensure_future(c()) for c in
                 (watch_ints, watch_floats, watch_mission, publish)]
        out.write({"event": "ready"})
        try:
            await asyncio.wait_for(stop.wait(), a.duration)
        except asyncio.TimeoutError:
            pass
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        out.write({"event": "stopping"})
    return 0


async def first_matching(agen, pred):
    async for value in agen:
        if pred(value):
            return value


async def role_mavsdk_gcs(a):
    from mavsdk.asyncio import Mavsdk, Configuration, ComponentType
    from mavsdk.asyncio.plugins.param import ParamAsync
    from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync, MissionItem
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    out = JsonOut(a.out)
    res = {"failures": [], "finished": False}
    steps = []
    t0 = time.monotonic()

    def fail(msg):
        res["failures"].append(msg)
        out.write(res)

    def step(msg):
        steps.append("%s %.1fs" % (msg, time.monotonic() - t0))
        res["summary"] = ", ".join(steps)
        out.write(res)

    class Abort(Exception):
        pass

    def need(ok, msg):
        if not ok:
            fail(msg)
            raise Abort()

    async def session(mavsdk):
        res["stage"] = "discovering the autopilot"
        await mavsdk.add_any_connection(a.url)
        system = await mavsdk.first_autopilot(15.0)
        need(system is not None, "no autopilot discovered within 15 s")
        res["sysid"] = await system.get_system_id()
        res["component_ids"] = sorted(await system.component_ids())
        if res["sysid"] != 1 or 1 not in res["component_ids"]:
            fail("autopilot is sysid %s components %s, not 1/1"
                 % (res["sysid"], res["component_ids"]))
        step("autopilot found")

        # Parameters: list them all, set an int and a float one.
        res["stage"] = "listing parameters"
        param = ParamAsync(system)
        allp = await param.get_all_params()
        ints = {p.name: p.value for p in allp.int_params}
        floats = {p.name: p.value for p in allp.float_params}
        if ints != MAVSDK_INT_PARAMS:
            fail("int params listed %s, vehicle has %s" % (ints, MAVSDK_INT_PARAMS))
        if set(floats) != set(MAVSDK_FLOAT_PARAMS) or not all(
                same_float(floats[k], v, 1e-6) for k, v in MAVSDK_FLOAT_PARAMS.items()):
            fail("float params listed %s, vehicle has %s" % (floats, MAVSDK_FLOAT_PARAMS))
        step("%d params listed" % (len(ints) + len(floats)))
        res["stage"] = "setting parameters"
        await param.set_param_int(*MAVSDK_SET_INT)
        await param.set_param_float(*MAVSDK_SET_FLOAT)
        got_i = await param.get_param_int(MAVSDK_SET_INT[0])
        got_f = await param.get_param_float(MAVSDK_SET_FLOAT[0])
        if got_i != MAVSDK_SET_INT[1] or not same_float(got_f, MAVSDK_SET_FLOAT[1], 1e-6):
            fail("after set, %s=%s %s=%s" % (MAVSDK_SET_INT[0], got_i,
                                             MAVSDK_SET_FLOAT[0], got_f))
        step("int and float param set")

        # Mission: upload, download, compare.
        res["stage"] = "uploading the mission"
        mission = MissionRawAsync(system)
        items = [MissionItem(seq=s, frame=f, command=c, current=cur, autocontinue=ac,
                             param1=p1, param2=p2, param3=p3, param4=p4, x=x, y=y, z=z,
                             mission_type=0)
                 for (s, f, c, cur, ac, p1, p2, p3, p4, x, y, z) in mission_items_spec()]
        await mission.upload_mission(items)
        step("mission uploaded")
        res["stage"] = "downloading the mission"
        down = await mission.download_mission()
        diff = compare_mission([item_to_dict(i) for i in down])
        if diff:
            fail("mission downloaded back: " + diff)
        step("%d mission items downloaded" % len(down))

        # Telemetry the vehicle's TelemetryServer publishes.
        res["stage"] = "reading telemetry"
        telemetry = TelemetryAsync(system)
        pos = await first_matching(telemetry.subscribe_position(),
                                   lambda p: not math.isnan(p.latitude_deg))
        bat = await first_matching(telemetry.subscribe_battery(),
                                   lambda b: not math.isnan(b.voltage_v))
        if not (same_float(pos.latitude_deg, TEL_LAT, 0, 1e-6)
                and same_float(pos.longitude_deg, TEL_LON, 0, 1e-6)
                and same_float(pos.absolute_altitude_m, TEL_ALT_ABS, 0, 0.01)
                and same_float(pos.relative_altitude_m, TEL_ALT_REL, 0, 0.01)):
            fail("position %s, vehicle publishes %s %s %s %s"
                 % (pos, TEL_LAT, TEL_LON, TEL_ALT_ABS, TEL_ALT_REL))
        if not (same_float(bat.voltage_v, TEL_BATT_V, 0, 0.001)
                and same_float(bat.remaining_percent, TEL_BATT_FRACTION * 100, 0, 0.5)):
            fail("battery %s, vehicle publishes %s V %s" % (bat, TEL_BATT_V, TEL_BATT_FRACTION))
        step("position %.6f,%.6f and battery %.2f V %.0f%% read"
             % (pos.latitude_deg, pos.longitude_deg, bat.voltage_v, bat.remaining_percent))
        res["stage"] = "done"
        res["finished"] = True
        out.write(res)

    cfg = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(cfg) as mavsdk:
        try:
            await asyncio.wait_for(session(mavsdk), a.duration)
        except Abort:
            pass
        except asyncio.TimeoutError:
            fail("timed out after %.0f s while %s" % (a.duration, res.get("stage")))
        except Exception as e:  # MAVSDK reports a failed request as an exception
            fail("%s: %s: %s" % (res.get("stage"), type(e).__name__, e))
    return 0 if res["finished"] and not res["failures"] else 1


# --------------------------------------------------------------------------
# Check: mavproxy
# --------------------------------------------------------------------------

def check_mavproxy(args):
    if importlib.util.find_spec("MAVProxy") is None:
        raise CheckSkipped("Python package 'MAVProxy' is not installed (pip install MAVProxy)")
    wd = os.path.join(args.workdir, "mavproxy")
    state = os.path.join(wd, "state")
    home = os.path.join(wd, "home")
    for d in (wd, state, home):
        os.makedirs(d, exist_ok=True)
    for name in ("mav.parm", "mav.tlog", "mav.tlog.raw"):
        if os.path.exists(os.path.join(state, name)):
            os.remove(os.path.join(state, name))
    p_vehicle = free_port()
    p_gcs = free_port()
    router = Router(args, "mavproxy", "ardupilotmega.xml",
                    ["udpin://%s:%d" % (HOST, p_vehicle), "tcpin://%s:%d" % (HOST, p_gcs)])
    vehicle_events = os.path.join(wd, "vehicle.jsonl")
    if os.path.exists(vehicle_events):
        os.remove(vehicle_events)
    vehicle = mavproxy = None
    router.start()
    args.tlogs.append(router)
    try:
        vehicle = Proc("vehicle", script_cmd("param-vehicle", "--url", "udpout:%s:%d" % (HOST, p_vehicle),
                                             "--out", vehicle_events, "--duration", "55"),
                       os.path.join(wd, "vehicle.log"))
        if not wait_for_file_text(vehicle_events, ['"event": "ready"'], 10, [vehicle]):
            raise CheckFailed("pymavlink vehicle did not come up: %s" % tail(vehicle.log_path))
        env = dict(os.environ)
        env.update({"HOME": home, "PYTHONUNBUFFERED": "1", "MPLBACKEND": "Agg"})
        env.pop("DISPLAY", None)
        cmd = [sys.executable, "-m", "MAVProxy.mavproxy",
               "--master=tcp:%s:%d" % (HOST, p_gcs),
               "--daemon", "--non-interactive", "--state-basedir=" + state]
        t_mp = time.monotonic()
        mavproxy = Proc("mavproxy", cmd, os.path.join(wd, "mavproxy.log"), env=env, cwd=wd)
        n = len(param_vehicle_table())
        got = wait_for_file_text(mavproxy.log_path, ["Saved %d parameters to" % n], 35, [mavproxy])
        elapsed = time.monotonic() - t_mp
        time.sleep(0.5)  # let the file be written completely
        mavproxy.stop(signal.SIGTERM, 10)
        _, vehicle_clean = vehicle.stop(signal.SIGTERM, 10)
        router.stop()

        log = read_text(mavproxy.log_path)
        if not got:
            raise CheckFailed("MAVProxy did not report 'Saved %d parameters' within 35 s: %s"
                              % (n, tail(mavproxy.log_path)))
        failures = []
        if "Received %d parameters" % n not in log:
            failures.append("MAVProxy did not print 'Received %d parameters'" % n)
        parm = parse_mav_parm(os.path.join(state, "mav.parm"))
        want = {name: value for name, value, _ in param_vehicle_table()}
        if set(parm) != set(want):
            failures.append("mav.parm has %s; missing %s, extra %s"
                            % (len(parm), sorted(set(want) - set(parm)), sorted(set(parm) - set(want))))
        for name, value in sorted(want.items()):
            if name in parm and not math.isclose(parm[name], value, rel_tol=1e-5, abs_tol=1e-5):
                failures.append("%s is %s in mav.parm, vehicle has %s" % (name, parm[name], value))

        events = read_json_lines(vehicle_events)
        rx = [e for e in events if e.get("event") == "rx"]
        lists = [e for e in rx if e["type"] == "PARAM_REQUEST_LIST"]
        reads = [e for e in rx if e["type"] == "PARAM_REQUEST_READ"]
        if not lists:
            failures.append("vehicle never got PARAM_REQUEST_LIST")
        elif lists[0]["src"] != [255, 230]:
            failures.append("PARAM_REQUEST_LIST came from %s, not MAVProxy's 255/230" % lists[0]["src"])
        if not any(e.get("param_index") == PARAM_VEHICLE_GAP for e in reads):
            failures.append("vehicle never got PARAM_REQUEST_READ for index %d (MAVProxy's re-request)"
                            % PARAM_VEHICLE_GAP)
        ftp_requests = [e for e in rx if e["type"] == "FILE_TRANSFER_PROTOCOL"]
        ftp_replies = count_in_tlog(os.path.join(state, "mav.tlog"), "FILE_TRANSFER_PROTOCOL", 1)
        # MAVProxy flushes its tlog only now and then, so an empty one proves nothing. It
        # ends the session (opcode 1) only on reading the NAK to its open (opcode 4); a lost
        # NAK would make it resend the open instead.
        opens = sum(1 for e in ftp_requests if e.get("opcode") == 4)
        ended = any(e.get("opcode") == 1 for e in ftp_requests)
        if ftp_requests and ftp_replies == 0 and not (ended and opens == 1):
            failures.append("vehicle answered %d MAVLink FTP requests (%d opens) but MAVProxy "
                            "neither ended the session nor logged a FILE_TRANSFER_PROTOCOL from "
                            "sysid 1" % (len(ftp_requests), opens))
        if not vehicle_clean:
            failures.append("pymavlink vehicle did not end within 10 s of SIGTERM")
        if failures:
            raise CheckFailed("; ".join(failures))
        return "%d params in %.1f s; vehicle got %d PARAM_REQUEST_LIST, %d PARAM_REQUEST_READ, " \
               "%d FTP requests (MAVProxy got %d FTP replies)" % (
                   len(parm), elapsed, len(lists), len(reads), len(ftp_requests), ftp_replies)
    finally:
        for p in (mavproxy, vehicle):
            if p is not None and p.alive():
                p.stop(signal.SIGKILL, 5)
        router.kill()


def parse_mav_parm(path):
    out = {}
    for line in read_text(path).splitlines():
        parts = line.split("#")[0].split()
        if len(parts) >= 2:
            try:
                out[parts[0]] = float(parts[1])
            except ValueError:
                pass
    return out


def count_in_tlog(path, mtype, src_system):
    if not os.path.isfile(path):
        return 0
    from pymavlink import mavutil
    conn = mavutil.mavlink_connection(path, dialect="ardupilotmega")
    n = 0
    try:
        while True:
            m = conn.recv_match(type=mtype)
            if m is None:
                break
            if m.get_srcSystem() == src_system:
                n += 1
    finally:
        conn.close()
    return n


def role_param_vehicle(a):
    from pymavlink import mavutil
    mav = mavutil.mavlink  # the MAVLink 2 ardupilotmega module
    out = JsonOut(a.out)
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    table = param_vehicle_table()
    conn = mavutil.mavlink_connection(a.url, source_system=1, source_component=1,
                                      dialect="ardupilotmega")
    values = {name: value for name, value, _ in table}
    index_of = {name: i for i, (name, _, _) in enumerate(table)}
    list_requests = 0

    def send_param(i):
        name, _, ptype = table[i]
        conn.mav.param_value_send(name.encode(), values[name], ptype, len(table), i)

    out.write({"event": "ready"})
    t_end = time.monotonic() + a.duration
    last_hb = 0.0
    while not stop and time.monotonic() < t_end:
        if time.monotonic() - last_hb >= 1.0:
            conn.mav.heartbeat_send(mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                    mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0,
                                    mav.MAV_STATE_STANDBY)
            last_hb = time.monotonic()
        try:
            m = conn.recv_match(blocking=True, timeout=0.05)
        except OSError:
            m = None  # e.g. ECONNREFUSED before the router listens
        if m is None:
            continue
        mtype = m.get_type()
        if mtype in ("HEARTBEAT", "BAD_DATA"):
            continue
        ev = {"event": "rx", "type": mtype, "src": [m.get_srcSystem(), m.get_srcComponent()]}
        target = getattr(m, "target_system", None)
        ev["target"] = target
        if mtype == "PARAM_REQUEST_READ":
            ev["param_index"] = m.param_index
            ev["param_id"] = m.param_id
        if mtype == "FILE_TRANSFER_PROTOCOL":
            ev["opcode"] = bytes(m.payload)[3]
        out.write(ev)
        if target not in (0, 1):
            continue
        if mtype == "PARAM_REQUEST_LIST":
            list_requests += 1
            for i in range(len(table)):
                if i != PARAM_VEHICLE_GAP or list_requests > 1:
                    send_param(i)
        elif mtype == "PARAM_REQUEST_READ":
            if 0 <= m.param_index < len(table):
                send_param(m.param_index)
            elif m.param_id in index_of:
                send_param(index_of[m.param_id])
        elif mtype == "PARAM_SET" and m.param_id in index_of:
            values[m.param_id] = m.param_value
            send_param(index_of[m.param_id])
        elif mtype == "FILE_TRANSFER_PROTOCOL":
            # No MAVLink FTP here: NAK every request (ACK session ends), as a
            # vehicle without the file system would, so MAVProxy falls back.
            payload = bytes(m.payload)
            seq, session, opcode = struct.unpack_from("<HBB", payload)
            if opcode in (1, 2):  # TerminateSession, ResetSessions
                reply, size, data = 128, 0, b""
            else:
                err = 10 if opcode == 4 else 7  # FileNotFound / UnknownCommand
                reply, size, data = 129, 1, bytes([err])
            hdr = struct.pack("<HBBBBBBI", (seq + 1) & 0xFFFF, session, reply, size, opcode, 0, 0, 0)
            body = (hdr + data).ljust(251, b"\0")
            conn.mav.file_transfer_protocol_send(0, m.get_srcSystem(), m.get_srcComponent(), body)
        elif mtype == "COMMAND_LONG":
            conn.mav.command_ack_send(m.command, mav.MAV_RESULT_UNSUPPORTED, 0, 0,
                                      m.get_srcSystem(), m.get_srcComponent())
    out.write({"event": "stopping"})
    conn.close()
    return 0


# --------------------------------------------------------------------------
# Check: tlog_matches
# --------------------------------------------------------------------------

def dialect_module(xml_path):
    name = os.path.splitext(os.path.basename(xml_path))[0]
    return importlib.import_module("pymavlink.dialects.v20." + name)


def parse_tlog(path, mod):
    """Split a tlog into records; raise CheckFailed at the first malformed one.
    Returns a list of (t_us, msgid, sysid, compid, seq, known)."""
    with open(path, "rb") as f:
        data = f.read()
    records = []
    pos = 0
    while pos < len(data):
        where = "record %d at offset %d" % (len(records), pos)
        if len(data) - pos < 8 + 1:
            raise CheckFailed("%s: %d trailing bytes, not a record" % (where, len(data) - pos))
        t_us = struct.unpack_from(">Q", data, pos)[0]
        f0 = pos + 8
        magic = data[f0]
        if magic == 0xFD:
            if len(data) - f0 < 10:
                raise CheckFailed("%s: truncated MAVLink 2 header" % where)
            plen, incompat, _compat, seq, sysid, compid = struct.unpack_from("<BBBBBB", data, f0 + 1)
            msgid = data[f0 + 7] | (data[f0 + 8] << 8) | (data[f0 + 9] << 16)
            if incompat & ~0x01:
                raise CheckFailed("%s: unknown incompat_flags 0x%02x" % (where, incompat))
            hdr_len = 10
            flen = hdr_len + plen + 2 + (13 if incompat & 0x01 else 0)
        elif magic == 0xFE:
            if len(data) - f0 < 6:
                raise CheckFailed("%s: truncated MAVLink 1 header" % where)
            plen, seq, sysid, compid, msgid = struct.unpack_from("<BBBBB", data, f0 + 1)
            hdr_len = 6
            flen = hdr_len + plen + 2
        else:
            raise CheckFailed("%s: frame starts with 0x%02x, not 0xFD/0xFE" % (where, magic))
        if len(data) - f0 < flen:
            raise CheckFailed("%s: frame of %d bytes cut off at %d" % (where, flen, len(data) - f0))
        known = msgid in mod.mavlink_map
        if known:
            crc = mod.x25crc(data[f0 + 1:f0 + hdr_len + plen])
            crc.accumulate(bytes([mod.mavlink_map[msgid].crc_extra]))
            got = struct.unpack_from("<H", data, f0 + hdr_len + plen)[0]
            if crc.crc != got:
                raise CheckFailed("%s: msgid %d CRC 0x%04x, frame has 0x%04x"
                                  % (where, msgid, crc.crc, got))
        records.append((t_us, msgid, sysid, compid, seq, known))
        pos = f0 + flen
    return records


def check_one_tlog(router):
    path = router.tlog
    if not os.path.isfile(path):
        raise CheckFailed("%s: no tlog written" % router.name)
    mod = dialect_module(router.dialect)
    try:
        records = parse_tlog(path, mod)
    except CheckFailed as e:
        raise CheckFailed("%s: %s" % (router.name, e))
    if not records:
        raise CheckFailed("%s: tlog is empty" % router.name)
    prev = 0
    lo = router.t_start_us - 1000000
    hi = (router.t_stop_us or now_us()) + 1000000
    for i, rec in enumerate(records):
        t_us = rec[0]
        if t_us < prev:
            raise CheckFailed("%s: record %d goes back in time (%d < %d)" % (router.name, i, t_us, prev))
        if not lo <= t_us <= hi:
            raise CheckFailed("%s: record %d timestamp %d outside the router's run [%d, %d]"
                              % (router.name, i, t_us, lo, hi))
        prev = t_us

    # The reference decoder must see exactly the same frames.
    from pymavlink import mavutil
    conn = mavutil.mavlink_connection(path, dialect="common")
    decoded = []
    bad = 0
    try:
        while True:
            m = conn.recv_msg()
            if m is None:
                break
            if m.get_type() == "BAD_DATA":
                bad += 1
                continue
            decoded.append((int(round(m._timestamp * 1e6)), m.get_msgId(),
                            m.get_srcSystem(), m.get_srcComponent(), m.get_seq()))
    finally:
        conn.close()
    if bad:
        raise CheckFailed("%s: pymavlink found %d BAD_DATA in the tlog" % (router.name, bad))
    if len(decoded) != len(records):
        raise CheckFailed("%s: pymavlink decoded %d frames, the tlog has %d records"
                          % (router.name, len(decoded), len(records)))
    for i, (rec, dec) in enumerate(zip(records, decoded)):
        if rec[1:5] != dec[1:5] or abs(rec[0] - dec[0]) > 2:
            raise CheckFailed("%s: record %d is %s, pymavlink decoded %s"
                              % (router.name, i, rec[:5], dec))

    # The router's own count of received frames (last --stats-json line, at exit).
    # Per source (sysid, compid): a link that went away (MAVProxy closing its TCP
    # connection) is no longer listed under "links", its sources still are.
    stats = read_json_lines(router.stats)
    if not stats:
        raise CheckFailed("%s: --stats-json file is empty" % router.name)
    last = stats[-1]
    if last.get("sources_evicted", 0) == 0:
        rx = sum(src.get("rx_frames", 0) for src in last.get("sources", []))
        if rx != len(records):
            raise CheckFailed("%s: router stats count %d received frames over all sources, "
                              "tlog has %d records" % (router.name, rx, len(records)))
    crc_fail = 0
    for line in stats:  # the largest count any link ever showed
        crc_fail = max(crc_fail, sum(link.get("crc_failures", 0) for link in line.get("links", [])))
    if crc_fail:
        raise CheckFailed("%s: router counted %d CRC failures" % (router.name, crc_fail))
    unknown = sum(1 for r in records if not r[5])
    return "%s: %d records (%d of ids the dialect lacks), %.1f s" % (
        router.name, len(records), unknown, (records[-1][0] - records[0][0]) / 1e6)


class SavedRun:
    """A router run of an earlier invocation, from its NAME.run.json."""

    def __init__(self, path):
        with open(path) as f:
            for key, value in json.load(f).items():
                setattr(self, key, value)


def check_tlog_matches(args):
    if importlib.util.find_spec("pymavlink") is None:
        raise CheckSkipped("Python package 'pymavlink' is not installed")
    runs = list(args.tlogs)
    if not runs:
        # Nothing ran in this invocation (--only tlog_matches): check the tlogs
        # an earlier run left in --workdir.
        for name in ("mavsdk", "mavproxy"):
            path = os.path.join(args.workdir, name + ".run.json")
            if os.path.isfile(path):
                runs.append(SavedRun(path))
    if not runs:
        raise CheckSkipped("no router tlog to check: run it with mavsdk and/or mavproxy, "
                           "or after them with the same --workdir")
    notes = []
    failures = []
    for router in runs:
        try:
            notes.append(check_one_tlog(router))
        except CheckFailed as e:
            failures.append(str(e))
    if failures:
        raise CheckFailed("; ".join(failures))
    return "; ".join(notes)


# --------------------------------------------------------------------------
# Main
# --------------------------------------------------------------------------

def run_role(a):
    if a.role == "mavsdk-vehicle":
        return asyncio.run(role_mavsdk_vehicle(a))
    if a.role == "mavsdk-gcs":
        return asyncio.run(role_mavsdk_gcs(a))
    if a.role == "param-vehicle":
        return role_param_vehicle(a)
    raise SystemExit("unknown role " + a.role)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 2)[2])
    ap.add_argument("--router", help="the ferrolink binary")
    ap.add_argument("--dialect-dir", help="folder with common.xml and ardupilotmega.xml")
    ap.add_argument("--workdir", help="folder for tlogs and logs (created)")
    ap.add_argument("--only", action="append", default=[],
                    help="run only this check (repeatable, or comma-separated): " + ", ".join(CHECKS))
    ap.add_argument("--verbose", "-v", action="store_true", help="print what each check saw")
    ap.add_argument("--role", help=argparse.SUPPRESS)
    ap.add_argument("--url", help=argparse.SUPPRESS)
    ap.add_argument("--out", help=argparse.SUPPRESS)
    ap.add_argument("--duration", type=float, default=50.0, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.role:
        return run_role(args)
    for name in ("router", "dialect_dir", "workdir"):
        if not getattr(args, name):
            ap.error("--%s is required" % name.replace("_", "-"))
    args.router = os.path.abspath(args.router)
    args.dialect_dir = os.path.abspath(args.dialect_dir)
    args.workdir = os.path.abspath(args.workdir)
    if not os.access(args.router, os.X_OK):
        ap.error("router binary %s is not executable" % args.router)
    os.makedirs(args.workdir, exist_ok=True)
    only = [n.strip() for item in args.only for n in item.split(",") if n.strip()]
    for name in only:
        if name not in CHECKS:
            ap.error("unknown check %r (checks: %s)" % (name, ", ".join(CHECKS)))
    selected = [c for c in CHECKS if not only or c in only]
    args.tlogs = []
    runners = {"mavsdk": check_mavsdk, "mavproxy": check_mavproxy,
               "tlog_matches": check_tlog_matches}
    passed = failed = 0
    for name in selected:
        t0 = time.monotonic()
        try:
            note = runners[name](args)
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
        print("ok   %s" % name, flush=True)
        if args.verbose and note:
            print("     %s (%.1f s)" % (note, time.monotonic() - t0), flush=True)
    print("%d passed, %d failed" % (passed, failed), flush=True)
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
