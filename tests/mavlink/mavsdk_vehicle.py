#!/usr/bin/env python3
"""A MAVLink vehicle built from MAVSDK's server plugins, for tests against real peer software.

    mavsdk_vehicle.py [CONNECTION] [--seconds S] [--attitude-hz HZ]

CONNECTION is a MAVSDK 4 connection URL, default ``udpout://127.0.0.1:14550`` (MAVSDK
sends to that address and answers from the same socket; ``udpin://`` and ``tcpout://``
work too). Needs the ``mavsdk`` package, version 4 or later: the native binding that
embeds the MAVSDK C++ core in-process (no mavsdk_server, no gRPC).

The vehicle is one MAVSDK instance configured as an autopilot,
``Configuration.create_with_component_type(ComponentType.AUTOPILOT)`` with sysid 1 and
compid 1 set explicitly. Everything it puts on the wire comes from MAVSDK itself:

* HEARTBEAT at 1 Hz (MAV_TYPE_GENERIC, MAV_AUTOPILOT_GENERIC), sent by the MAVSDK core.
* COMMAND_ACK: MAVSDK's TelemetryServer plugin handles MAV_CMD_SET_MESSAGE_INTERVAL (511)
  and MAV_CMD_REQUEST_MESSAGE (512) addressed to 1/1 and acknowledges them itself.
* ATTITUDE (30): one frame per ``TelemetryServer.publish_attitude()`` call. MAVSDK does
  not stream messages at a requested interval on its own (its SET_MESSAGE_INTERVAL
  handler only records the interval), so this script publishes ATTITUDE at the interval
  the last SET_MESSAGE_INTERVAL for message 30 asked for, as MAVSDK logged it. With
  ``--attitude-hz HZ`` it publishes at HZ from the start instead, request or not; with a
  negative HZ it never calls publish_attitude, which shows what MAVSDK does by itself
  (it acknowledges the request and sends no ATTITUDE).
* GLOBAL_POSITION_INT and BATTERY_STATUS at 1 Hz (publish_position, publish_battery).
* PING (target 0/0), once, about 5 s after MAVSDK starts, sent by the core.

It watches incoming traffic with MavlinkDirectServer.subscribe_message (which only
observes; MAVSDK still acknowledges the commands) and MAVSDK's log, and prints one line
per thing it observed:

    peer S/C: HEARTBEAT type T autopilot A        first heartbeat of each peer
    got command N from S/C (params ...)           each COMMAND_LONG / COMMAND_INT
    MAVSDK: interval for message M set to I ms    MAVSDK's own log of SET_MESSAGE_INTERVAL
    publishing ATTITUDE at H Hz                   each change of the publishing rate
    published N ATTITUDE, N GLOBAL_POSITION_INT, N BATTERY_STATUS   at the end

It exits with status 0 after S seconds.
"""
import argparse
import asyncio
import json
import math
import re
import sys
import time

sys.dont_write_bytecode = True  # keep the source tree clean

ATTITUDE_ID = 30
SET_MESSAGE_INTERVAL = 511


def say(line):
    print(line, flush=True)


def field(fields, name, default=None):
    value = fields.get(name, default)
    return default if value is None else value


