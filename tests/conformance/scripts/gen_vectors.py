#!/usr/bin/env python3
"""Generate per-message conformance vectors from pymavlink.

Usage:
    python gen_vectors.py DIALECT.xml OUT.jsonl [--seed N] [--per-message K]

For every message of the dialect (included files too) K vectors are written,
one JSON object per line:

    {"name": ..., "id": ..., "crc_extra": ...,
     "fields": <to_dict() of the message decoded by pymavlink from "v2">,
     "seq": ..., "sysid": ..., "compid": ...,
     "v2": "<hex, pymavlink MAVLink 2 frame, unsigned>",
     "v1": "<hex, MAVLink 1 frame with base fields only>" | null}

The v1 frame is built here the way the MAVLink C library sends it (payload
is the MIN_LEN base part); pymavlink's own force_mavlink1 path would append
the extension fields.  Output is deterministic for a given dialect and seed.
"""

import argparse
import json
import os
import sys
import time

sys.dont_write_bytecode = True  # keep the source tree clean
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import mavvectors as mv  # noqa: E402

DEFAULT_SEED = 20240501


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dialect", help="dialect XML file")
    ap.add_argument("out", help="output JSON lines file")
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED)
    ap.add_argument("--per-message", type=int, default=3, metavar="K")
    args = ap.parse_args(argv)
    if args.per_message < 1:
        ap.error("--per-message must be at least 1")

    t0 = time.monotonic()
    dialect = mv.Dialect(args.dialect)
    codec = mv.Codec(dialect)
    t_load = time.monotonic() - t0

    n_vec = n_v1 = n_trunc = n_ext = 0
    out_dir = os.path.dirname(os.path.abspath(args.out))
    os.makedirs(out_dir, exist_ok=True)
    with open(args.out, "w", encoding="ascii", newline="\n") as out:
        for msg in dialect.messages:
            # One RNG per message: vectors of a message do not depend on
            # which other messages the dialect contains.
            rng = mv.make_rng(args.seed, "vectors", msg.name)
            gen = mv.ValueGenerator(dialect, rng)
            for k in range(args.per_message):
                mode = mv.mode_for_vector(msg, k, rng)
                values = gen.gen_values(msg, mode)
                seq = rng.randint(0, 255)
                sysid = rng.randint(1, 255)
                compid = rng.randint(0, 255)
                v2, v1, fields = mv.make_vector(codec, msg, values,
                                                seq, sysid, compid)
                rec = {
                    "name": msg.name,
                    "id": msg.id,
                    "crc_extra": msg.crc_extra,
                    "fields": fields,
                    "seq": seq,
                    "sysid": sysid,
                    "compid": compid,
                    "v2": v2.hex(),
                    "v1": v1.hex() if v1 is not None else None,
                }
                line = json.dumps(rec, allow_nan=False, separators=(",", ":"))
                # JSON numbers must give back the very same values.
                assert json.loads(line)["fields"] == fields
                out.write(line + "\n")
                n_vec += 1
                n_v1 += v1 is not None
                n_trunc += (v2[1] < msg.max_len)
                n_ext += msg.has_extensions

    elapsed = time.monotonic() - t0
    n_big = sum(1 for m in dialect.messages if m.id > 255)
    n_extmsg = sum(1 for m in dialect.messages if m.has_extensions)
    print("%s: %d messages from %d files (%d with extensions, %d ids > 255), "
          "%d vectors (%d with v1, %d truncated v2), %d bytes, "
          "%.2fs (mavgen+parse %.2fs)"
          % (os.path.basename(args.dialect), len(dialect.messages),
             len(dialect.files), n_extmsg, n_big, n_vec, n_v1, n_trunc,
             os.path.getsize(args.out), elapsed, t_load), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
