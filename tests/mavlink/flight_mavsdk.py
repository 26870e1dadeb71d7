#!/usr/bin/env python3
"""The flying software vehicle and the vehicle API against MAVSDK 4.1 (in-process).

    flight_mavsdk.py --ferrolink BIN --workdir DIR [--only NAME]... [--loss P]

Checks, each in a child process of its own, all at once (MAVSDK's library may crash; a check
whose process dies of a signal is run once more):

  mavsdk_flies_px4, mavsdk_flies_ardupilot
        MAVSDK's Telemetry, Action and MissionRaw clients fly ``ferrolink mavlink vehicle
        --autopilot px4`` (and ``ardupilotmega``): arm, take off to 10 m, go to a point
        80 m away, fly a 5-item mission, return and land. Telemetry shows each step: the
        position (a go-to ends within 1 m), armed, in air, and the flight modes MAVSDK names
        from the vehicle's heartbeats.
  our_actions
        our ``action`` command against our vehicle: take-off refused while disarmed, arm,
        take off, disarm in flight refused, MISSION without a mission refused, hold, land,
        and an unknown mode's name; each ends with the vehicle's own answer.
  ours_against_mavsdk_servers
        our ``telemetry`` and ``action`` commands (the vehicle API, blocking) against a vehicle
        built from MAVSDK's TelemetryServer and ActionServer: the position, battery and GPS
        MAVSDK publishes arrive equal; its action server sees our arm and take-off; and with
        ``--fly BIN`` (examples/fly's program), the async face's arm and take-off too.

``--loss P`` puts a relay that loses P of the datagrams both ways between the two sides of
the flying checks: every action must still end with its true result.

Prints ``ok NAME (S s): NOTE``, ``FAIL NAME: WHY`` or ``skip NAME: WHY`` (no mavsdk package) per
check, then ``N passed, M failed``.
"""
import argparse
import asyncio
import math
import os
import random
import signal
import socket
import subprocess
import sys
import threading
import time

sys.dont_write_bytecode = True  # keep the source tree clean
from ports import free_port  # noqa: E402
from services_mavsdk import CheckFailed, ferrolink, stop  # noqa: E402

HOST = "127.0.0.1"
HOME = (47.397742, 8.545594, 488.0)
M_PER_DEG = 111_320.0


async def retried(what, call, notes):
    """A MAVSDK call, again when MAVSDK gave up with TIMEOUT: its client sends a command or an
    upload's frames a few times and then gives up, which at 20 % loss each way happens now and
    then (its driver's limit, not the vehicle's). A user tries again; so does this, twice at
    most, and says so in the notes. Every step is one the vehicle takes twice unharmed."""
    from mavsdk.plugins.action.action import ActionError
    from mavsdk.plugins.mission_raw.mission_raw import MissionRawError
    for attempt in range(1, 4):
        try:
            return await call()
        except (ActionError, MissionRawError) as e:
            if attempt == 3 or "TIMEOUT" not in str(e):
                raise
            notes.append("MAVSDK's %s timed out once" % what)


def metres(lat, lon, to_lat, to_lon):
    n = (to_lat - lat) * M_PER_DEG
    e = (to_lon - lon) * M_PER_DEG * math.cos(math.radians(lat))
    return math.hypot(n, e)


class Relay(object):
    """UDP between a listening side (our vehicle sends to `port`) and the vehicle's socket,
    losing `loss` of the datagrams each way."""

    def __init__(self, to_port, seed, loss):
        self.rng = random.Random(seed)
        self.loss = loss
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((HOST, 0))
        self.port = self.sock.getsockname()[1]
        self.out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.out.bind((HOST, 0))
        self.to = (HOST, to_port)
        self.vehicle = None
        self.stopped = False
        for f in (self.forward, self.back):
            threading.Thread(target=f, daemon=True).start()

    def forward(self):
        self.sock.settimeout(0.2)
        while not self.stopped:
            try:
                data, self.vehicle = self.sock.recvfrom(65536)
            except OSError:
                continue
            if self.rng.random() >= self.loss:
                self.out.sendto(data, self.to)

    def back(self):
        self.out.settimeout(0.2)
        while not self.stopped:
            try:
                data, _ = self.out.recvfrom(65536)
            except OSError:
                continue
            if self.vehicle and self.rng.random() >= self.loss:
                self.sock.sendto(data, self.vehicle)

    def close(self):
        self.stopped = True


