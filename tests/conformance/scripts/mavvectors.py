"""Shared helpers for the pymavlink conformance generators.

This module turns a MAVLink dialect XML file into:

* a freshly generated pymavlink (mavgen, Python3, wire protocol 2.0) module,
  imported at runtime, which is the encoding/decoding oracle;
* a parsed description of every message (field types, wire order, extension
  boundary, CRC_EXTRA, lengths) taken from ``pymavlink.generator.mavparse``;
* random, in-range field values and the frames built from them.

Only the standard library and pymavlink (with its own dependencies) are used.
"""

import contextlib
import importlib.util
import io
import os
import random
import re
import struct
import sys
import tempfile

from pymavlink.generator import mavgen, mavparse
from pymavlink.generator.mavcrc import x25crc

MAGIC_V1 = 0xFE
MAGIC_V2 = 0xFD
V2_HEADER_LEN = 10
V1_HEADER_LEN = 6

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

TYPE_SIZES = {
    "char": 1, "int8_t": 1, "uint8_t": 1, "int16_t": 2, "uint16_t": 2,
    "int32_t": 4, "uint32_t": 4, "int64_t": 8, "uint64_t": 8,
    "float": 4, "double": 8,
}

PRINTABLE = "".join(chr(c) for c in range(0x20, 0x7F))

# Value-generation modes.
MODE_MIXED = "mixed"      # everything random, extensions set
MODE_NOEXT = "noext"      # extensions zero, some base fields zero
MODE_EXTREME = "extreme"  # range limits, full-length strings
MODE_SPARSE = "sparse"    # mostly zero, sometimes the whole payload
ALL_MODES = (MODE_MIXED, MODE_NOEXT, MODE_EXTREME, MODE_SPARSE)


# ---------------------------------------------------------------------------
# CRC
# ---------------------------------------------------------------------------

def crc_mcrf4xx(data, crc=0xFFFF):
    """CRC-16/MCRF4XX (reflected 0x1021, init 0xFFFF, no final xor)."""
    for b in data:
        tmp = (b ^ crc) & 0xFF
        tmp = (tmp ^ (tmp << 4)) & 0xFF
        crc = ((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)) & 0xFFFF
    return crc


def frame_crc(body, crc_extra):
    """Checksum of a frame: ``body`` is everything after the magic byte up
    to the end of the payload."""
    return crc_mcrf4xx(bytes([crc_extra]), crc_mcrf4xx(body))


def compute_crc_extra(name, base_fields_wire_order):
    """CRC_EXTRA from the message name and its base fields in wire order.

    ``base_fields_wire_order`` is a sequence of (c_type, name, array_length).
    """
    crc = crc_mcrf4xx((name + " ").encode())
    for ctype, fname, alen in base_fields_wire_order:
        crc = crc_mcrf4xx((ctype + " ").encode(), crc)
        crc = crc_mcrf4xx((fname + " ").encode(), crc)
        if alen:
            crc = crc_mcrf4xx(bytes([alen]), crc)
    return (crc & 0xFF) ^ (crc >> 8)


# ---------------------------------------------------------------------------
# Dialect loading
# ---------------------------------------------------------------------------

class FieldInfo(object):
    __slots__ = ("name", "ctype", "array_length", "enum", "bitmask",
                 "extension", "const_value", "wire_offset", "size")

    def __init__(self, name, ctype, array_length, enum, bitmask, extension,
                 const_value, wire_offset, size):
        self.name = name
        self.ctype = ctype
        self.array_length = array_length
        self.enum = enum
        self.bitmask = bitmask
        self.extension = extension
        self.const_value = const_value
        self.wire_offset = wire_offset
        self.size = size

    def zero_value(self):
        """The value a decoder reports for an all-zero field (to_dict form)."""
        if self.ctype == "char":
            return ""
        scalar = 0.0 if self.ctype in ("float", "double") else 0
        if self.array_length:
            return [scalar] * self.array_length
        return scalar


class MessageInfo(object):
    def __init__(self, name, msgid, crc_extra, min_len, max_len, fields, cls,
                 source):
        self.name = name
        self.id = msgid
        self.crc_extra = crc_extra
        self.min_len = min_len
        self.max_len = max_len
        self.fields = fields          # XML order
        self.cls = cls                # generated pymavlink class
        self.source = source          # file that defines the message

    @property
    def has_extensions(self):
        return any(f.extension for f in self.fields)


def _quiet_call(func, *args, **kwargs):
    """Run a chatty pymavlink function with its stdout captured.  The text is
    replayed on stderr if the call fails."""
    buf = io.StringIO()
    try:
        with contextlib.redirect_stdout(buf):
            return func(*args, **kwargs)
    except BaseException:
        sys.stderr.write(buf.getvalue())
        raise


