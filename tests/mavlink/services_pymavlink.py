#!/usr/bin/env python3
"""The microservices against pymavlink's mission and FTP tools, and MAVProxy through the router.

    services_pymavlink.py --ferrolink BIN --workdir DIR [--only CHECK,...] [--seed N]

Checks (each prints ``ok``, ``FAIL`` or ``skip``; the last line is ``N passed, M failed``):

  mavwp      pymavlink's mavwp.MAVWPLoader loads a QGC WPL 110 file and a pymavlink ground
             station uploads it to ``ferrolink mavlink vehicle`` (MISSION_COUNT, answering each
             MISSION_REQUEST_INT with the loader's item); it downloads the mission back into a
             new loader with MISSION_REQUEST (answered with MISSION_ITEM, in degrees), saves it,
             and the saved file equals the one loaded. Our CLI's
             download of the same mission is item for item the same.
  mavftp     pymavlink's mavftp.MAVFTP against the vehicle's --ftp-root: the listing, a
             300 kB burst read with pymavlink's own burst size (80 bytes a reply), a
             100 kB write; each checked against the directory on disk.
  mavproxy   MAVProxy on a TCP endpoint of ``ferrolink mavlink router``, the vehicle on a UDP
             one: its parameter download (it tries MAVLink FTP's @PARAM/param.pck first and
             falls back to the parameter protocol on our NAK) saves every parameter with the
             vehicle's value, and ``wp list`` saves the mission our CLI uploaded through the
             router, item for item.
  mavproxy_flies
             MAVProxy through the router flies the vehicle (ArduCopter): ``mode GUIDED``,
             ``arm throttle``, ``takeoff 10``; MAVProxy's prompt shows our STABILIZE and
             GUIDED, and our ``telemetry`` on another endpoint sees it armed at 10 m.
"""
import argparse
import math
import os
import random
import shutil
import signal
import subprocess
import sys
import time

sys.dont_write_bytecode = True  # keep the source tree clean
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import services_mavsdk as base  # noqa: E402  (the shared parameter table and mission spec)
from ports import free_port  # noqa: E402

HOST = "127.0.0.1"


class CheckFailed(Exception):
    pass


class CheckSkipped(Exception):
    pass


def start(cmd, log, **kw):
    return subprocess.Popen(cmd, stdout=open(log, "wb"), stderr=subprocess.STDOUT, **kw)


def wait_text(path, needle, timeout, proc=None):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if os.path.exists(path):
            with open(path, "rb") as f:
                if needle.encode() in f.read():
                    return True
        if proc is not None and proc.poll() is not None:
            return False
        time.sleep(0.1)
    return False


def finish(*procs):
    for p in procs:
        if p is not None and p.poll() is None:
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(5)
            except subprocess.TimeoutExpired:
                p.kill()


def vehicle(args, port, name, ftp_root=None, seconds=90):
    """``ferrolink mavlink vehicle`` with the shared parameter table, talking to udpin `port`."""
    params = os.path.join(args.workdir, "pymavlink.params")
    base.write_params(params)
    log = os.path.join(args.workdir, name + "-vehicle.log")
    extra = ["--ftp-root", ftp_root] if ftp_root else []
    p = start([args.ferrolink, "mavlink", "vehicle", "--params", params, "--autopilot",
               "ardupilotmega", "--run-for", str(seconds), *extra,
               "udpout://%s:%d" % (HOST, port)], log)
    if not wait_text(log, "ready", 10, p):
        finish(p)
        raise CheckFailed("the vehicle did not start")
    return p


def gcs(port):
    from pymavlink import mavutil
    m = mavutil.mavlink_connection("udpin:%s:%d" % (HOST, port), source_system=255,
                                   source_component=190, dialect="common")
    if m.wait_heartbeat(timeout=10) is None:
        raise CheckFailed("no HEARTBEAT from the vehicle")
    return m


def recv(m, types, timeout=2.0):
    return m.recv_match(type=types, blocking=True, timeout=timeout)


def same_number(a, b):
    """Equal as the file's numbers go: NaN as NaN, others to float32 precision."""
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-6)


