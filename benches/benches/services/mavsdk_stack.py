#!/usr/bin/env python3
"""MAVSDK's side of the services benchmark: a vehicle from its server plugins, or a ground
station that times the work. Driven by benches/benches/services.rs, which runs the relay.

    mavsdk_stack.py vehicle --port V --params N --ftp-root DIR
    mavsdk_stack.py client --port F --params N --items M --file BYTES --timeout SECS

The client prints one JSON line per operation: {"op": ..., "seconds": S, "ok": true} or
{"op": ..., "seconds": S, "ok": false, "error": "..."}.
"""
import argparse
import asyncio
import json
import os
import sys
import time

sys.dont_write_bytecode = True


def params(n):
    """n parameters: even indices INT32, odd REAL32 (the types MAVSDK lists)."""
    out = []
    for i in range(n):
        name = "P%04d" % i
        out.append((name, i * 7 - 3000) if i % 2 == 0 else (name, i / 8.0))
    return out


def items(n):
    from mavsdk.asyncio.plugins.mission_raw import MissionItem
    return [MissionItem(seq=i, frame=3, command=16, current=1 if i == 0 else 0, autocontinue=1,
                        param1=0.0, param2=2.0, param3=0.0, param4=0.0,
                        x=473977420 + 97 * i, y=85455940 - 31 * i, z=10.0 + i / 8,
                        mission_type=0)
            for i in range(n)]


async def vehicle(a):
    from mavsdk.asyncio import Mavsdk, Configuration, ComponentType
    from mavsdk.asyncio.plugins.param_server import ParamServerAsync
    from mavsdk.asyncio.plugins.mission_raw_server import MissionRawServerAsync
    from mavsdk.asyncio.plugins.ftp_server import FtpServerAsync
    cfg = Configuration.create_with_component_type(ComponentType.AUTOPILOT)
    cfg.system_id = 1
    cfg.component_id = 1
    async with Mavsdk(cfg) as mavsdk:
        await mavsdk.add_any_connection("udpin://127.0.0.1:%d" % a.port)
        component = await mavsdk.server_component()
        server = ParamServerAsync(component)
        for name, value in params(a.params):
            if isinstance(value, int):
                await server.provide_param_int(name, value)
            else:
                await server.provide_param_float(name, value)
        missions = MissionRawServerAsync(component)
        ftp = FtpServerAsync(component)
        await ftp.set_root_dir(a.ftp_root)

        async def drain():
            async for _ in missions.incoming_mission():
                pass
        task = asyncio.ensure_future(drain())
        print("ready", flush=True)
        await asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)
        task.cancel()
        del server, missions, ftp


async def timed(op, coro, timeout):
    t0 = time.monotonic()
    try:
        err = await asyncio.wait_for(coro, timeout)
    except asyncio.TimeoutError:
        err = "no result within %d s" % timeout
    except Exception as e:  # MAVSDK's errors: the operation failed
        err = "%s: %s" % (type(e).__name__, e)
    line = {"op": op, "seconds": round(time.monotonic() - t0, 3), "ok": err is None}
    if err is not None:
        line["error"] = err
    print(json.dumps(line), flush=True)


async def client(a):
    from mavsdk.asyncio import Mavsdk, Configuration, ComponentType
    from mavsdk.asyncio.plugins.param import ParamAsync
    from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
    from mavsdk.asyncio.plugins.ftp import FtpAsync
    cfg = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(cfg) as mavsdk:
        await mavsdk.add_any_connection("udpout://127.0.0.1:%d" % a.port)
        system = await mavsdk.first_autopilot(30.0)
        if system is None:
            print(json.dumps({"op": "discovery", "seconds": 30, "ok": False,
                              "error": "no autopilot"}), flush=True)
            return

        async def fetch():
            got = await ParamAsync(system).get_all_params()
            n = len(got.int_params) + len(got.float_params)
            return None if n == a.params else "%d of %d parameters" % (n, a.params)

        mission = MissionRawAsync(system)

        # A mission transfer is tried again from the start when MAVSDK gives it up, up to
        # five times (ours tries three), so the download has a mission to fetch and the time is
        # that of getting the job done.
        async def upload():
            for attempt in range(5):
                try:
                    await mission.upload_mission(items(a.items))
                    return None
                except Exception as e:  # MAVSDK's error: try again
                    err = "%d attempts, the last: %s" % (attempt + 1, str(e).split(";")[0])
            return err

        async def download():
            for attempt in range(5):
                try:
                    got = await mission.download_mission()
                except Exception as e:  # MAVSDK's error: try again
                    err = "%d attempts, the last: %s" % (attempt + 1, str(e).split(";")[0])
                    continue
                return None if len(got) == a.items else "%d of %d items" % (len(got), a.items)
            return err

        async def ftp_read():
            local = os.path.join(a.workdir, "mavsdk-read")
            os.makedirs(local, exist_ok=True)
            async for _ in FtpAsync(system).download("/big.bin", local, True):
                pass
            with open(os.path.join(local, "big.bin"), "rb") as f:
                n = len(f.read())
            return None if n == a.file else "%d of %d bytes" % (n, a.file)

        await timed("params", fetch(), a.timeout)
        await timed("mission_upload", upload(), a.timeout)
        await timed("mission_download", download(), a.timeout)
        await timed("ftp_read", ftp_read(), a.timeout)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("role", choices=["vehicle", "client"])
    ap.add_argument("--port", type=int, required=True)
    ap.add_argument("--params", type=int, default=1000)
    ap.add_argument("--items", type=int, default=500)
    ap.add_argument("--file", type=int, default=1 << 20)
    ap.add_argument("--ftp-root", default=".")
    ap.add_argument("--workdir", default=".")
    ap.add_argument("--timeout", type=float, default=180)
    a = ap.parse_args()
    asyncio.run(vehicle(a) if a.role == "vehicle" else client(a))


if __name__ == "__main__":
    main()