def _parse_tree(xml_path):
    """Parse a dialect and every file it includes (breadth first), the way
    mavgen does.  Returns a list of MAVXML objects, root first."""
    root = os.path.abspath(xml_path)
    docs = []
    seen = set()
    queue = [root]
    while queue:
        path = queue.pop(0)
        if path in seen:
            continue
        seen.add(path)
        doc = _quiet_call(mavparse.MAVXML, path, mavparse.PROTOCOL_2_0)
        docs.append(doc)
        for inc in doc.include:
            queue.append(os.path.abspath(
                os.path.join(os.path.dirname(path), inc.strip())))
    return docs


def _merged_message_crcs(docs):
    """Mirror mavgen's include update: the root file ends up with the CRCs of
    every file below it."""
    merged = {}
    for doc in docs:
        merged.update(doc.message_crcs)
    return merged


def _generate_module(xml_path, workdir):
    base = re.sub(r"[^0-9A-Za-z_]", "_",
                  os.path.splitext(os.path.basename(xml_path))[0])
    modname = "conformance_dialect_" + base
    out_py = os.path.join(workdir, modname + ".py")
    opts = mavgen.Opts(out_py, wire_protocol=mavparse.PROTOCOL_2_0,
                       language="Python3")
    ok = _quiet_call(mavgen.mavgen, opts, [os.path.abspath(xml_path)])
    if not ok or not os.path.exists(out_py):
        raise RuntimeError("mavgen failed for %s" % xml_path)
    spec = importlib.util.spec_from_file_location(modname, out_py)
    module = importlib.util.module_from_spec(spec)
    sys.modules[modname] = module
    spec.loader.exec_module(module)
    return module


class Dialect(object):
    """A dialect, its generated pymavlink module and message descriptions."""

    def __init__(self, xml_path):
        self.xml_path = os.path.abspath(xml_path)
        with tempfile.TemporaryDirectory(prefix="mavgen-") as tmp:
            self.module = _generate_module(self.xml_path, tmp)
        docs = _parse_tree(self.xml_path)
        self.version = docs[0].version
        self.files = [os.path.basename(d.filename) for d in docs]
        xml_crcs = _merged_message_crcs(docs)
        enums = getattr(self.module, "enums", {})

        self.messages = []
        by_id = {}
        for doc in docs:
            for m in doc.message:
                if m.id in by_id:
                    raise RuntimeError("message id %d defined twice" % m.id)
                info = self._describe(m, doc, enums)
                by_id[m.id] = info
                self.messages.append(info)
        self.messages.sort(key=lambda mi: mi.id)
        self.by_id = by_id
        self.by_name = {mi.name: mi for mi in self.messages}

        gen_ids = set(self.module.mavlink_map.keys())
        if gen_ids != set(by_id):
            raise AssertionError(
                "generated module and XML disagree on message ids: %s"
                % sorted(gen_ids.symmetric_difference(by_id)))
        for mi in self.messages:
            assert xml_crcs[mi.id] == mi.crc_extra, mi.name

    def _describe(self, m, doc, enums):
        cls = self.module.mavlink_map[m.id]
        if cls.msgname != m.name:
            raise AssertionError("id %d: %s vs %s" % (m.id, cls.msgname, m.name))
        nbase = m.base_fields()
        ext_names = set(f.name for f in m.fields[nbase:])
        fields = []
        for f in m.fields:
            enum_name = cls.fieldenums_by_name.get(f.name) or (f.enum or None)
            bitmask = False
            if enum_name:
                e = enums.get(enum_name)
                bitmask = bool(getattr(e, "bitmask", False))
            if cls.fielddisplays_by_name.get(f.name) == "bitmask":
                bitmask = True
            fields.append(FieldInfo(
                name=f.name,
                ctype=f.type,
                array_length=f.array_length,
                enum=enum_name,
                bitmask=bitmask,
                extension=f.name in ext_names,
                const_value=f.const_value if f.omit_arg else None,
                wire_offset=f.wire_offset,
                size=f.wire_length,
            ))

        # Cross-checks against the generated class and the layout rules.
        assert list(cls.fieldnames) == [f.name for f in fields], m.name
        assert list(cls.ordered_fieldnames) == [f.name for f in m.ordered_fields], m.name
        assert cls.unpacker.size == m.wire_length, m.name
        base_wire = [(f.type, f.name, f.array_length)
                     for f in m.ordered_fields[:nbase]]
        crc_extra = compute_crc_extra(m.name, base_wire)
        assert crc_extra == m.crc_extra == cls.crc_extra, (
            m.name, crc_extra, m.crc_extra, cls.crc_extra)
        # Stable sort of the base fields by element size, largest first.
        expect = sorted(m.fields[:nbase], key=lambda f: -TYPE_SIZES[f.type])
        expect += m.fields[nbase:]
        assert [f.name for f in expect] == [f.name for f in m.ordered_fields], m.name
        assert m.wire_min_length == sum(f.wire_length for f in m.fields[:nbase])

        return MessageInfo(m.name, m.id, m.crc_extra, m.wire_min_length,
                           m.wire_length, fields, cls,
                           os.path.basename(doc.filename))