def check_mavwp(args):
    from pymavlink import mavwp
    spec = base.mission_spec(40)
    wpl = os.path.join(args.workdir, "mavwp-in.waypoints")
    base.write_wpl(wpl, spec)
    port = free_port()
    v = vehicle(args, port, "mavwp")
    try:
        m = gcs(port)
        loader = mavwp.MAVWPLoader(target_system=1, target_component=1)
        if loader.load(wpl) != len(spec):
            raise CheckFailed("mavwp loaded %d of %d items" % (loader.count(), len(spec)))
        for _attempt in range(5):
            m.mav.mission_count_send(1, 1, loader.count(), 0)
            ack = None
            deadline = time.monotonic() + 20
            while time.monotonic() < deadline:
                msg = recv(m, ["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"])
                if msg is None:
                    break
                if msg.get_type() == "MISSION_ACK":
                    ack = msg
                    break
                item = loader.wp(msg.seq)
                item.target_system, item.target_component = 1, 1
                m.mav.send(item)
            if ack is not None:
                break
        if ack is None or ack.type != 0:
            raise CheckFailed("the upload ended with %s" % ack)
        down = mavwp.MAVWPLoader(target_system=1, target_component=1)
        m.mav.mission_request_list_send(1, 1, 0)
        count = recv(m, "MISSION_COUNT", 5)
        if count is None:
            raise CheckFailed("no MISSION_COUNT")
        seq = 0
        while seq < count.count:
            # MISSION_REQUEST, as mavwp's loader keeps MISSION_ITEMs: answered in degrees.
            m.mav.mission_request_send(1, 1, seq, 0)
            msg = recv(m, ["MISSION_ITEM"], 1.0)
            if msg is None or msg.seq != seq:
                continue
            down.add(msg)
            seq += 1
        m.mav.mission_ack_send(1, 1, 0, 0)
        saved = os.path.join(args.workdir, "mavwp-out.waypoints")
        down.save(saved)
        with open(wpl) as a, open(saved) as b:
            want, got = a.read().split("\n"), b.read().split("\n")
        mine = [l.split("\t") for l in want if l.strip()][1:]
        theirs = [l.split("\t") for l in got if l.strip()][1:]
        if len(mine) != len(theirs):
            raise CheckFailed("saved %d items, loaded %d" % (len(theirs), len(mine)))
        for a, b in zip(mine, theirs):
            # Field by field: numbers compared as numbers (mavwp prints its own way).
            if any(not same_number(float(x), float(y)) for x, y in zip(a, b)):
                raise CheckFailed("item differs:\n  %s\n  %s" % (a, b))
        m.close()
        rc = subprocess.run([args.ferrolink, "mavlink", "mission", "download",
                             "udpin://%s:%d" % (HOST, port)], capture_output=True, timeout=60)
        if rc.returncode != 0:
            raise CheckFailed("our download exited %d: %s" % (rc.returncode, rc.stderr[-300:]))
        # mavwp uploads MISSION_ITEMs, whose float32 degrees hold about 7 digits: the vehicle
        # holds what they said, which is what our download must print.
        ours = [l.split("\t") for l in rc.stdout.decode().split("\n") if l.strip()][1:]
        for a, b in zip(theirs, ours):
            if any(not same_number(float(x), float(y)) for x, y in zip(a, b)):
                raise CheckFailed("our download differs from mavwp's:\n  %s\n  %s" % (a, b))
    finally:
        finish(v)
    return "%d items up and down through mavwp, the saved file equal to the loaded one" % len(spec)


def check_mavftp(args):
    from pymavlink import mavftp
    root = os.path.join(args.workdir, "mavftp-root")
    shutil.rmtree(root, ignore_errors=True)
    os.makedirs(os.path.join(root, "logs"))
    data = random.Random(args.seed).randbytes(300_000)
    with open(os.path.join(root, "big.bin"), "wb") as f:
        f.write(data)
    port = free_port()
    v = vehicle(args, port, "mavftp", ftp_root=root)
    notes = []
    try:
        m = gcs(port)
        ftp = mavftp.MAVFTP(m, 1, 1)
        ret = ftp.cmd_list(["/"])
        listing = sorted((e.name, e.is_dir, e.size_b) for e in ret.directory_listing
                         if e.name not in (".", ".."))
        want = [("big.bin", False, len(data)), ("logs", True, 0)]
        if ret.error_code != mavftp.FtpError.Success or listing != want:
            raise CheckFailed("mavftp listed %s (%s), the directory holds %s"
                              % (listing, ret.error_code, want))
        local = os.path.join(args.workdir, "mavftp-got.bin")
        t0 = time.monotonic()
        ftp.cmd_get(["/big.bin", local])
        ret = ftp.process_ftp_reply("OpenFileRO", timeout=120)
        notes.append("get %.2f s" % (time.monotonic() - t0))
        if ret.error_code != mavftp.FtpError.Success:
            raise CheckFailed("mavftp get: %s" % ret.error_code)
        with open(local, "rb") as f:
            if f.read() != data:
                raise CheckFailed("mavftp's read differs from the file")
        up = os.path.join(args.workdir, "mavftp-up.bin")
        payload = random.Random(args.seed + 1).randbytes(100_000)
        with open(up, "wb") as f:
            f.write(payload)
        t0 = time.monotonic()
        ftp.cmd_put([up, "/logs/up.bin"])
        ret = ftp.process_ftp_reply("CreateFile", timeout=120)
        notes.append("put %.2f s" % (time.monotonic() - t0))
        if ret.error_code != mavftp.FtpError.Success:
            raise CheckFailed("mavftp put: %s" % ret.error_code)
        with open(os.path.join(root, "logs", "up.bin"), "rb") as f:
            if f.read() != payload:
                raise CheckFailed("mavftp's write differs on disk")
        m.close()
    finally:
        finish(v)
    return "listing, 300 kB read in 80-byte bursts, 100 kB written (%s)" % ", ".join(notes)