async def start_vehicle(args, autopilot, port):
    params = os.path.join(args.workdir, "vehicle-%s.params" % autopilot)
    with open(params, "w") as f:
        # PX4's take-off height, which MAVSDK's set_takeoff_altitude sets.
        f.write("1\t1\tMIS_TAKEOFF_ALT\t2.5\t9\n")
    proc = await asyncio.create_subprocess_exec(
        args.ferrolink, "mavlink", "vehicle", "--autopilot", autopilot, "--params", params,
        "--run-for", "300", "udpout://%s:%d" % (HOST, port),
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    line = await asyncio.wait_for(proc.stdout.readline(), 10)
    if b"ready" not in line:
        proc.kill()
        raise CheckFailed("the vehicle did not start: %r" % line)
    return proc


async def until(what, cond, seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if cond():
            return
        await asyncio.sleep(0.05)
    raise CheckFailed("%s: not within %d s" % (what, seconds))


async def fly(args, autopilot):
    from mavsdk.asyncio import Mavsdk, Configuration, ComponentType
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync, MissionItem
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
    from mavsdk.plugins.telemetry import FlightMode

    port = free_port()
    relay = Relay(port, args.seed, args.loss) if args.loss > 0 else None
    vehicle = await start_vehicle(args, autopilot, relay.port if relay else port)
    cfg = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    notes = []
    try:
        async with Mavsdk(cfg) as mavsdk:
            await mavsdk.add_any_connection("udpin://%s:%d" % (HOST, port))
            system = await mavsdk.first_autopilot(15.0)
            if system is None:
                raise CheckFailed("MAVSDK found no autopilot")
            tel, act, mis = TelemetryAsync(system), ActionAsync(system), MissionRawAsync(system)
            seen = {"modes": [], "position": None, "armed": None, "in_air": None,
                    "progress": None}

            async def watch(gen, key, f=lambda v: v):
                async for v in gen:
                    v = f(v)
                    if key == "modes":
                        if not seen["modes"] or seen["modes"][-1] != v:
                            seen["modes"].append(v)
                    else:
                        seen[key] = v

            tasks = [asyncio.ensure_future(t) for t in (
                watch(tel.subscribe_flight_mode(), "modes", lambda m: FlightMode(m).name),
                watch(tel.subscribe_position(), "position"),
                watch(tel.subscribe_armed(), "armed"),
                watch(tel.subscribe_in_air(), "in_air"),
                watch(mis.subscribe_mission_progress(), "progress"))]
            try:
                await until("a position", lambda: seen["position"] is not None, 10)
                home = seen["position"]
                await retried("arm", act.arm, notes)
                await until("armed", lambda: seen["armed"] is True, 5)
                await retried("take-off altitude", lambda: act.set_takeoff_altitude(10.0), notes)
                await retried("take-off", act.takeoff, notes)
                await until("10 m up", lambda: seen["position"].relative_altitude_m > 9.9, 20)
                await until("in air", lambda: seen["in_air"] is True, 5)
                notes.append("took off to %.1f m" % seen["position"].relative_altitude_m)
                # 80 m north-east, 15 m up.
                lat, lon = home.latitude_deg + 0.0005, home.longitude_deg + 0.0008
                alt = home.absolute_altitude_m + 15.0
                await retried("go-to", lambda: act.goto_location(lat, lon, alt, float("nan")),
                              notes)

                def there():
                    p = seen["position"]
                    return (metres(p.latitude_deg, p.longitude_deg, lat, lon) < 1.0
                            and abs(p.absolute_altitude_m - alt) < 1.0)
                await until("the go-to point", there, 40)
                notes.append("went 80 m, ended %.2f m off" % metres(
                    seen["position"].latitude_deg, seen["position"].longitude_deg, lat, lon))
                items = []
                if autopilot == "ardupilotmega":
                    # ArduPilot's item 0 is home.
                    items.append((home.latitude_deg, home.longitude_deg, 0.0))
                for i in range(5):
                    items.append((lat + 0.0002 * (i % 2), lon + 0.0002 * (i // 2), 12.0 + i))
                plan = [MissionItem(seq, 6, 16, 1 if seq == 0 else 0, 1, 0.0, 0.0, 0.0,
                                    float("nan"), int(la * 1e7), int(lo * 1e7), z, 0)
                        for seq, (la, lo, z) in enumerate(items)]
                await retried("mission upload", lambda: mis.upload_mission(plan), notes)
                await retried("mission start", mis.start_mission, notes)
                total = len(plan)

                def done():
                    p = seen["progress"]
                    return p is not None and p.total == total and p.current == total
                await until("the mission's end", done, 90)
                notes.append("flew a %d-item mission" % 5)
                await retried("return", act.return_to_launch, notes)
                await until("landed", lambda: seen["in_air"] is False and seen["armed"] is False,
                            90)
                p = seen["position"]
                off = metres(p.latitude_deg, p.longitude_deg, home.latitude_deg,
                             home.longitude_deg)
                if off > 1.0:
                    raise CheckFailed("landed %.1f m from home" % off)
                modes = seen["modes"]
                want = (["HOLD", "MISSION", "RETURN_TO_LAUNCH", "LAND"] if autopilot == "px4"
                        else ["OFFBOARD", "MISSION", "RETURN_TO_LAUNCH", "LAND"])
                missing = [m for m in want if m not in modes]
                if missing:
                    raise CheckFailed("MAVSDK never saw modes %s (saw %s)" % (missing, modes))
                notes.append("returned and landed %.2f m from home; modes %s"
                             % (off, " ".join(modes)))
            finally:
                for t in tasks:
                    t.cancel()
    finally:
        await stop(vehicle)
        if relay:
            relay.close()
    return "; ".join(notes)


async def check_our_actions(args):
    """Our `action` command against our vehicle (PX4), through the relay when `--loss` is set:
    each ends with the vehicle's true answer."""
    import json
    port = free_port()
    relay = Relay(port, args.seed + 1, args.loss) if args.loss > 0 else None
    vehicle = await start_vehicle(args, "px4", relay.port if relay else port)
    uri = "udpin://%s:%d" % (HOST, port)
    steps = [
        (["takeoff", "5"], 1, "TEMPORARILY_REJECTED"),
        (["arm"], 0, "ACCEPTED"),
        (["takeoff", "5"], 0, "ACCEPTED"),
        (["disarm"], 1, "DENIED"),
        (["mode", "mission"], 1, "DENIED"),
        (["hold"], 0, "ACCEPTED"),
        (["land"], 0, "ACCEPTED"),
    ]
    try:
        for argv, want_rc, want in steps:
            rc, out, err = await ferrolink(args, "action", uri, *argv)
            got = json.loads(out).get("result") if out.strip() else None
            if (rc, got) != (want_rc, want):
                raise CheckFailed("action %s: exit %d %s, the vehicle's answer is %s: %s"
                                  % (" ".join(argv), rc, got, want, err))
            if argv[0] == "takeoff" and want == "ACCEPTED":
                await asyncio.sleep(2.5)
        rc, out, err = await ferrolink(args, "action", uri, "mode", "guided")
        if rc != 1 or "MISSION" not in err:
            raise CheckFailed("an unknown mode: exit %d, %r" % (rc, err))
    finally:
        await stop(vehicle)
        if relay:
            relay.close()
    return "%d actions, each with the vehicle's own answer%s" % (
        len(steps), " at %d %% loss" % (args.loss * 100) if relay else "")


async def check_mavsdk_flies_px4(args):
    return await fly(args, "px4")


async def check_mavsdk_flies_ardupilot(args):
    return await fly(args, "ardupilotmega")


async def check_ours_against_mavsdk_servers(args):
    import json
    from mavsdk.asyncio import Mavsdk, Configuration, ComponentType
    from mavsdk.asyncio.plugins.telemetry_server import TelemetryServerAsync
    from mavsdk.asyncio.plugins.action_server import ActionServerAsync
    from mavsdk.plugins import telemetry_server as ts

    port = free_port()
    cfg = Configuration.create_with_component_type(ComponentType.AUTOPILOT)
    cfg.system_id = 1
    cfg.component_id = 1
    lat, lon, amsl, rel = 47.3981234, 8.5461234, 512.5, 24.5
    events = []
    async with Mavsdk(cfg) as mavsdk:
        component = await mavsdk.server_component()
        telemetry = TelemetryServerAsync(component)
        action = ActionServerAsync(component)
        await action.set_armable(True, True)
        await action.set_allow_takeoff(True)

        async def watch(gen, name):
            async for result, value in gen:
                events.append((name, value))

        async def publish():
            while True:
                await telemetry.publish_position(
                    ts.Position(lat, lon, amsl, rel), ts.VelocityNed(1.0, 2.0, -0.5),
                    ts.Heading(90.0))
                await telemetry.publish_raw_gps(
                    ts.RawGps(0, lat, lon, amsl, 0.8, 1.2, 2.0, 90.0, amsl + 50.0, 1.0, 1.5,
                              0.3, 2.0, 90.0),
                    ts.GpsInfo(14, ts.FixType.FIX_3D))
                # MAVSDK 4.1's server takes the charge as a fraction (73.0 overflows
                # SYS_STATUS's int8 to -124).
                await telemetry.publish_sys_status(ts.Battery(15.6, 0.73), True, True,
                                                   True, True, True)
                await asyncio.sleep(0.1)

        tasks = [asyncio.ensure_future(t) for t in (
            watch(action.subscribe_arm_disarm(), "arm"),
            watch(action.subscribe_takeoff(), "takeoff"),
            publish())]
        await mavsdk.add_any_connection("udpout://%s:%d" % (HOST, port))
        try:
            uri = "udpin://%s:%d" % (HOST, port)
            rc, out, err = await ferrolink(args, "telemetry", uri, "--count", "20")
            if rc != 0:
                raise CheckFailed("telemetry exited %d: %s" % (rc, err))
            lines = [json.loads(line) for line in out.splitlines()]
            kinds = {line["kind"]: line for line in lines}
            p, b, g = kinds.get("position"), kinds.get("battery"), kinds.get("gps")
            if not (p and b and g):
                raise CheckFailed("telemetry printed no position, battery or gps: %s" % out)
            if (abs(p["lat"] - lat) > 1e-7 or abs(p["lon"] - lon) > 1e-7
                    or abs(p["alt_amsl"] - amsl) > 1e-3 or abs(p["alt_rel"] - rel) > 1e-3):
                raise CheckFailed("position %s, MAVSDK published %s" % (p, (lat, lon, amsl, rel)))
            if abs(b["voltage"] - 15.6) > 1e-3 or b["remaining"] != 73:
                raise CheckFailed("battery %s, MAVSDK published 15.6 V 73 %%" % b)
            if (g["fix"], g["satellites"]) != ("3D", 14):
                raise CheckFailed("gps %s, MAVSDK published a 3D fix with 14" % g)
            for act in ("arm", "takeoff"):
                rc, out, err = await ferrolink(args, "action", uri, act)
                line = json.loads(out or "{}")
                if rc != 0 or line.get("result") != "ACCEPTED":
                    raise CheckFailed("action %s exited %d: %s %s" % (act, rc, out, err))
            await until("MAVSDK's action server saw arm and take-off",
                        lambda: {"arm", "takeoff"} <= {e[0] for e in events}, 5)
            # The API's async face (examples/fly --async): discovery, the position, arm and
            # take-off, against the same MAVSDK vehicle.
            if args.fly:
                events.clear()
                proc = await asyncio.create_subprocess_exec(
                    args.fly, uri, "--async", stdout=asyncio.subprocess.PIPE,
                    stderr=asyncio.subprocess.PIPE)
                out, err = await asyncio.wait_for(proc.communicate(), 60)
                text = out.decode()
                if (proc.returncode != 0 or "lat: %s" % lat not in text
                        or "arm: Accepted" not in text or "takeoff: Accepted" not in text):
                    raise CheckFailed("the async face: exit %d: %s %s"
                                      % (proc.returncode, text, err.decode()))
                await until("MAVSDK's action server saw the async arm and take-off",
                            lambda: {"arm", "takeoff"} <= {e[0] for e in events}, 5)
        finally:
            for t in tasks:
                t.cancel()
    return ("position, battery and GPS equal to what MAVSDK published; its action server saw "
            "%s%s" % (", ".join(sorted({e[0] for e in events})),
                      ", blocking and async" if args.fly else ""))


CHECKS = {
    "our_actions": check_our_actions,
    "mavsdk_flies_px4": check_mavsdk_flies_px4,
    "mavsdk_flies_ardupilot": check_mavsdk_flies_ardupilot,
    "ours_against_mavsdk_servers": check_ours_against_mavsdk_servers,
}


def run_one(args, name):
    t0 = time.monotonic()
    try:
        import mavsdk  # noqa: F401
    except ImportError:
        print("skip %s: the mavsdk package is not installed" % name, flush=True)
        return 0
    try:
        note = asyncio.run(asyncio.wait_for(CHECKS[name](args), 300))
    except CheckFailed as e:
        print("FAIL %s: %s" % (name, e), flush=True)
        return 1
    except Exception as e:  # a bug in the driver is a failure, not a crash
        print("FAIL %s: %s: %s" % (name, type(e).__name__, e), flush=True)
        return 1
    print("ok   %s (%.1f s): %s" % (name, time.monotonic() - t0, note), flush=True)
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ferrolink", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--only", action="append", default=[])
    ap.add_argument("--seed", type=int, default=20261129)
    ap.add_argument("--loss", type=float, default=0.0)
    ap.add_argument("--fly", help="examples/fly's program, for the API's async face")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    args.ferrolink = os.path.abspath(args.ferrolink)
    os.makedirs(args.workdir, exist_ok=True)
    only = [n for item in args.only for n in item.split(",") if n]
    if args.child:
        return run_one(args, only[0])
    names = [n for n in CHECKS if not only or n in only]
    argv = {n: [sys.executable, os.path.abspath(__file__), "--ferrolink", args.ferrolink,
                "--workdir", os.path.join(args.workdir, n), "--seed", str(args.seed),
                "--loss", str(args.loss), "--only", n, "--child"]
            + (["--fly", args.fly] if args.fly else []) for n in names}
    # They mostly wait on the vehicle's flight: all at once.
    children = {n: subprocess.Popen(argv[n]) for n in names}
    passed = failed = 0
    for name in names:
        rc = children[name].wait()
        if rc < 0:
            print("note %s: its process died of signal %d; run again" % (name, -rc), flush=True)
            rc = subprocess.run(argv[name]).returncode
        if rc == 0:
            passed += 1
        else:
            failed += 1
    print("%d passed, %d failed" % (passed, failed), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
