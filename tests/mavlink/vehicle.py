#!/usr/bin/env python3
"""A small MAVLink vehicle built on pymavlink, for tests against real peer software.

    vehicle.py CONNECTION [--seconds S] [--sysid N] [--params N]

CONNECTION is a pymavlink connection string (``udpout:127.0.0.1:14550``, ``tcp:...``). The
vehicle (compid 1, an ArduPilot quadrotor) sends HEARTBEAT at 1 Hz and ATTITUDE at 10 Hz,
answers every COMMAND_LONG addressed to it with an accepted COMMAND_ACK to the sender,
and answers PARAM_REQUEST_LIST / PARAM_REQUEST_READ / PARAM_SET with PARAM_VALUE for N
parameters. It prints one line per request it answered and exits after S seconds.
"""
import argparse
import math
import os
import sys
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("connection")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--sysid", type=int, default=1)
    ap.add_argument("--params", type=int, default=20)
    args = ap.parse_args()

    m = mavutil.mavlink_connection(args.connection, source_system=args.sysid,
                                   source_component=1, dialect="common")
    names = ["PARAM_%02d" % i for i in range(args.params)]
    values = {name: float(i) * 1.5 for i, name in enumerate(names)}
    REAL32 = mavutil.mavlink.MAV_PARAM_TYPE_REAL32

    def send_param(i):
        name = names[i]
        m.mav.param_value_send(name.encode(), values[name], REAL32, len(names), i)

    start = time.time()
    next_hb = next_att = start
    while time.time() - start < args.seconds:
        now = time.time()
        if now >= next_hb:
            m.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_QUADROTOR,
                                 mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0,
                                 mavutil.mavlink.MAV_STATE_ACTIVE)
            next_hb += 1.0
        if now >= next_att:
            t = now - start
            m.mav.attitude_send(int(t * 1000), 0.1 * math.sin(t), 0.05, 1.0, 0, 0, 0)
            next_att += 0.1
        msg = m.recv_match(blocking=True, timeout=0.02)
        if msg is None:
            continue
        kind = msg.get_type()
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind == "COMMAND_LONG" and msg.target_system in (0, args.sysid):
            m.mav.command_ack_send(msg.command, mavutil.mavlink.MAV_RESULT_ACCEPTED, 0, 0,
                                   src[0], src[1])
            print("command %d from %d/%d acknowledged" % (msg.command, src[0], src[1]),
                  flush=True)
        elif kind == "PARAM_REQUEST_LIST" and msg.target_system == args.sysid:
            for i in range(len(names)):
                send_param(i)
            print("parameter list sent to %d/%d" % src, flush=True)
        elif kind == "PARAM_REQUEST_READ" and msg.target_system == args.sysid:
            pid = msg.param_id if isinstance(msg.param_id, str) else msg.param_id.decode()
            i = msg.param_index if msg.param_index >= 0 else names.index(pid) if pid in names else -1
            if 0 <= i < len(names):
                send_param(i)
        elif kind == "PARAM_SET" and msg.target_system == args.sysid:
            pid = msg.param_id if isinstance(msg.param_id, str) else msg.param_id.decode()
            if pid in values:
                values[pid] = msg.param_value
                send_param(names.index(pid))
                print("parameter %s set to %g" % (pid, msg.param_value), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
