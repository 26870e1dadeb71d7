#!/usr/bin/env python3
"""Decode a telemetry log with pymavlink and print one JSON line per message.

Usage:
    pymavlink_dump.py [--raw] [--dialect NAME] [--wire auto|2] FILE

FILE is a ``.tlog`` (8-byte big-endian timestamp before every frame) or, with
--raw, a raw byte stream without timestamps.  The log is read the way the
reference decoder does it, ``mavutil.mavlink_connection(FILE, dialect=NAME)``
(plus ``notimestamps=True`` for --raw), looping ``recv_msg()`` until it
returns None at the end of the file.

Output, one JSON object per line, for every message pymavlink decoded as a
message of the dialect:

    {"sysid": .., "compid": .., "seq": .., "msg": {<to_dict()>}}

BAD_DATA (bytes that did not make a valid frame, bad CRCs included) and
UNKNOWN_<id> (ids the dialect lacks; pymavlink does not CRC-check those) are
not printed but counted.  The last line is

    {"summary": {"messages": N, "bad_data": B, "unknown": U}}

Float NaN and infinities are written as null, so the output is strict JSON.

--wire selects the pymavlink dialect module.  With the default, 2, the
MAVLink 2 module is used from the start (it decodes MAVLink 1 and 2 frames,
extension fields included).  With "auto" pymavlink picks the module from the
first frame of the file, as it does when MAVLINK20 is not set: a log that
starts with a MAVLink 1 frame is then decoded without extension fields.
"""

import argparse
import json
import math
import os
import sys

sys.dont_write_bytecode = True  # keep the source tree clean


def json_safe(value):
    """Turn a to_dict() value into plain JSON: NaN/inf become None, bytes
    become str the way pymavlink's format_attr does it."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, (bytes, bytearray)):
        return bytes(value).decode(errors="backslashreplace").rstrip("\x00")
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    return value


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file", help="telemetry log (.tlog, or raw stream with --raw)")
    ap.add_argument("--raw", action="store_true",
                    help="the file is a raw byte stream without timestamps")
    ap.add_argument("--dialect", default="ardupilotmega",
                    help="pymavlink dialect name (default: %(default)s)")
    ap.add_argument("--wire", choices=("auto", "2"), default="2",
                    help="pymavlink module selection (default: %(default)s)")
    args = ap.parse_args(argv)

    if args.wire == "2":
        os.environ["MAVLINK20"] = "1"
    else:
        os.environ.pop("MAVLINK20", None)
    # Imported only now: mavutil picks its default module at import time.
    from pymavlink import mavutil

    if not os.path.isfile(args.file):
        ap.error("no such file: %s" % args.file)
    conn = mavutil.mavlink_connection(args.file, dialect=args.dialect,
                                      notimestamps=args.raw)

    n_msg = n_bad = n_unknown = 0
    out = sys.stdout
    try:
        while True:
            m = conn.recv_msg()
            if m is None:  # end of file
                break
            mtype = m.get_type()
            if mtype == "BAD_DATA":
                n_bad += 1
                continue
            if mtype.startswith("UNKNOWN_"):
                n_unknown += 1
                continue
            n_msg += 1
            record = {
                "sysid": m.get_srcSystem(),
                "compid": m.get_srcComponent(),
                "seq": m.get_seq(),
                "msg": json_safe(m.to_dict()),
            }
            out.write(json.dumps(record, allow_nan=False) + "\n")
    finally:
        conn.close()

    summary = {"messages": n_msg, "bad_data": n_bad, "unknown": n_unknown}
    out.write(json.dumps({"summary": summary}) + "\n")
    out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