def start_mavproxy(wd, port, state, home, log):
    """MAVProxy, without its GUI, on tcp:HOST:port, target 1/1, its state in `state`, its
    output in `log`, commands on its stdin."""
    env = dict(os.environ, HOME=home, PYTHONUNBUFFERED="1", MPLBACKEND="Agg")
    env.pop("DISPLAY", None)
    return subprocess.Popen(
        [sys.executable, "-m", "MAVProxy.mavproxy", "--master=tcp:%s:%d" % (HOST, port),
         "--state-basedir=" + state, "--target-system=1", "--target-component=1"],
        stdin=subprocess.PIPE, stdout=open(log, "wb"), stderr=subprocess.STDOUT,
        env=env, cwd=wd)


def check_mavproxy(args):
    import importlib.util
    if importlib.util.find_spec("MAVProxy") is None:
        raise CheckSkipped("Python package 'MAVProxy' is not installed")
    wd = os.path.join(args.workdir, "mavproxy-services")
    shutil.rmtree(wd, ignore_errors=True)
    state, home, ftp_root = (os.path.join(wd, d) for d in ("state", "home", "ftp"))
    for d in (state, home, ftp_root):
        os.makedirs(d)
    p_vehicle = free_port()
    p_gcs = free_port()
    p_cli = free_port()
    router_log = os.path.join(wd, "router.log")
    router = start([args.ferrolink, "mavlink", "router", "udpin://%s:%d" % (HOST, p_vehicle),
                    "tcpin://%s:%d" % (HOST, p_gcs), "udpin://%s:%d" % (HOST, p_cli)],
                   router_log)
    v = mavproxy = None
    try:
        time.sleep(0.5)
        v = vehicle(args, p_vehicle, "mavproxy", ftp_root=ftp_root)
        spec = base.mission_spec(25)
        wpl = os.path.join(wd, "up.waypoints")
        base.write_wpl(wpl, spec)
        # Our CLI reaches the router's third endpoint, which sends to it once it has heard it.
        rc = subprocess.run([args.ferrolink, "mavlink", "mission", "upload",
                             "udpout://%s:%d" % (HOST, p_cli), wpl], capture_output=True,
                            timeout=60)
        if rc.returncode != 0:
            raise CheckFailed("our upload through the router exited %d: %s"
                              % (rc.returncode, rc.stderr[-300:]))
        log = os.path.join(wd, "mavproxy.log")
        mavproxy = start_mavproxy(wd, p_gcs, state, home, log)
        n = len(base.PARAMS)
        if not wait_text(log, "Saved %d parameters" % n, 40, mavproxy):
            raise CheckFailed("MAVProxy did not save %d parameters: %s"
                              % (n, open(log, errors="replace").read()[-600:]))
        mavproxy.stdin.write(b"wp list\n")
        mavproxy.stdin.flush()
        if not wait_text(log, "Saved %d waypoints" % len(spec), 30, mavproxy):
            raise CheckFailed("MAVProxy's wp list saved nothing: %s"
                              % open(log, errors="replace").read()[-600:])
        parm = {}
        with open(os.path.join(state, "mav.parm")) as f:
            for line in f:
                parts = line.split("#")[0].split()
                if len(parts) >= 2:
                    parm[parts[0]] = float(parts[1])
        for name, _ty, value in base.PARAMS:
            # mav.parm holds what MAVProxy prints, to about six decimals.
            if name not in parm or not same_number(parm[name], value):
                raise CheckFailed("%s is %s in MAVProxy's mav.parm, the vehicle has %s"
                                  % (name, parm.get(name), value))
        # MAVProxy keeps degrees as float32 (MISSION_ITEM's), about 7 digits.
        with open(os.path.join(state, "way.txt")) as f:
            got = [l.split("\t") for l in f.read().split("\n") if l.strip()][1:]
        with open(wpl) as f:
            want = [l.split("\t") for l in f.read().split("\n") if l.strip()][1:]
        if len(got) != len(want):
            raise CheckFailed("MAVProxy's wp list saved %d items, not %d" % (len(got), len(want)))
        for a, b in zip(want, got):
            if any(not same_number(float(x), float(y)) for x, y in zip(a, b)):
                raise CheckFailed("MAVProxy's wp list differs:\n  %s\n  %s" % (a, b))
    finally:
        finish(mavproxy, v, router)
    return "%d parameters and a %d-item mission through the router" % (n, len(spec))