async def run(args):
    from mavsdk.asyncio import Mavsdk, Configuration, ComponentType
    from mavsdk.asyncio.plugins.telemetry_server import TelemetryServerAsync
    from mavsdk.asyncio.plugins.mavlink_direct_server import MavlinkDirectServerAsync
    from mavsdk.plugins import telemetry_server as ts
    from mavsdk.logging import log_subscribe, LogLevel

    loop = asyncio.get_running_loop()
    # (msgid, interval in ms) from MAVSDK's SET_MESSAGE_INTERVAL handler, via its log.
    intervals = asyncio.Queue()
    interval_log = re.compile(r"Setting interval for msg id: (\d+) interval_ms:(\d+)")

    def on_log(level, message, _file, _line):
        m = interval_log.search(message)
        if m:
            loop.call_soon_threadsafe(intervals.put_nowait, (int(m.group(1)), int(m.group(2))))
            return True
        # Keep MAVSDK's own output for warnings and errors, drop the chatter.
        return level < LogLevel.WARN

    log_subscribe(on_log)

    cfg = Configuration.create_with_component_type(ComponentType.AUTOPILOT)
    cfg.system_id = 1
    cfg.component_id = 1
    counts = {"ATTITUDE": 0, "GLOBAL_POSITION_INT": 0, "BATTERY_STATUS": 0}
    start = time.monotonic()

    async with Mavsdk(cfg) as mavsdk:
        # Plugins and subscriptions first, the connection last: the companion answers
        # MAVSDK's first heartbeat within milliseconds.
        component = await mavsdk.server_component()
        telemetry = TelemetryServerAsync(component)
        direct = MavlinkDirectServerAsync(component)

        async def watch_heartbeats():
            seen = set()
            async for msg in direct.subscribe_message("HEARTBEAT"):
                src = (msg.system_id, msg.component_id)
                if src in seen or src == (1, 1):
                    continue
                seen.add(src)
                f = json.loads(msg.fields_json or "{}")
                say("peer %d/%d: HEARTBEAT type %s autopilot %s"
                    % (src[0], src[1], field(f, "type"), field(f, "autopilot")))

        async def watch_commands(name):
            async for msg in direct.subscribe_message(name):
                f = json.loads(msg.fields_json or "{}")
                params = [field(f, "param%d" % i, 0) for i in range(1, 5)]
                say("got command %s from %d/%d to %d/%d (%s, params %s)"
                    % (field(f, "command"), msg.system_id, msg.component_id,
                       msg.target_system_id, msg.target_component_id, name,
                       ", ".join("%g" % p for p in params)))

        async def watch_acks():
            async for msg in direct.subscribe_message("COMMAND_ACK"):
                if (msg.system_id, msg.component_id) == (1, 1):
                    continue
                f = json.loads(msg.fields_json or "{}")
                say("got COMMAND_ACK %s result %s from %d/%d"
                    % (field(f, "command"), field(f, "result"), msg.system_id, msg.component_id))

        async def publish_attitude():
            period = 1.0 / args.attitude_hz if args.attitude_hz > 0 else None
            follow = args.attitude_hz == 0
            if period:
                say("publishing ATTITUDE at %g Hz" % args.attitude_hz)
            next_t = time.monotonic()
            while True:
                timeout = None if period is None else max(0.0, next_t - time.monotonic())
                try:
                    msgid, interval_ms = await asyncio.wait_for(intervals.get(), timeout)
                    say("MAVSDK: interval for message %d set to %d ms" % (msgid, interval_ms))
                    if msgid == ATTITUDE_ID and follow and interval_ms > 0:
                        period = interval_ms / 1000.0
                        next_t = time.monotonic()
                        say("publishing ATTITUDE at %g Hz" % (1.0 / period))
                    continue
                except asyncio.TimeoutError:
                    pass
                t = time.monotonic() - start
                angle = ts.EulerAngle(roll_deg=math.degrees(0.1 * math.sin(t)),
                                      pitch_deg=math.degrees(0.05),
                                      yaw_deg=math.degrees(1.0),
                                      timestamp_us=int(t * 1e6))
                rates = ts.AngularVelocityBody(roll_rad_s=0.1 * math.cos(t),
                                               pitch_rad_s=0.0, yaw_rad_s=0.0)
                await telemetry.publish_attitude(angle, rates)
                counts["ATTITUDE"] += 1
                next_t += period

        async def publish_slow():
            position = ts.Position(latitude_deg=47.397742, longitude_deg=8.545594,
                                   absolute_altitude_m=488.25, relative_altitude_m=12.5)
            velocity = ts.VelocityNed(north_m_s=0.0, east_m_s=0.0, down_m_s=0.0)
            heading = ts.Heading(heading_deg=57.3)
            battery = ts.Battery(voltage_v=15.25, remaining_percent=0.66)
            while True:
                await telemetry.publish_position(position, velocity, heading)
                counts["GLOBAL_POSITION_INT"] += 1
                await telemetry.publish_battery(battery)
                counts["BATTERY_STATUS"] += 1
                await asyncio.sleep(1.0)

        tasks = [asyncio.ensure_future(c) for c in (
            watch_heartbeats(), watch_commands("COMMAND_LONG"), watch_commands("COMMAND_INT"),
            watch_acks(), publish_attitude())]
        await asyncio.sleep(0.2)  # let the watchers subscribe
        await mavsdk.add_any_connection(args.connection)
        say("MAVSDK %s autopilot 1/1 on %s" % (await mavsdk.version(), args.connection))
        tasks.append(asyncio.ensure_future(publish_slow()))
        try:
            await asyncio.sleep(max(0.0, args.seconds - (time.monotonic() - start)))
        finally:
            for t in tasks:
                t.cancel()
            results = await asyncio.gather(*tasks, return_exceptions=True)
        for r in results:
            if isinstance(r, Exception) and not isinstance(r, asyncio.CancelledError):
                say("error: %s: %s" % (type(r).__name__, r))
        say("published %s" % ", ".join("%d %s" % (n, k) for k, n in counts.items()))
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("connection", nargs="?", default="udpout://127.0.0.1:14550")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--attitude-hz", type=float, default=0.0,
                    help="publish ATTITUDE at this rate from the start; 0 (default): at the "
                         "interval a SET_MESSAGE_INTERVAL asks for; negative: never")
    args = ap.parse_args()
    return asyncio.run(run(args))


if __name__ == "__main__":
    sys.exit(main())
