#!/usr/bin/env python3
"""Generate a raw MAVLink byte capture and its expected decode.

Usage:
    python gen_stream.py DIALECT.xml OUT.bin OUT_EXPECTED.jsonl [--seed N] [--frames N]

OUT.bin holds N frames of random messages with random values: MAVLink 2
frames encoded by pymavlink and, for ids <= 255, some MAVLink 1 frames built
the way the C library sends them (base fields only).  Garbage bytes are put
between some frames; garbage never contains 0xFD or 0xFE, so any correct
parser must recover exactly the listed frames.

OUT_EXPECTED.jsonl has one line per frame, in stream order:
    {"sysid": .., "compid": .., "seq": .., "msg": {<to_dict() as pymavlink decodes it>}}
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
GARBAGE_BYTES = bytes(b for b in range(256) if b not in (mv.MAGIC_V1, mv.MAGIC_V2))

V1_PROBABILITY = 0.25
GARBAGE_PROBABILITY = 0.3
GARBAGE_MAX = 40


def garbage(rng):
    n = rng.randint(1, GARBAGE_MAX)
    return bytes(rng.choice(GARBAGE_BYTES) for _ in range(n))


def reparse_with_pymavlink(dialect, stream):
    """Feed the capture to pymavlink's own stream parser (self-check)."""
    mav = dialect.module.MAVLink(None)
    mav.robust_parsing = True
    out = []
    for m in mav.parse_buffer(stream) or []:
        if m.get_type() == "BAD_DATA":
            continue
        out.append(m)
    # parse_buffer stops on the first None; drain what is left.
    while True:
        m = mav.parse_char(b"")
        if m is None:
            break
        if m.get_type() != "BAD_DATA":
            out.append(m)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dialect", help="dialect XML file")
    ap.add_argument("out_bin", help="raw byte capture to write")
    ap.add_argument("out_expected", help="expected decode (JSON lines)")
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED)
    ap.add_argument("--frames", type=int, default=300)
    args = ap.parse_args(argv)
    if args.frames < 0:
        ap.error("--frames must not be negative")

    t0 = time.monotonic()
    dialect = mv.Dialect(args.dialect)
    codec = mv.Codec(dialect)
    rng = mv.make_rng(args.seed, "stream")
    gen = mv.ValueGenerator(dialect, rng)

    # A few talking components, each with its own sequence counter, plus
    # the odd one-off sender.
    links = {}
    for _ in range(4):
        key = (rng.randint(1, 255), rng.randint(0, 255))
        links[key] = rng.randint(0, 255)
    link_keys = sorted(links)

    stream = bytearray()
    expected = []
    n_v1 = n_garbage = n_garbage_bytes = 0
    for _ in range(args.frames):
        if rng.random() < GARBAGE_PROBABILITY:
            g = garbage(rng)
            stream += g
            n_garbage += 1
            n_garbage_bytes += len(g)
        msg = rng.choice(dialect.messages)
        mode = rng.choice(mv.ALL_MODES)
        values = gen.gen_values(msg, mode)
        if rng.random() < 0.9:
            sysid, compid = rng.choice(link_keys)
            seq = links[(sysid, compid)]
            links[(sysid, compid)] = (seq + 1) & 0xFF
        else:
            sysid, compid, seq = rng.randint(1, 255), rng.randint(0, 255), rng.randint(0, 255)
        v2, v1, fields = mv.make_vector(codec, msg, values, seq, sysid, compid)
        frame = v2
        if v1 is not None and rng.random() < V1_PROBABILITY:
            frame = v1
            fields = codec.decode_dict(msg, v1)
            n_v1 += 1
        stream += frame
        expected.append({"sysid": sysid, "compid": compid, "seq": seq,
                         "msg": fields})
    if args.frames and rng.random() < 0.5:
        g = garbage(rng)
        stream += g
        n_garbage += 1
        n_garbage_bytes += len(g)

    # Self-check: pymavlink must recover every frame, in order.
    got = reparse_with_pymavlink(dialect, bytes(stream))
    assert len(got) == len(expected), (len(got), len(expected))
    for m, e in zip(got, expected):
        assert (m.get_srcSystem(), m.get_srcComponent(), m.get_seq()) == (
            e["sysid"], e["compid"], e["seq"])
        d = mv.normalize_dict(dialect.by_name[m.get_type()], m.to_dict())
        assert d == e["msg"], (d, e["msg"])

    for path in (args.out_bin, args.out_expected):
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(args.out_bin, "wb") as f:
        f.write(stream)
    with open(args.out_expected, "w", encoding="ascii", newline="\n") as f:
        for e in expected:
            line = json.dumps(e, allow_nan=False, separators=(",", ":"))
            assert json.loads(line) == e
            f.write(line + "\n")

    print("%s: %d frames (%d v1, %d v2), %d garbage runs (%d bytes), "
          "%d bytes captured, %d distinct messages, %.2fs"
          % (os.path.basename(args.dialect), len(expected), n_v1,
             len(expected) - n_v1, n_garbage, n_garbage_bytes, len(stream),
             len(set(e["msg"]["mavpackettype"] for e in expected)),
             time.monotonic() - t0), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
