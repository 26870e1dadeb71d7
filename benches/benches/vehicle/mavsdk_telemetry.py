"""MAVSDK's ground station for the vehicle bench (benches/vehicle.rs).

    mavsdk_telemetry.py PORT SECONDS

Listens on udpin://127.0.0.1:PORT with MAVSDK 4.1 (the mavsdk package, its C++ core in this
process), prints "listening", then: when the first position came (monotonic ns), the time
Action.arm() takes, and over SECONDS the updates of six subscriptions (position,
attitude_euler, attitude_quaternion, raw_gps, battery, health), each an async loop as a user
writes it, with the CPU time this process spent and, per numbered update, "rx KIND INDEX NS"
on the system's monotonic clock.
"""
import asyncio
import math
import resource
import sys
import time


def cpu():
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


async def main(port, seconds):
    from mavsdk.asyncio import Mavsdk, Configuration, ComponentType
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    cfg = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(cfg) as mavsdk:
        await mavsdk.add_any_connection("udpin://127.0.0.1:%d" % port)
        print("listening", flush=True)
        system = await mavsdk.first_autopilot(15.0)
        tel, act = TelemetryAsync(system), ActionAsync(system)
        async for _ in tel.subscribe_position():
            break
        print("first_position_ns %d" % time.monotonic_ns(), flush=True)
        t = time.monotonic()
        await act.arm()
        print("arm_s %f" % (time.monotonic() - t), flush=True)
        rx = []
        count = [0]

        def number(kind, index):
            count[0] += 1
            if index is not None:
                rx.append((kind, index, time.monotonic_ns()))

        async def loop(gen, kind, index):
            async for v in gen:
                number(kind, index(v))

        streams = [
            (tel.subscribe_position(), 0, lambda p: round(p.latitude_deg * 1e7) - 470000000),
            (tel.subscribe_attitude_euler(), 1, lambda a: round(math.radians(a.yaw_deg) * 1000)),
            (tel.subscribe_attitude_quaternion(), 2, lambda q: int(q.w)),
            (tel.subscribe_raw_gps(), 3, lambda g: None),
            (tel.subscribe_battery(), 4, lambda b: round(b.voltage_v * 1000) - 10000),
            (tel.subscribe_health(), 5, lambda h: None),
        ]
        c0, t0 = cpu(), time.monotonic()
        tasks = [asyncio.ensure_future(loop(g, k, i)) for g, k, i in streams]
        await asyncio.sleep(seconds)
        window, used = time.monotonic() - t0, cpu() - c0
        for task in tasks:
            task.cancel()
        print("updates %d" % count[0])
        print("window_s %f" % window)
        print("cpu_s %f" % used)
        for kind, index, ns in rx:
            print("rx %d %d %d" % (kind, index, ns))
        sys.stdout.flush()


if __name__ == "__main__":
    asyncio.run(main(int(sys.argv[1]), float(sys.argv[2])))
