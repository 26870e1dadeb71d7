#!/usr/bin/env python3
"""Reading a 100 MB tlog from Python: ferrolink against pymavlink 2.4.50, pymavlog 0.4.2,
fasttlogparser 1.1.1 and mavkit 0.3.0, each through its fastest API, in one run on the same
generated log. Each tool runs in its own process, so its peak memory (max RSS, the interpreter
and its imports included) is its own.

    bash benches/python/run.sh            # sets up the peers in a venv, then runs this

Tasks:
- messages: every message as an object, one by one, its type read (pymavlink's recv_match
  loop; ferrolink's open_log; mavkit's tlog entries);
- messages + to_dict(): the same, each message turned into a dict of its fields;
- columns into pandas: one DataFrame per message type (ferrolink's load_log; fasttlogparser's
  parseTLog into DataFrames; pymavlog's MavTLog).
"""

import argparse
import json
import os
import platform
import random
import resource
import struct
import subprocess
import sys
import time

os.environ.setdefault("MAVLINK20", "1")


def generate(path, size_mb):
    """A flight's telemetry mix, as ArduPilot streams it, until the file is `size_mb` MB."""
    from pymavlink.dialects.v20 import ardupilotmega as apm

    mav = apm.MAVLink(None, srcSystem=1, srcComponent=1)
    rng = random.Random(7)
    f = rng.uniform
    # (rate per second, message factory)
    streams = [
        (50, lambda t: apm.MAVLink_attitude_message(t, f(-1, 1), f(-1, 1), f(-3, 3), f(-1, 1), f(-1, 1), f(-1, 1))),
        (50, lambda t: apm.MAVLink_raw_imu_message(t * 1000, *[rng.randint(-2000, 2000) for _ in range(9)])),
        (10, lambda t: apm.MAVLink_global_position_int_message(t, 473977418 + rng.randint(0, 999), 85455939 + rng.randint(0, 999), 500000, 10000, 10, -5, 0, 9000)),
        (10, lambda t: apm.MAVLink_vfr_hud_message(f(0, 20), f(0, 20), rng.randint(0, 359), 50, f(0, 100), f(-2, 2))),
        (10, lambda t: apm.MAVLink_servo_output_raw_message((t * 1000) % 2**32, 0, *[rng.randint(1000, 2000) for _ in range(8)])),
        (5, lambda t: apm.MAVLink_gps_raw_int_message(t * 1000, 3, 473977418, 85455939, 500000, 120, 150, 500, 9000, 12)),
        (5, lambda t: apm.MAVLink_rc_channels_message(t, 16, *[rng.randint(1000, 2000) for _ in range(18)], 255)),
        (2, lambda t: apm.MAVLink_sys_status_message(0x3f, 0x3f, 0x3f, 500, 12600, 1500, 80, 0, 0, 0, 0, 0, 0)),
        (1, lambda t: apm.MAVLink_heartbeat_message(2, 3, 217, 5, 4, 3)),
        (1, lambda t: apm.MAVLink_statustext_message(6, b"EKF3 IMU0 is using GPS")),
    ]
    written = 0
    t_us = 1_700_000_000_000_000
    tick = 0
    with open(path, "wb") as out:
        while written < size_mb * 1_000_000:
            for rate, make in streams:
                if tick % (50 // rate) == 0:
                    frame = make(tick * 20).pack(mav)
                    record = struct.pack(">Q", t_us) + frame
                    out.write(record)
                    written += len(record)
            tick += 1
            t_us += 20_000


def peak_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def run(tool, task, path):
    """Does the work in this process: (messages, seconds)."""
    if tool == "pymavlink":
        from pymavlink import mavutil

        start = time.perf_counter()
        conn = mavutil.mavlink_connection(path, dialect="ardupilotmega")
        n = 0
        while True:
            m = conn.recv_match()
            if m is None:
                break
            m.get_type()
            if task == "dicts":
                m.to_dict()
            n += 1
        return n, time.perf_counter() - start
    if tool == "ferrolink":
        from ferrolink import mavlink

        if task == "pandas":
            # Imported before the clock starts, as pandas is for the others.
            import pandas  # noqa: F401
            import pyarrow  # noqa: F401
        start = time.perf_counter()
        n = 0
        if task == "pandas":
            tables = mavlink.load_log(path, to="pandas")
            n = sum(len(t) for t in tables.values())
        else:
            for m in mavlink.open_log(path):
                m.get_type()
                if task == "dicts":
                    m.to_dict()
                n += 1
        return n, time.perf_counter() - start
    if tool == "mavkit":
        import asyncio

        import mavkit

        async def read():
            log = await mavkit.TlogFile.open(path)
            return await log.entries()

        start = time.perf_counter()
        n = 0
        for entry in asyncio.run(read()):
            entry.message_name
            if task == "dicts":
                json.loads(entry.message_json())
            n += 1
        return n, time.perf_counter() - start
    if tool == "fasttlogparser":
        import fasttlogparser
        import pandas as pd

        start = time.perf_counter()
        messages, _ids = fasttlogparser.parseTLog(path)
        frames = {name: pd.DataFrame(fields) for name, fields in messages.items()}
        n = sum(len(f) for f in frames.values())
        return n, time.perf_counter() - start
    if tool == "pymavlog":
        import pandas as pd
        from pymavlog import MavTLog

        start = time.perf_counter()
        log = MavTLog(path, messages_to_ignore=[])
        log.parse()
        frames = {t: pd.DataFrame(log.get(t).fields) for t in log.types}
        n = sum(len(f) for f in frames.values())
        return n, time.perf_counter() - start
    raise SystemExit(f"unknown tool {tool}")


TASKS = [
    ("messages", ["ferrolink", "pymavlink", "mavkit"]),
    ("dicts", ["ferrolink", "pymavlink", "mavkit"]),
    ("pandas", ["ferrolink", "fasttlogparser", "pymavlog"]),
]
TITLES = {
    "messages": "messages, one by one (type read)",
    "dicts": "messages, one by one, each to_dict()",
    "pandas": "columns into pandas DataFrames",
}
VERSIONS = {"pymavlink": "pymavlink", "mavkit": "mavkit", "fasttlogparser": "fasttlogparser",
            "pymavlog": "pymavlog", "ferrolink": "ferrolink"}


def version(tool):
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as v

    try:
        return v(VERSIONS[tool])
    except PackageNotFoundError:
        return None


def machine():
    cpu = platform.processor()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}, Python {platform.python_version()}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size-mb", type=int, default=100)
    ap.add_argument("--log", default="target/bench-logs/flight-100mb.tlog")
    ap.add_argument("--run", nargs=2, metavar=("TOOL", "TASK"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.run:
        n, seconds = run(args.run[0], args.run[1], args.log)
        print(json.dumps({"messages": n, "seconds": seconds, "peak_mb": peak_mb()}))
        return
    os.makedirs(os.path.dirname(args.log) or ".", exist_ok=True)
    if not os.path.exists(args.log) or os.path.getsize(args.log) < args.size_mb * 1_000_000:
        print(f"generating {args.log} ({args.size_mb} MB)...", file=sys.stderr)
        generate(args.log, args.size_mb)
    size = os.path.getsize(args.log) / 1e6
    print(f"machine: {machine()}")
    print(f"log: {args.log}, {size:.0f} MB")
    print()
    print("| task | tool | messages/s | seconds | peak memory | vs. ferrolink |")
    print("|---|---|---:|---:|---:|---:|")
    results = {}
    for task, tools in TASKS:
        for tool in tools:
            if version(tool) is None:
                print(f"| {TITLES[task]} | {tool} | not installed | | | |")
                continue
            out = subprocess.run([sys.executable, __file__, "--log", args.log, "--run", tool, task],
                                 capture_output=True, text=True)
            if out.returncode != 0:
                print(f"| {TITLES[task]} | {tool} {version(tool)} | failed: {out.stderr.strip().splitlines()[-1:]} | | | |")
                continue
            r = json.loads(out.stdout.strip().splitlines()[-1])
            results[(task, tool)] = r
            rate = r["messages"] / r["seconds"]
            ours = results.get((task, "ferrolink"))
            ratio = "" if tool == "ferrolink" or not ours else f"{(ours['messages'] / ours['seconds']) / rate:.1f}× slower"
            print(f"| {TITLES[task]} | {tool} {version(tool)} | {rate:,.0f} | {r['seconds']:.2f} | "
                  f"{r['peak_mb']:,.0f} MB | {ratio} |", flush=True)


if __name__ == "__main__":
    main()