# ---------------------------------------------------------------------------
# Value generation
# ---------------------------------------------------------------------------

def _f32_from_bits(bits):
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def _f64_from_bits(bits):
    return struct.unpack("<d", struct.pack("<Q", bits))[0]


FLT_MAX = _f32_from_bits(0x7F7FFFFF)
FLT_MIN = _f32_from_bits(0x00800000)
FLT_TRUE_MIN = _f32_from_bits(0x00000001)
DBL_MAX = _f64_from_bits(0x7FEFFFFFFFFFFFFF)
DBL_MIN = _f64_from_bits(0x0010000000000000)
DBL_TRUE_MIN = _f64_from_bits(0x0000000000000001)

F32_SPECIALS = (0.0, -0.0, 1.0, -1.0, 0.5, FLT_MAX, -FLT_MAX, FLT_MIN, -FLT_MIN,
                FLT_TRUE_MIN, -FLT_TRUE_MIN, 16777216.0, -16777216.0,
                _f32_from_bits(0x40490FDB), _f32_from_bits(0x3DCCCCCD))
F64_SPECIALS = (0.0, -0.0, 1.0, -1.0, 0.1, DBL_MAX, -DBL_MAX, DBL_MIN, -DBL_MIN,
                DBL_TRUE_MIN, -DBL_TRUE_MIN, 9007199254740992.0,
                FLT_MAX, -FLT_MAX, 3.141592653589793)


def is_f32_exact(x):
    return struct.unpack("<f", struct.pack("<f", x))[0] == x