def check_mavproxy_flies(args):
    """MAVProxy through our router flies our vehicle (as ArduCopter): `mode GUIDED`, `arm
    throttle`, `takeoff 10`; the modes MAVProxy shows are ours, and our `telemetry` through
    the router's other endpoint sees the climb."""
    import importlib.util
    import json
    if importlib.util.find_spec("MAVProxy") is None:
        raise CheckSkipped("Python package 'MAVProxy' is not installed")
    wd = os.path.join(args.workdir, "mavproxy-flies")
    shutil.rmtree(wd, ignore_errors=True)
    state, home = os.path.join(wd, "state"), os.path.join(wd, "home")
    for d in (state, home):
        os.makedirs(d)
    p_vehicle, p_gcs, p_cli = free_port(), free_port(), free_port()
    router = start([args.ferrolink, "mavlink", "router", "udpin://%s:%d" % (HOST, p_vehicle),
                    "tcpin://%s:%d" % (HOST, p_gcs), "udpin://%s:%d" % (HOST, p_cli)],
                   os.path.join(wd, "router.log"))
    v = mavproxy = None
    try:
        time.sleep(0.5)
        v = vehicle(args, p_vehicle, "mavproxy-flies")
        log = os.path.join(wd, "mavproxy.log")
        mavproxy = start_mavproxy(wd, p_gcs, state, home, log)

        def say(line, expect, seconds=20):
            mavproxy.stdin.write(line.encode() + b"\n")
            mavproxy.stdin.flush()
            if not wait_text(log, expect, seconds, mavproxy):
                raise CheckFailed("MAVProxy's `%s` never showed %r: %s"
                                  % (line, expect, open(log, errors="replace").read()[-800:]))

        # MAVProxy names our modes from the heartbeat with pymavlink's ArduCopter table.
        if not wait_text(log, "STABILIZE>", 30, mavproxy):
            raise CheckFailed("MAVProxy did not show our STABILIZE: %s"
                              % open(log, errors="replace").read()[-800:])
        say("mode GUIDED", "GUIDED>")
        say("arm throttle", "ARMED")
        say("takeoff 10", "Got COMMAND_ACK: NAV_TAKEOFF: ACCEPTED")
        # Our telemetry through the router's third endpoint: armed, GUIDED, 10 m up.
        time.sleep(4.0)
        out = subprocess.run([args.ferrolink, "mavlink", "telemetry",
                              "udpout://%s:%d" % (HOST, p_cli), "--duration", "3"],
                             capture_output=True, timeout=30)
        lines = [json.loads(l) for l in out.stdout.decode().splitlines()]
        states = [l for l in lines if l["kind"] == "state"]
        heights = [l["alt_rel"] for l in lines if l["kind"] == "position"]
        if not states or states[-1]["mode"] != "GUIDED" or not states[-1]["armed"]:
            raise CheckFailed("our telemetry through the router saw %s" % states[-1:])
        if not heights or abs(heights[-1] - 10.0) > 0.01:
            raise CheckFailed("the vehicle is at %s m, not 10" % heights[-1:])
    finally:
        finish(mavproxy, v, router)
    return "mode GUIDED, arm throttle, takeoff 10 through the router: at %.1f m, %s" % (
        heights[-1], states[-1]["mode"])


CHECKS = {"mavwp": check_mavwp, "mavftp": check_mavftp, "mavproxy": check_mavproxy,
          "mavproxy_flies": check_mavproxy_flies}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ferrolink", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--only", action="append", default=[])
    ap.add_argument("--seed", type=int, default=20261126)
    args = ap.parse_args()
    args.ferrolink = os.path.abspath(args.ferrolink)
    os.makedirs(args.workdir, exist_ok=True)
    only = [n for item in args.only for n in item.split(",") if n]
    passed = failed = 0
    for name, check in CHECKS.items():
        if only and name not in only:
            continue
        t0 = time.monotonic()
        try:
            note = check(args)
        except CheckSkipped as e:
            print("skip %s: %s" % (name, e), flush=True)
            continue
        except Exception as e:  # a failed check or a bug in the driver: a failure either way
            failed += 1
            print("FAIL %s: %s: %s" % (name, type(e).__name__, e), flush=True)
            continue
        passed += 1
        print("ok   %s (%.1f s): %s" % (name, time.monotonic() - t0, note), flush=True)
    print("%d passed, %d failed" % (passed, failed), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
