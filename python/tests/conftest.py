"""Shared fixtures: pymavlink (the reference, MAVLink 2 module), generated logs, the test data."""

import math
import os
import random
import struct
from pathlib import Path

import pytest

# pymavlink's MAVLink 2 module decodes MAVLink 1 and 2 frames, extension fields included, as
# ArduPilot's tools set it up. It must be chosen before mavutil is imported.
os.environ["MAVLINK20"] = "1"

from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v10 import ardupilotmega as apm1  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as apm2  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
CAPTURES = ROOT.parent / "shared" / "captures"

INT_RANGES = {
    "int8_t": (-(1 << 7), (1 << 7) - 1),
    "uint8_t": (0, (1 << 8) - 1),
    "int16_t": (-(1 << 15), (1 << 15) - 1),
    "uint16_t": (0, (1 << 16) - 1),
    "int32_t": (-(1 << 31), (1 << 31) - 1),
    "uint32_t": (0, (1 << 32) - 1),
    "int64_t": (-(1 << 63), (1 << 63) - 1),
    "uint64_t": (0, (1 << 64) - 1),
}


def random_value(rng, ftype, length):
    """A random value pymavlink's encoder takes for a field of type `ftype` (`length` > 0 for
    arrays): the edges, zero, NaN and infinities among them."""
    if ftype == "char":
        n = rng.randint(0, max(length, 1))
        # ASCII, and now and then a byte above 0x7f (pymavlink shows it as U+FFFD).
        return bytes(rng.choice([rng.randint(32, 126), rng.randint(128, 255)]) for _ in range(n))
    if length:
        return [random_value(rng, ftype, 0) for _ in range(length)]
    if ftype in ("float", "double"):
        pick = rng.random()
        if pick < 0.05:
            return float("nan")
        if pick < 0.08:
            return rng.choice([float("inf"), float("-inf"), 0.0, -0.0])
        x = rng.uniform(-1e6, 1e6)
        return struct.unpack("<f", struct.pack("<f", x))[0] if ftype == "float" else x
    lo, hi = INT_RANGES[ftype]
    return rng.choice([lo, hi, 0, rng.randint(lo, hi)])


def encode_all(seed=1, rounds=3, mavlink1=True):
    """Every ardupilotmega message, `rounds` times, with random values, as frames from random
    senders: MAVLink 2, and MAVLink 1 for ids below 256 whose frames are 12 bytes or longer
    (shorter ones meet pymavlink's tlog reader's peek, tested on its own)."""
    rng = random.Random(seed)
    frames = []
    for r in range(rounds):
        for msgid, cls in sorted(apm2.mavlink_map.items()):
            # Types are in XML order, array lengths in wire order.
            lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths))
            values = [
                random_value(rng, t, lengths[name])
                for name, t in zip(cls.fieldnames, cls.fieldtypes)
            ]
            sender = (rng.randint(1, 255), rng.randint(0, 255))
            v1cls = apm1.mavlink_map.get(msgid)
            use_v1 = mavlink1 and v1cls is not None and r % 2 == 1
            if use_v1:
                mav = apm1.MAVLink(None, srcSystem=sender[0], srcComponent=sender[1])
                base = len(v1cls.fieldnames)
                frame = v1cls(*values[:base]).pack(mav)
                if len(frame) < 12:
                    continue
            else:
                mav = apm2.MAVLink(None, srcSystem=sender[0], srcComponent=sender[1])
                frame = cls(*values).pack(mav)
            mav.seq = rng.randint(0, 255)
            frames.append(bytes(frame))
    return frames


def write_tlog(path, frames, start_us=1_700_000_000_000_000, step_us=1_234):
    with open(path, "wb") as f:
        for i, frame in enumerate(frames):
            f.write(struct.pack(">Q", start_us + i * step_us))
            f.write(frame)
    return path


def pymavlink_messages(path, raw=False):
    """Every message pymavlink 2.4.50 reads from a log, as mavlogdump reads it."""
    conn = mavutil.mavlink_connection(str(path), dialect="ardupilotmega", notimestamps=raw)
    out = []
    while True:
        m = conn.recv_match()
        if m is None:
            break
        out.append(m)
    conn.close()
    return out


def same(a, b):
    """Equal, NaN equal to NaN, key for key and value for value (types included)."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if isinstance(a, dict) and isinstance(b, dict):
        return list(a) == list(b) and all(same(a[k], b[k]) for k in a)
    if isinstance(a, (list, bytearray)) and isinstance(b, (list, bytearray)):
        return type(a) is type(b) and len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return type(a) is type(b) and a == b


@pytest.fixture(scope="session")
def generated_tlog(tmp_path_factory):
    """Every ardupilotmega message, three times, random values, MAVLink 1 and 2."""
    return write_tlog(tmp_path_factory.mktemp("logs") / "all.tlog", encode_all())


@pytest.fixture(scope="session")
def captures():
    """The real captures of the test data; the tests that use them skip without it."""
    if not CAPTURES.is_dir():
        pytest.skip(f"{CAPTURES} is absent: the tests on real captures are skipped")
    return sorted(CAPTURES.glob("*.tlog"))