class ValueGenerator(object):
    """Produces constructor arguments for generated pymavlink messages."""

    def __init__(self, dialect, rng):
        self.dialect = dialect
        self.rng = rng
        self._named_cache = {}

    # -- scalars ------------------------------------------------------------

    def gen_int(self, ctype, mode):
        rng = self.rng
        lo, hi = INT_RANGES[ctype]
        if mode == MODE_EXTREME or rng.random() < 0.15:
            choices = [lo, hi, 0, 1, hi - 1, lo + 1]
            if lo < 0:
                choices += [-1, hi // 2 + 1, lo // 2]
            return rng.choice(choices)
        if rng.random() < 0.5:
            return rng.randint(lo, hi)
        nbits = TYPE_SIZES[ctype] * 8
        v = rng.getrandbits(rng.randint(1, nbits))
        if lo < 0 and rng.random() < 0.5:
            v = -v
        return max(lo, min(hi, v))

    def gen_f32(self, mode):
        rng = self.rng
        r = rng.random()
        if mode == MODE_EXTREME or r < 0.06:
            return rng.choice(F32_SPECIALS)
        if r < 0.20:
            return float(rng.randint(-4096, 4096)) / (1 << rng.randint(0, 10))
        sign = rng.getrandbits(1) << 31
        mant = rng.getrandbits(23)
        if r < 0.72:
            exp = rng.randint(-24, 24) + 127      # everyday magnitudes
        elif r < 0.94:
            exp = rng.randint(1, 254)             # whole normal range
        else:
            exp = 0                               # subnormal
            mant = mant or 1
        return _f32_from_bits(sign | (exp << 23) | mant)

    def gen_f64(self, mode):
        rng = self.rng
        r = rng.random()
        if mode == MODE_EXTREME or r < 0.06:
            return rng.choice(F64_SPECIALS)
        if r < 0.16:
            return self.gen_f32(MODE_MIXED)
        if r < 0.26:
            return float(rng.randint(-10 ** 7, 10 ** 7)) / (1 << rng.randint(0, 20))
        sign = rng.getrandbits(1) << 63
        mant = rng.getrandbits(52)
        if r < 0.76:
            exp = rng.randint(-60, 60) + 1023
        elif r < 0.95:
            exp = rng.randint(1, 2046)
        else:
            exp = 0
            mant = mant or 1
        return _f64_from_bits(sign | (exp << 52) | mant)

    def _named_values(self, field):
        key = (field.enum, field.ctype)
        if key not in self._named_cache:
            lo, hi = INT_RANGES[field.ctype]
            entries = self.dialect.module.enums.get(field.enum, {})
            vals = sorted(v for v, e in entries.items()
                          if lo <= v <= hi and not e.name.endswith("_ENUM_END"))
            self._named_cache[key] = vals
        return self._named_cache[key]

    def gen_enum(self, field, mode):
        rng = self.rng
        named = self._named_values(field)
        r = rng.random()
        lo, hi = INT_RANGES[field.ctype]
        if lo < 0 and r >= 0.85:
            # An enum on a signed field: pymavlink shows negative values as they are, and
            # they are outside every enum.
            return rng.choice((lo, -1, rng.randint(lo, -1)))
        if named and r < 0.5:
            if mode == MODE_EXTREME:
                return rng.choice((named[0], named[-1]))
            return rng.choice(named)
        if named and field.bitmask and r < 0.75:
            v = 0
            for _ in range(rng.randint(1, min(4, len(named)))):
                v |= rng.choice(named)
            lo, hi = INT_RANGES[field.ctype]
            if lo <= v <= hi:
                return v
        return self.gen_int(field.ctype, mode)

    def gen_scalar(self, field, mode):
        t = field.ctype
        if t == "float":
            return self.gen_f32(mode)
        if t == "double":
            return self.gen_f64(mode)
        if t == "char":
            if mode == MODE_EXTREME or self.rng.random() < 0.8:
                return self.rng.choice(PRINTABLE)
            return ""
        if field.enum:
            return self.gen_enum(field, mode)
        return self.gen_int(t, mode)

    def gen_string(self, n, mode):
        rng = self.rng
        r = rng.random()
        if mode == MODE_EXTREME:
            length = n if r < 0.75 else 0
        elif r < 0.12:
            length = 0
        elif r < 0.40:
            length = n
        elif n > 1:
            length = rng.randint(1, n - 1)
        else:
            length = n
        return "".join(rng.choice(PRINTABLE) for _ in range(length))

    # -- fields and messages ----------------------------------------------

    def gen_field(self, field, mode, zero_prob):
        """A value in to_dict form (str for char fields, list for arrays)."""
        if field.const_value is not None:
            return field.const_value
        rng = self.rng
        if rng.random() < zero_prob:
            return field.zero_value()
        if field.ctype == "char" and field.array_length:
            return self.gen_string(field.array_length, mode)
        if field.array_length:
            vals = [self.gen_scalar(field, mode) for _ in range(field.array_length)]
            if mode != MODE_EXTREME and rng.random() < 0.25:
                # Partly filled array, zero tail.
                keep = rng.randint(0, field.array_length)
                vals[keep:] = field.zero_value()[keep:]
            return vals
        return self.gen_scalar(field, mode)

    def gen_values(self, msg, mode):
        """Field values (dict, XML order) in to_dict form for one message."""
        rng = self.rng
        if mode == MODE_SPARSE and rng.random() < 0.3:
            return {f.name: (f.const_value if f.const_value is not None
                             else f.zero_value()) for f in msg.fields}
        base_zero = {MODE_MIXED: 0.05, MODE_NOEXT: 0.25, MODE_EXTREME: 0.0,
                     MODE_SPARSE: 0.7}[mode]
        values = {}
        for f in msg.fields:
            if f.extension and mode == MODE_NOEXT:
                values[f.name] = (f.const_value if f.const_value is not None
                                  else f.zero_value())
            else:
                values[f.name] = self.gen_field(f, mode, base_zero)
        return values


def mode_for_vector(msg, k, rng):
    """Mode of the k-th vector of a message: the first three cover random,
    extension-free (or sparse) and extreme values; later ones are random."""
    if k == 0:
        return MODE_MIXED
    if k == 1:
        return MODE_NOEXT if msg.has_extensions else MODE_SPARSE
    if k == 2:
        return MODE_EXTREME
    return rng.choice(ALL_MODES)


# ---------------------------------------------------------------------------
# Encoding, decoding and frame building
# ---------------------------------------------------------------------------

def to_ctor_args(msg, values):
    """Constructor arguments for the generated class (char fields as bytes)."""
    args = []
    for f in msg.fields:
        v = values[f.name]
        if f.ctype == "char":
            v = v.encode("ascii")
            if not f.array_length:
                v = v if v else b"\x00"
        elif f.array_length:
            v = list(v)
        args.append(v)
    return args


def normalize_dict(msg, d):
    """to_dict() output, with the (theoretical) length-1 array case turned
    into a list so that arrays are always lists."""
    for f in msg.fields:
        if f.array_length == 1 and f.ctype != "char" and not isinstance(d[f.name], list):
            d[f.name] = [d[f.name]]
    return d


class Codec(object):
    """Encodes/decodes with the generated pymavlink module and builds the
    C-library style v1 frame."""

    def __init__(self, dialect):
        self.dialect = dialect
        self.mod = dialect.module
        self.mav = self.mod.MAVLink(None, srcSystem=1, srcComponent=1)

    def encode_v2(self, msg, values, seq, sysid, compid):
        m = msg.cls(*to_ctor_args(msg, values))
        self.mav.seq = seq
        self.mav.srcSystem = sysid
        self.mav.srcComponent = compid
        frame = bytes(m.pack(self.mav))
        self.check_v2_frame(msg, frame, seq, sysid, compid)
        return frame

    def decode(self, frame):
        return self.mod.MAVLink(None).decode(bytearray(frame))

    def decode_dict(self, msg, frame):
        m = self.decode(frame)
        assert m.get_type() == msg.name, (m.get_type(), msg.name)
        assert m.get_msgId() == msg.id
        return normalize_dict(msg, m.to_dict())

    @staticmethod
    def full_payload(msg, frame_v2):
        """The untruncated payload (wire order, MAX_LEN bytes)."""
        payload = frame_v2[V2_HEADER_LEN:-2]
        return payload + bytes(msg.max_len - len(payload))

    def build_v1(self, msg, frame_v2, seq, sysid, compid):
        """MAVLink 1 frame as the C library sends it: base fields only."""
        if msg.id > 255:
            return None
        payload = self.full_payload(msg, frame_v2)[:msg.min_len]
        body = bytes([len(payload), seq, sysid, compid, msg.id]) + payload
        crc = frame_crc(body, msg.crc_extra)
        ref = x25crc(body)
        ref.accumulate(bytes([msg.crc_extra]))
        assert ref.crc == crc
        return bytes([MAGIC_V1]) + body + struct.pack("<H", crc)

    def check_v2_frame(self, msg, frame, seq, sysid, compid):
        plen = frame[1]
        assert frame[0] == MAGIC_V2
        assert len(frame) == V2_HEADER_LEN + plen + 2
        assert frame[2] == 0 and frame[3] == 0
        assert (frame[4], frame[5], frame[6]) == (seq, sysid, compid)
        assert frame[7] | (frame[8] << 8) | (frame[9] << 16) == msg.id
        assert 1 <= plen <= msg.max_len
        payload = frame[V2_HEADER_LEN:V2_HEADER_LEN + plen]
        # Truncation rule: no trailing zero unless it is the only byte.
        assert plen == 1 or payload[-1] != 0
        crc = struct.unpack("<H", frame[-2:])[0]
        assert crc == frame_crc(frame[1:-2], msg.crc_extra), msg.name

    def check_values(self, msg, values, decoded, v1=False):
        """The decoded dict must reproduce the generated values exactly
        (extension fields read as zero from a v1 frame)."""
        assert decoded["mavpackettype"] == msg.name
        for f in msg.fields:
            want = values[f.name]
            if v1 and f.extension:
                want = f.zero_value()
            got = decoded[f.name]
            if not _same(want, got):
                raise AssertionError("%s.%s: generated %r, decoded %r%s"
                                     % (msg.name, f.name, want, got,
                                        " (v1)" if v1 else ""))


def _same(a, b):
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(
            _same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        # Exact, including the sign of zero.
        return (isinstance(b, float) and struct.pack("<d", a) == struct.pack("<d", b))
    return type(a) is type(b) and a == b


def make_vector(codec, msg, values, seq, sysid, compid):
    """Encode one set of values; returns (v2 frame, v1 frame or None,
    decoded dict).  Everything is cross-checked on the way."""
    v2 = codec.encode_v2(msg, values, seq, sysid, compid)
    fields = codec.decode_dict(msg, v2)
    codec.check_values(msg, values, fields)
    v1 = codec.build_v1(msg, v2, seq, sysid, compid)
    if v1 is not None:
        d1 = codec.decode_dict(msg, v1)
        codec.check_values(msg, values, d1, v1=True)
    return v2, v1, fields


def default_dialect_dir():
    import pymavlink
    return os.path.join(os.path.dirname(pymavlink.__file__), "dialects", "v20")


def make_rng(seed, *parts):
    """Deterministic RNG keyed by the seed and a label (str seeds are hashed
    with SHA-512 by ``random``, independent of PYTHONHASHSEED)."""
    return random.Random(":".join([str(seed)] + [str(p) for p in parts]))
