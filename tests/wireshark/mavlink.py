#!/usr/bin/env python3
"""The MAVLink Wireshark dissector of `ferrolink wireshark`, end to end in tshark.

Usage:
    mavlink.py --ferrolink BIN --dialect-dir DIR --workdir DIR [--only NAME]...

DIR is pymavlink's dialects/v20 folder. The script runs
`BIN wireshark DIR/common.xml --out WORKDIR/mavlink.lua`, writes capture files itself (libpcap,
raw IPv4 packets carrying UDP or TCP) with frames packed by pymavlink (the reference encoder),
mixed with garbage, bad checksums, truncations and signatures, reads them with
`tshark -X lua_script:WORKDIR/mavlink.lua -T json` under an empty configuration directory, and
compares the decoded field VALUES with what pymavlink decodes from the same bytes. Every tshark
run must be free of Lua errors and malformed-packet markers. Each check prints `ok   NAME`,
`FAIL NAME: detail` or `skip NAME: why`; the last line is `N passed, M failed`; the status is 0
only if nothing failed.

  generate        `ferrolink wireshark` writes the Lua file.
  luac            The file parses with luac5.2 and luac5.4 (those installed).
  lua_versions    The dissector runs outside Wireshark on a small mock of its Lua API, under
                  Lua 5.4 (bit operators), Lua 5.2 (bit32) and Lua 5.2 without bit32 (plain
                  arithmetic): checksums verified, a 64-bit bitmask, a zero-filled payload.
  fields          tshark loads the file and registers the header, checksum, signature and
                  message fields (mavlink.sysid, mavlink.heartbeat.custom_mode, ...).
  heartbeat       HEARTBEAT: header fields, every message field, one boolean per base_mode
                  flag, enum and flag names usable in display filters.
  attitude        ATTITUDE: every float field.
  bitmask64       AUTOPILOT_VERSION: 64-bit capabilities bitmask and its flags, arrays.
  bitmask64_high  A dialect written here: a uint64 bitmask with bits 31, 32, 40 and 63, an enum
                  on an int16, int64, a double with a multiplier, an array of bitmasks.
  enum_signed     CAMERA_IMAGE_CAPTURED: enum (MAV_BOOL) on an int8, values 1 and -1.
  char_arrays     STATUSTEXT and PARAM_VALUE: strings ending in NULs, filling the array, empty,
                  with control characters, UTF-8.
  arrays          GPS_STATUS (uint8[20], scaled by 360/255) and ATTITUDE_QUATERNION_COV.
  extensions      GPS_RAW_INT with every extension field set; as MAVLink 1 without them.
  zero_fill       MAVLink 2 payloads with trailing zeros stripped are decoded zero-filled.
  signed          Signed frames: link id, timestamp, signature, the signed flag.
  v1              MAVLink 1 frames (HEARTBEAT, ATTITUDE, SYS_STATUS).
  multi_frame     Three frames and garbage in one datagram: frames in order, garbage exact.
  tcp             Frames split across TCP segments and several in one segment, reassembled.
  bad_crc         A corrupted checksum and a corrupted payload: status "bad", expert error;
                  the next frame still decodes.
  unknown_msgid   Message id 60000: raw payload, status "unverified"; a frame with an unknown
                  incompatibility flag is dropped (garbage).
  robustness      Random bytes, every truncation of a signed frame, the signed flag on a short
                  buffer, huge lengths, over UDP and TCP: no Lua error, truncations marked.
  heuristic       A frame on UDP and TCP ports no table names, taken by the heuristic
                  dissectors, which then claim the conversation (the next datagram, not starting
                  with a frame, is decoded too); TCP frames split over segments reassembled.
                  With the heuristics disabled nothing is decoded.
  decode_as       `-d udp.port==N,mavlink` and `-d tcp.port==N,mavlink` with the heuristics off.
  default_ports   UDP 14550 and 14540, TCP 5760 with the heuristics off.
  prefs_ports     `-o mavlink.udp_ports:N` and `-o mavlink.tcp_ports:N` move the ports.
  our_encoder     Frames from our own encoder (`ferrolink mavlink encode`, fed pymavlink's
                  to_dict() of HEARTBEAT, AUTOPILOT_VERSION with a 64-bit bitmask and
                  CAMERA_IMAGE_CAPTURED with -1 in its signed enum field) decode to the same
                  values pymavlink reads from them.
"""

import argparse
import json
import math
import os
import random
import shutil
import struct
import subprocess
import sys
import tempfile

sys.dont_write_bytecode = True
os.environ["MAVLINK20"] = "1"

from pymavlink.dialects.v10 import common as mavlink1  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink2  # noqa: E402

CHECKS = ("generate", "luac", "lua_versions", "fields", "heartbeat", "attitude", "bitmask64",
          "bitmask64_high", "enum_signed", "char_arrays", "arrays", "extensions", "zero_fill",
          "signed", "v1", "multi_frame", "tcp", "bad_crc", "unknown_msgid", "robustness",
          "heuristic", "decode_as", "default_ports", "prefs_ports", "our_encoder")
# Lua errors, and exceptions a dissector let escape. (A truncated frame is reported as
# malformed on purpose: `_ws.malformed` is allowed in packets with `mavlink.truncated` only.)
ERROR_MARKERS = ("Lua Error", "Lua: Error", "_ws.lua.error", "Dissector bug",
                 "Exception occurred")
NO_HEURISTICS = ("--disable-heuristic", "mavlink_udp", "--disable-heuristic", "mavlink_tcp")


class CheckFailed(Exception):
    pass


class CheckSkipped(Exception):
    pass


def expect(cond, what):
    if not cond:
        raise CheckFailed(what)


# ------------------------------------------------------------------------------------------
# Capture files

LINKTYPE_RAW = 101


def write_pcap(path, packets):
    """A libpcap file of raw IPv4 packets, one second apart."""
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, LINKTYPE_RAW))
        for i, p in enumerate(packets):
            f.write(struct.pack("<IIII", 1_700_000_000 + i, 0, len(p), len(p)))
            f.write(p)
    return path


def ipv4(proto, payload, src=(10, 0, 0, 1), dst=(10, 0, 0, 2)):
    return struct.pack(">BBHHHBBH4s4s", 0x45, 0, 20 + len(payload), 1, 0, 64, proto, 0,
                       bytes(src), bytes(dst)) + payload


def udp(payload, dport, sport=45000):
    return ipv4(17, struct.pack(">HHHH", sport, dport, 8 + len(payload), 0) + payload)


class TcpStream:
    """Segments of one TCP connection from a client to a server port, handshake first."""

    def __init__(self, dport, sport=46000):
        self.dport, self.sport = dport, sport
        self.seq, self.ack = 1000, 5000
        self.packets = [self._seg(b"", 0x02, seq=self.seq - 1, ack=0),
                        self._seg(b"", 0x12, seq=self.ack - 1, ack=self.seq, reply=True),
                        self._seg(b"", 0x10)]

    def _seg(self, payload, flags, seq=None, ack=None, reply=False):
        sport, dport = (self.dport, self.sport) if reply else (self.sport, self.dport)
        hdr = struct.pack(">HHIIBBHHH", sport, dport, self.seq if seq is None else seq,
                          self.ack if ack is None else ack, 5 << 4, flags, 65535, 0, 0)
        src, dst = ((10, 0, 0, 2), (10, 0, 0, 1)) if reply else ((10, 0, 0, 1), (10, 0, 0, 2))
        return ipv4(6, hdr + payload, src, dst)

    def send(self, payload):
        self.packets.append(self._seg(payload, 0x18))
        self.seq += len(payload)
        return self


# ------------------------------------------------------------------------------------------
# Frames (pymavlink)

def mav2(sysid=1, compid=1):
    return mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)


def pack2(msg, sysid=1, compid=1, seq=0, mav=None):
    mav = mav or mav2(sysid, compid)
    mav.seq = seq
    return bytes(msg.pack(mav))


def pack1(msg, sysid=1, compid=1, seq=0):
    mav = mavlink1.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    mav.seq = seq
    return bytes(msg.pack(mav))


def decode(frame, v1=False):
    """pymavlink's reading of a frame: the expected values."""
    mav = mavlink1.MAVLink(None) if v1 else mavlink2.MAVLink(None)
    mav.robust_parsing = False
    return mav.decode(bytearray(frame))


def x25(data, crc=0xFFFF):
    for b in data:
        tmp = b ^ (crc & 0xFF)
        tmp = (tmp ^ (tmp << 4)) & 0xFF
        crc = ((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)) & 0xFFFF
    return crc


def raw_v2(msgid, payload, crc_extra, sysid=1, compid=1, seq=0, incompat=0):
    hdr = bytes([0xFD, len(payload), incompat, 0, seq, sysid, compid]) + msgid.to_bytes(3, "little")
    crc = x25(bytes([crc_extra]), x25(hdr[1:] + payload))
    return hdr + payload + crc.to_bytes(2, "little")


def heartbeat(custom_mode=1234, base_mode=0x51, status=4):
    return mavlink2.MAVLink_heartbeat_message(type=2, autopilot=12, base_mode=base_mode,
                                              custom_mode=custom_mode, system_status=status,
                                              mavlink_version=3)


# ------------------------------------------------------------------------------------------
# tshark

class Env:
    def __init__(self, args):
        self.args = args
        self.work = os.path.abspath(args.workdir)
        os.makedirs(self.work, exist_ok=True)
        self.lua = os.path.join(self.work, "mavlink.lua")
        self.tshark = shutil.which("tshark")
        self.home = tempfile.mkdtemp(prefix="wshome-", dir=self.work)
        self.n = 0

    def need_tshark(self):
        if not self.tshark:
            raise CheckSkipped("tshark is not installed")
        if not os.path.exists(self.lua):
            raise CheckFailed("no Lua file (generate failed)")

    def env(self):
        e = dict(os.environ)
        for k in ("HOME", "XDG_CONFIG_HOME", "WIRESHARK_CONFIG_DIR"):
            e[k] = self.home
        e.pop("WIRESHARK_PLUGIN_DIR", None)
        return e

    def pcap(self, name, packets):
        self.n += 1
        return write_pcap(os.path.join(self.work, "%02d-%s.pcap" % (self.n, name)), packets)

    def run(self, pcap, *extra, lua=None):
        """tshark's JSON for every packet; fails on Lua errors and malformed packets."""
        self.need_tshark()
        cmd = [self.tshark, "-n", "-X", "lua_script:" + (lua or self.lua), "-r", pcap,
               "-T", "json", "--no-duplicate-keys", *extra]
        p = subprocess.run(cmd, capture_output=True, text=True, env=self.env(), timeout=300)
        for marker in ERROR_MARKERS:
            for stream in (p.stderr, p.stdout):
                if marker in stream:
                    at = stream.index(marker)
                    raise CheckFailed("%r in tshark output: %s" % (
                        marker, stream[max(0, at - 200):at + 300].replace("\n", " ")))
        if p.returncode != 0:
            raise CheckFailed("tshark exited %d: %s" % (p.returncode, p.stderr[-500:]))
        try:
            packets = json.loads(p.stdout)
        except ValueError as e:
            raise CheckFailed("tshark printed no JSON (%s): %s" % (e, p.stdout[:300]))
        for i, pkt in enumerate(packets):
            text = json.dumps(pkt)
            if "_ws.malformed" in text and '"mavlink.truncated"' not in text:
                raise CheckFailed("packet %d malformed: %s" % (i + 1, text[-600:]))
        return packets

    def resolved(self, pcap, field, *extra, lua=None):
        """The field's values as Wireshark shows them (value strings applied), per packet."""
        self.need_tshark()
        cmd = [self.tshark, "-n", "-X", "lua_script:" + (lua or self.lua), "-r", pcap,
               "-o", 'gui.column.format:"R","%%Cus:%s:0:R"' % field, "-T", "fields",
               "-e", "_ws.col.R", *extra]
        p = subprocess.run(cmd, capture_output=True, text=True, env=self.env(), timeout=300)
        expect(p.returncode == 0, "tshark exited %d: %s" % (p.returncode, p.stderr[-300:]))
        return p.stdout.splitlines()

    def frames(self, pcap, *extra, lua=None):
        """Every MAVLink item of the capture, in order, as {abbrev: [values]}."""
        out = []
        for pkt in self.run(pcap, *extra, lua=lua):
            out.extend(mavlink_items(pkt))
        return out

    def packet_frames(self, pcap, *extra):
        return [mavlink_items(pkt) for pkt in self.run(pcap, *extra)]


def mavlink_items(pkt):
    layer = pkt["_source"]["layers"].get("mavlink", [])
    items = layer if isinstance(layer, list) else [layer]
    return [flatten(i) for i in items]


def flatten(node, out=None):
    """Field values under node by abbreviation, in tree order (text items looked into)."""
    out = {} if out is None else out
    if isinstance(node, list):
        for n in node:
            flatten(n, out)
        return out
    for key, value in node.items():
        if isinstance(value, dict) or (isinstance(value, list) and value
                                       and isinstance(value[0], dict)):
            if key.startswith("mavlink.") and not key.endswith("_tree"):
                out.setdefault(key, []).append("")
            flatten(value, out)
        elif isinstance(value, list):
            for v in value:
                out.setdefault(key, []).append(v)
        else:
            out.setdefault(key, []).append(value)
    return out


def messages(frames):
    return [f for f in frames if "mavlink.msgid" in f]


def one(flat, key):
    values = flat.get(key)
    expect(values is not None, "no %s (fields: %s)" % (key, ", ".join(sorted(flat)[:60])))
    expect(len(values) == 1, "%s appears %d times: %r" % (key, len(values), values))
    return values[0]


def as_int(text):
    return int(text, 0)


def same_float(got, want, single):
    got = float(got)
    if single:
        want = struct.unpack("<f", struct.pack("<f", want))[0]
    if math.isnan(want):
        return math.isnan(got)
    # tshark prints floats with 6 significant digits (FLT_DIG), doubles with 15 (DBL_DIG).
    return math.isclose(got, want, rel_tol=1e-5 if single else 1e-14, abs_tol=1e-30)


def check_message(flat, msg, skip=()):
    """Every field of pymavlink's msg against the frame's values (raw wire values)."""
    prefix = "mavlink.%s." % msg.get_type().lower()
    expect(one(flat, "mavlink.msgid") == str(msg.get_msgId()),
           "msgid %s" % flat.get("mavlink.msgid"))
    for name, ctype in zip(msg.fieldnames, msg.fieldtypes):
        if name in skip:
            continue
        key = prefix + name
        want = getattr(msg, name)
        got = flat.get(key)
        expect(got is not None, "no %s" % key)
        if isinstance(want, (bytes, str)) and ctype == "char":
            want = want.decode("latin-1") if isinstance(want, bytes) else want
            expect(got == [want], "%s: %r, pymavlink %r" % (key, got, want))
            continue
        wants = list(want) if isinstance(want, (list, tuple, bytes, bytearray)) else [want]
        expect(len(got) == len(wants), "%s: %d values %r, pymavlink %d" % (
            key, len(got), got, len(wants)))
        for g, w in zip(got, wants):
            if ctype in ("float", "double"):
                ok = same_float(g, w, ctype == "float")
            else:
                ok = as_int(g) == int(w)
            expect(ok, "%s: %r, pymavlink %r" % (key, got, want))


def check_header(flat, frame, version=2):
    expect(one(flat, "mavlink.magic") == ("0xfd" if version == 2 else "0xfe"), "magic")
    expect(one(flat, "mavlink.version") == str(version), "version")
    expect(one(flat, "mavlink.len") == str(frame[1]), "len")
    off = 4 if version == 2 else 2
    for key, b in (("seq", frame[off]), ("sysid", frame[off + 1]), ("compid", frame[off + 2])):
        expect(one(flat, "mavlink." + key) == str(b),
               "%s: %s, want %d" % (key, flat.get("mavlink." + key), b))
    expect(one(flat, "mavlink.crc.status") == "good",
           "crc.status %s" % flat.get("mavlink.crc.status"))


def count_matching(env, pcap, dfilter, *extra):
    return len(env.run(pcap, "-Y", dfilter, *extra))


# ------------------------------------------------------------------------------------------
# Checks

def check_generate(env):
    if os.path.exists(env.lua):
        os.remove(env.lua)
    common = os.path.join(env.args.dialect_dir, "common.xml")
    p = subprocess.run([env.args.ferrolink, "wireshark", common, "--out", env.lua],
                       capture_output=True, text=True, timeout=300)
    expect(p.returncode == 0, "exit %d: %s" % (p.returncode, p.stderr[-800:]))
    text = open(env.lua, encoding="latin-1").read()
    expect('Proto("mavlink"' in text, "no mavlink protocol in the file")
    expect('"HEARTBEAT"' in text and '"AUTOPILOT_VERSION"' in text, "messages missing")


def check_luac(env):
    if not os.path.exists(env.lua):
        raise CheckFailed("no Lua file")
    found = False
    for luac in ("luac5.2", "luac5.4"):
        path = shutil.which(luac)
        if not path:
            continue
        found = True
        p = subprocess.run([path, "-p", env.lua], capture_output=True, text=True)
        expect(p.returncode == 0, "%s: %s" % (luac, p.stderr.strip()))
    if not found:
        raise CheckSkipped("neither luac5.2 nor luac5.4 is installed")


# A mock of the part of Wireshark's Lua API the dissector uses: enough to load the file and run
# the dissector on frames given in hex; prints `abbrev=value` for every item added.
MOCK_LUA = r'''
local frames_hex = { ... }
local function any() return setmetatable({}, { __index = function() return 0 end }) end
base, expert, ftypes = any(), { group = any(), severity = any() }, any()
ENC_UTF_8, ENC_NA = 2, 0
DESEGMENT_ONE_MORE_SEGMENT = 0x0fffffff
local protos = {}
local function new_proto(name, desc)
  local values = {}
  local p = { name = name, fields = {}, experts = {} }
  p.prefs = setmetatable({}, { __newindex = function(_, k, v) values[k] = v.value end,
                                __index = function(_, k) return values[k] end })
  function p.register_heuristic() end
  protos[name] = p
  return p
end
Proto = setmetatable({ new = new_proto }, { __call = function(_, ...) return new_proto(...) end })
local function field(kind) return function(abbr) return { abbr = abbr, kind = kind } end end
ProtoField = setmetatable({}, { __index = function(_, kind) return field(kind) end })
ProtoExpert = { new = function(abbr) return { abbr = abbr } end }
Pref = { range = function(_, default) return { value = default } end }
local nop = function() end
local dissector_table = { add = nop, remove = nop, add_for_decode_as = nop }
DissectorTable = { get = function() return dissector_table end }

local U64 = {}
U64.__index = U64
U64.__tostring = function(u) return u.text end
function U64:tonumber() return self.num end

local Tvb, Range = {}, {}
Tvb.__index, Range.__index = Tvb, Range
local function tvb_of(s) return setmetatable({ s = s }, Tvb) end
function Tvb:len() return #self.s end
function Tvb:raw(off, len) return self.s:sub(off + 1, off + len) end
Tvb.__call = function(t, off, len)
  assert(off >= 0 and len >= 0 and off + len <= #t.s, "range out of bounds")
  return setmetatable({ t = t, off = off, n = len }, Range)
end
function Range:bytes_le()
  local v = {}
  for i = 1, self.n do v[i] = self.t.s:byte(self.off + i) end
  return v
end
function Range:le_uint()
  local b, v = self:bytes_le(), 0
  for i = #b, 1, -1 do v = v * 256 + b[i] end
  return v
end
function Range:uint()
  local b, v = self:bytes_le(), 0
  for i = 1, #b do v = v * 256 + b[i] end
  return v
end
function Range:le_int()
  local v = self:le_uint()
  if v >= 2 ^ (8 * self.n - 1) then v = v - 2 ^ (8 * self.n) end
  return math.floor(v)
end
local function u64_text(b)
  -- decimal text of a little-endian unsigned integer of up to 8 bytes, digit by digit
  local digits = { 0 }
  for i = #b, 1, -1 do
    local carry = b[i]
    for d = 1, #digits do
      local x = digits[d] * 256 + carry
      digits[d] = x % 10
      carry = math.floor(x / 10)
    end
    while carry > 0 do digits[#digits + 1] = carry % 10; carry = math.floor(carry / 10) end
  end
  local out = {}
  for d = #digits, 1, -1 do out[#out + 1] = string.format("%d", digits[d]) end
  return table.concat(out)
end
function Range:le_uint64()
  return setmetatable({ num = self:le_uint(), text = u64_text(self:bytes_le()) }, U64)
end
function Range:le_int64() return self:le_uint64() end
function Range:le_float() error("no floats in the mock") end
function Range:range(off, len) return self.t(self.off + off, len) end
function Range:string() return self.t.s:sub(self.off + 1, self.off + self.n) end
function Range:bytes() return { s = self:string() } end

ByteArray = { new = function()
  local ba = { s = "" }
  function ba:append(other) self.s = self.s .. other.s end
  function ba:set_size(n) self.s = (self.s .. string.rep("\0", n)):sub(1, n) end
  function ba:tvb() return tvb_of(self.s) end
  return ba
end }

local function hex(s)
  return (s:gsub(".", function(c) return string.format("%02x", c:byte()) end))
end
local Item = {}
Item.__index = Item
local function value_of(f, r, le)
  if f.kind == "string" then return (r:string():match("^[^\0]*")) end
  if f.kind == "bytes" then return hex(r:string()) end
  if f.kind == "none" then return "" end
  if f.kind:match("64") then return tostring(r:le_uint64()) end
  if f.kind:match("^int") then return string.format("%d", r:le_int()) end
  return string.format("%d", le and r:le_uint() or r:uint())
end
local function add(self, le, f, r, value)
  if type(f) == "table" and f.abbr and r ~= nil then
    local v = value
    if v == nil then v = value_of(f, r, le) end
    if type(v) == "boolean" then v = v and "1" or "0" end
    if type(v) == "table" then v = tostring(v) end
    if type(v) == "number" then v = string.format(math.floor(v) == v and "%d" or "%g", v) end
    print(f.abbr .. "=" .. tostring(v))
  end
  return setmetatable({}, Item)
end
function Item:add(...) return add(self, false, ...) end
function Item:add_packet_field(f, r) return add(self, false, f, r) end
function Item:add_le(...) return add(self, true, ...) end
for _, m in ipairs({ "append_text", "set_text", "set_generated", "prepend_text",
                     "add_proto_expert_info" }) do
  Item[m] = function(self) return self end
end

dofile(LUA_FILE)
local proto = assert(protos.mavlink, "no protocol mavlink")
for _, h in ipairs(frames_hex) do
  local s = h:gsub("%x%x", function(x) return string.char(tonumber(x, 16)) end)
  local pinfo = { cols = {}, can_desegment = 0 }
  print("--- frame")
  proto.dissector(tvb_of(s), pinfo, setmetatable({}, Item))
end
print("--- end " .. _VERSION .. " " .. tostring(bit32 ~= nil))
'''


def check_lua_versions(env):
    if not os.path.exists(env.lua):
        raise CheckFailed("no Lua file")
    mav = mav2(7, 8)
    frames = [
        pack2(heartbeat(custom_mode=0xDEADBEEF, base_mode=0x81), 7, 8, 3),
        bytearray(pack2(heartbeat(), 7, 8, 4)),
        pack2(mavlink2.MAVLink_autopilot_version_message(
            capabilities=0x100013, flight_sw_version=1, middleware_sw_version=2,
            os_sw_version=3, board_version=4, flight_custom_version=[1] * 8,
            middleware_custom_version=[2] * 8, os_custom_version=[3] * 8, vendor_id=5,
            product_id=6, uid=0xFFFFFFFFFFFFFFFE), mav=mav),
        pack2(mavlink2.MAVLink_sys_status_message(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 0, 0, 0),
              mav=mav),
    ]
    frames[1][-1] ^= 0xFF
    frames = [bytes(f) for f in frames]
    # The part every dissector shares and the MAVLink block: the other protocols of the file
    # are not this mock's business.
    text = open(env.lua, encoding="latin-1").read()
    shared = text.find("-- Shared by every dissector")
    start, end = text.find("-- MAVLink (protocol `mavlink`)"), text.find("\nend -- MAVLink\n")
    expect(0 <= shared < start < end, "no shared part or MAVLink block in the file")
    only = os.path.join(env.work, "mavlink-only.lua")
    with open(only, "w", encoding="latin-1") as f:
        f.write(text[shared:start])
        f.write(text[start:end + len("\nend -- MAVLink\n")])
    script = os.path.join(env.work, "mock.lua")
    with open(script, "w") as f:
        f.write(MOCK_LUA)
    runs = []
    for lua in ("lua5.4", "lua5.2"):
        path = shutil.which(lua)
        if path:
            runs.append((lua, [path, "-e", "LUA_FILE=%r" % only, script]))
            if lua == "lua5.2":
                runs.append(("lua5.2 without bit32",
                             [path, "-e", "LUA_FILE=%r; bit32=nil" % only, script]))
    if not runs:
        raise CheckSkipped("neither lua5.2 nor lua5.4 is installed")
    for name, cmd in runs:
        p = subprocess.run(cmd + [fr.hex() for fr in frames], capture_output=True, text=True,
                           timeout=120)
        expect(p.returncode == 0, "%s: %s" % (name, (p.stderr or p.stdout)[-600:]))
        blocks = [b.splitlines() for b in p.stdout.split("--- frame\n")[1:]]
        expect(len(blocks) == 4, "%s: %d frames" % (name, len(blocks)))
        got = [dict(line.split("=", 1) for line in b if "=" in line) for b in blocks]
        want = [
            {"mavlink.crc.status": "good", "mavlink.heartbeat.custom_mode": str(0xDEADBEEF),
             "mavlink.heartbeat.base_mode.mav_mode_flag_safety_armed": "1",
             "mavlink.heartbeat.base_mode.mav_mode_flag_test_enabled": "0",
             "mavlink.sysid": "7", "mavlink.compid": "8", "mavlink.seq": "3"},
            {"mavlink.crc.status": "bad"},
            {"mavlink.crc.status": "good",
             "mavlink.autopilot_version.capabilities": str(0x100013),
             "mavlink.autopilot_version.capabilities.mav_protocol_capability_gripper": "1",
             "mavlink.autopilot_version.capabilities.mav_protocol_capability_ftp": "0",
             "mavlink.autopilot_version.uid": str(0xFFFFFFFFFFFFFFFE)},
            {"mavlink.crc.status": "good", "mavlink.len": str(frames[3][1]),
             "mavlink.sys_status.battery_remaining": "7",
             "mavlink.sys_status.onboard_control_sensors_present_extended": "0"},
        ]
        for i, (g, w) in enumerate(zip(got, want)):
            for k, v in w.items():
                expect(g.get(k) == v, "%s, frame %d: %s=%r, want %r" % (name, i, k, g.get(k), v))


def check_fields(env):
    env.need_tshark()
    p = subprocess.run([env.tshark, "-G", "fields", "-X", "lua_script:" + env.lua],
                       capture_output=True, text=True, env=env.env(), timeout=300)
    for marker in ERROR_MARKERS:  # (stdout lists Wireshark's own "Lua Error" field)
        expect(marker not in p.stderr, "%s while loading: %s" % (marker, p.stderr[-500:]))
    abbrevs = {line.split("\t")[2] for line in p.stdout.splitlines()
               if line.startswith("F\t") and "\tmavlink" in line}
    for name in ("mavlink.sysid", "mavlink.compid", "mavlink.seq", "mavlink.msgid",
                 "mavlink.magic", "mavlink.len", "mavlink.incompat_flags", "mavlink.crc",
                 "mavlink.crc.status", "mavlink.signature.link_id", "mavlink.signature.timestamp",
                 "mavlink.signature.signature", "mavlink.payload", "mavlink.garbage",
                 "mavlink.heartbeat.custom_mode", "mavlink.attitude.roll",
                 "mavlink.autopilot_version.capabilities.mav_protocol_capability_ftp",
                 "mavlink.gps_raw_int.eph.scaled", "mavlink.statustext.text"):
        expect(name in abbrevs, "%s not registered" % name)


def check_heartbeat(env):
    frame = pack2(heartbeat(custom_mode=0x12345678, base_mode=0x91), 42, 200, 7)
    pcap = env.pcap("heartbeat", [udp(frame, 14550)])
    frames = env.frames(pcap)
    expect(len(frames) == 1, "%d MAVLink items" % len(frames))
    flat = frames[0]
    check_header(flat, frame)
    expect(one(flat, "mavlink.message") == "HEARTBEAT", "message name")
    expect(one(flat, "mavlink.incompat_flags.signed") == "0", "signed flag")
    check_message(flat, decode(frame))
    for bit, name in ((0x01, "custom_mode_enabled"), (0x02, "test_enabled"),
                      (0x10, "stabilize_enabled"), (0x80, "safety_armed"),
                      (0x40, "manual_input_enabled")):
        key = "mavlink.heartbeat.base_mode.mav_mode_flag_" + name
        expect(one(flat, key) == ("1" if 0x91 & bit else "0"), "%s: %s" % (key, flat.get(key)))
    for dfilter, want in (('mavlink.heartbeat.type == "MAV_TYPE_QUADROTOR"', 1),
                          ('mavlink.heartbeat.type == "MAV_TYPE_FIXED_WING"', 0),
                          ('mavlink.heartbeat.autopilot == "MAV_AUTOPILOT_PX4"', 1),
                          ('mavlink.heartbeat.system_status == "MAV_STATE_ACTIVE"', 1),
                          ('mavlink.msgid == "HEARTBEAT"', 1),
                          ("mavlink.heartbeat.base_mode.mav_mode_flag_safety_armed", 1),
                          ("mavlink.heartbeat.base_mode.mav_mode_flag_safety_armed == 1", 1),
                          ("mavlink.heartbeat.base_mode.mav_mode_flag_auto_enabled == 1", 0),
                          ("mavlink.heartbeat && mavlink.sysid == 42 && mavlink.compid == 200", 1)):
        n = count_matching(env, pcap, dfilter)
        expect(n == want, "filter %s matched %d packets, want %d" % (dfilter, n, want))
    for field, want in (("mavlink.heartbeat.type", "MAV_TYPE_QUADROTOR"),
                        ("mavlink.heartbeat.autopilot", "MAV_AUTOPILOT_PX4"),
                        ("mavlink.msgid", "HEARTBEAT")):
        shown = env.resolved(pcap, field)
        expect(shown == [want], "%s shown as %r, want %r" % (field, shown, want))


def check_attitude(env):
    msg = mavlink2.MAVLink_attitude_message(time_boot_ms=123456, roll=0.1, pitch=-1.25e-3,
                                            yaw=3.14159, rollspeed=-0.0, pitchspeed=1e30,
                                            yawspeed=float("nan"))
    frame = pack2(msg, 3, 4, 250)
    flat = env.frames(env.pcap("attitude", [udp(frame, 14550)]))[0]
    check_header(flat, frame)
    check_message(flat, decode(frame))


def autopilot_version(capabilities, uid=0x1234567890ABCDEF, uid2=None):
    return mavlink2.MAVLink_autopilot_version_message(
        capabilities=capabilities, flight_sw_version=0x01020304, middleware_sw_version=2,
        os_sw_version=3, board_version=4, flight_custom_version=list(b"abcdefgh"),
        middleware_custom_version=[1, 2, 3, 4, 5, 6, 7, 8], os_custom_version=[255] * 8,
        vendor_id=0x26AC, product_id=0x11, uid=uid, uid2=uid2 or list(range(1, 19)))


def check_bitmask64(env):
    caps = 0x100000 | 0x2000 | 0x13
    frame = pack2(autopilot_version(caps, uid=0xFFFFFFFFFFFFFFFF), 1, 1, 9)
    flat = env.frames(env.pcap("bitmask64", [udp(frame, 14550)]))[0]
    check_header(flat, frame)
    check_message(flat, decode(frame))
    flags = {k.rsplit(".", 1)[1]: one(flat, k) for k in flat
             if k.startswith("mavlink.autopilot_version.capabilities.")}
    for value, entry in mavlink2.enums["MAV_PROTOCOL_CAPABILITY"].items():
        if not entry.name.endswith("_ENUM_END"):
            got = flags.get(entry.name.lower())
            want = "1" if caps & value == value else "0"
            expect(got == want, "flag %s: %s, want %s" % (entry.name, got, want))


TEST_XML = """<?xml version="1.0"?>
<mavlink>
  <version>3</version>
  <dialect>0</dialect>
  <enums>
    <enum name="FL_WIDE_FLAGS" bitmask="true">
      <description>Flags in every 32-bit half.</description>
      <entry value="1" name="FL_WIDE_FLAGS_BIT0"><description>Bit 0.</description></entry>
      <entry value="2147483648" name="FL_WIDE_FLAGS_BIT31">
        <description>Bit 31.</description></entry>
      <entry value="4294967296" name="FL_WIDE_FLAGS_BIT32">
        <description>Bit 32.</description></entry>
      <entry value="1099511627776" name="FL_WIDE_FLAGS_BIT40">
        <description>Bit 40.</description></entry>
      <entry value="9223372036854775808" name="FL_WIDE_FLAGS_BIT63">
        <description>Bit 63.</description></entry>
    </enum>
    <enum name="FL_WIDE_MODE">
      <description>Modes.</description>
      <entry value="0" name="FL_WIDE_MODE_OFF"><description>Off.</description></entry>
      <entry value="2" name="FL_WIDE_MODE_ON"><description>On.</description></entry>
    </enum>
  </enums>
  <messages>
    <message id="42000" name="FL_WIDE">
      <description>Wide values.</description>
      <field type="uint64_t" name="flags" enum="FL_WIDE_FLAGS" display="bitmask">Flags.</field>
      <field type="int16_t" name="mode" enum="FL_WIDE_MODE">Mode.</field>
      <field type="int64_t" name="big">Big.</field>
      <field type="double" name="ratio" units="m" multiplier="1E-3">Scaled.</field>
      <field type="uint32_t[3]" name="words" enum="FL_WIDE_FLAGS" display="bitmask">Words.</field>
      <extensions/>
      <field type="uint16_t" name="tail">Tail.</field>
    </message>
  </messages>
</mavlink>
"""


def check_bitmask64_high(env):
    env.need_tshark()
    xml = os.path.join(env.work, "fl_wide.xml")
    with open(xml, "w") as f:
        f.write(TEST_XML)
    lua = os.path.join(env.work, "fl_wide.lua")
    p = subprocess.run([env.args.ferrolink, "wireshark", xml, "--out", lua],
                       capture_output=True, text=True, timeout=300)
    expect(p.returncode == 0, "ferrolink wireshark: %s" % p.stderr[-500:])
    from pymavlink.generator import mavgen, mavparse
    out = os.path.join(env.work, "fl_wide_py", "fl_wide.py")
    os.makedirs(os.path.dirname(out), exist_ok=True)
    import contextlib
    import io
    with contextlib.redirect_stdout(io.StringIO()):
        mavgen.mavgen(mavgen.Opts(out, wire_protocol=mavparse.PROTOCOL_2_0, language="Python3",
                                  validate=False), [xml])
    sys.path.insert(0, os.path.dirname(out))
    import importlib
    mod = importlib.import_module("fl_wide")
    mav = mod.MAVLink(None, srcSystem=5, srcComponent=6)
    cases = [(1 | 2 ** 31 | 2 ** 32 | 2 ** 63, 2, -2 ** 63 + 1, 1234.5, [2 ** 31, 1, 0], 7),
             (2 ** 40, -1, 2 ** 63 - 1, -0.001, [0xFFFFFFFF, 0, 2 ** 31], 0)]
    frames = [bytes(mod.MAVLink_fl_wide_message(*c).pack(mav)) for c in cases]
    pcap = env.pcap("fl_wide", [udp(fr, 14550) for fr in frames])
    got = env.frames(pcap, lua=lua)
    expect(len(got) == 2, "%d MAVLink items" % len(got))
    for flat, frame, case in zip(got, frames, cases):
        dec = mod.MAVLink(None).decode(bytearray(frame))
        check_message(flat, dec)
        flags = case[0]
        for bit in (0, 31, 32, 40, 63):
            key = "mavlink.fl_wide.flags.fl_wide_flags_bit%d" % bit
            expect(one(flat, key) == ("1" if flags >> bit & 1 else "0"),
                   "%s: %s (flags 0x%x)" % (key, flat.get(key), flags))
        words = flat.get("mavlink.fl_wide.words.fl_wide_flags_bit31")
        expect(words == ["1" if w >> 31 & 1 else "0" for w in case[4]], "words bit31 %r" % words)
        expect("mavlink.fl_wide.words.fl_wide_flags_bit32" not in flat,
               "a 32-bit field shows a flag of bit 32")
        scaled = float(one(flat, "mavlink.fl_wide.ratio.scaled"))
        expect(math.isclose(scaled, case[3] * 1e-3), "ratio.scaled %r" % scaled)
    for dfilter, want in (('mavlink.fl_wide.mode == "FL_WIDE_MODE_ON"', 1),
                          ("mavlink.fl_wide.mode == -1", 1),
                          ("mavlink.fl_wide.flags.fl_wide_flags_bit63 == 1", 1),
                          ("mavlink.fl_wide.flags.fl_wide_flags_bit40 == 1", 1),
                          ("mavlink.fl_wide.big == -9223372036854775807", 1)):
        n = len(env.run(pcap, "-Y", dfilter, lua=lua))
        expect(n == want, "filter %s matched %d, want %d" % (dfilter, n, want))
    modes = env.resolved(pcap, "mavlink.fl_wide.mode", lua=lua)
    expect(modes == ["FL_WIDE_MODE_ON", "-1"], "mode shown as %r" % modes)


def camera_image_captured(result):
    return mavlink2.MAVLink_camera_image_captured_message(
        time_boot_ms=1, time_utc=1_700_000_000_000_000, camera_id=1, lat=473977418,
        lon=85455939, alt=500000, relative_alt=12000, q=[1.0, 0.0, 0.5, -0.5],
        image_index=-3, capture_result=result, file_url=b"http://10.0.0.2/img/0001.jpg")


def check_enum_signed(env):
    # MAV_BOOL is a bitmask enum in common.xml: a flag per entry on a signed field.
    values = (1, -1, 0)
    frames = [pack2(camera_image_captured(v), seq=i) for i, v in enumerate(values)]
    pcap = env.pcap("enum_signed", [udp(fr, 14550) for fr in frames])
    got = env.frames(pcap)
    expect(len(got) == 3, "%d MAVLink items" % len(got))
    for flat, frame, v in zip(got, frames, values):
        check_header(flat, frame)
        check_message(flat, decode(frame))
        key = "mavlink.camera_image_captured.capture_result.mav_bool_true"
        expect(one(flat, key) == str(v & 1), "%s: %s for %d" % (key, flat.get(key), v))
    for dfilter, want in (("mavlink.camera_image_captured.capture_result.mav_bool_true == 1", 2),
                          ("mavlink.camera_image_captured.capture_result == -1", 1),
                          ("mavlink.camera_image_captured.image_index == -3", 3)):
        n = count_matching(env, pcap, dfilter)
        expect(n == want, "filter %s matched %d, want %d" % (dfilter, n, want))


def check_char_arrays(env):
    msgs = [mavlink2.MAVLink_statustext_message(severity=4, text=b"ferrolink: hello", id=9,
                                                chunk_seq=1),
            mavlink2.MAVLink_statustext_message(severity=6, text=b"x" * 50),
            mavlink2.MAVLink_param_value_message(param_id=b"SYSID_THISMAVLNK", param_value=1.5,
                                                 param_type=9, param_count=700, param_index=3),
            mavlink2.MAVLink_param_value_message(param_id=b"", param_value=-2.0, param_type=2,
                                                 param_count=0, param_index=65535),
            mavlink2.MAVLink_statustext_message(severity=2, text=b"tab\there\x01"),
            # STATUSTEXT is UTF-8 (pymavlink reads it as ASCII: compared by hand below)
            mavlink2.MAVLink_statustext_message(severity=2, text="Höhe ✓ 30 m".encode())]
    frames = [pack2(m, seq=i) for i, m in enumerate(msgs)]
    got = env.frames(env.pcap("char_arrays", [udp(fr, 14550) for fr in frames]))
    expect(len(got) == len(frames), "%d MAVLink items" % len(got))
    for flat, frame in zip(got, frames):
        check_header(flat, frame)
        check_message(flat, decode(frame), skip=("text",) if flat is got[-1] else ())
    expect(one(got[0], "mavlink.statustext.text") == "ferrolink: hello", "text")
    expect(one(got[2], "mavlink.param_value.param_id") == "SYSID_THISMAVLNK", "param_id")
    text = one(got[-1], "mavlink.statustext.text")
    expect(text == "Höhe ✓ 30 m", "UTF-8 text %r" % text)


def check_arrays(env):
    gps = mavlink2.MAVLink_gps_status_message(
        satellites_visible=5, satellite_prn=list(range(1, 21)), satellite_used=[1, 0] * 10,
        satellite_elevation=list(range(70, 90)), satellite_azimuth=list(range(0, 200, 10)),
        satellite_snr=[40] * 19 + [255])
    cov = mavlink2.MAVLink_attitude_quaternion_cov_message(
        time_usec=99, q=[0.5, 0.5, -0.5, 0.5], rollspeed=0.01, pitchspeed=0.02, yawspeed=0.03,
        covariance=[float(i) / 7 for i in range(9)])
    frames = [pack2(gps), pack2(cov)]
    got = env.frames(env.pcap("arrays", [udp(fr, 14550) for fr in frames]))
    for flat, frame in zip(got, frames):
        check_header(flat, frame)
        check_message(flat, decode(frame))
    scaled = [float(v) for v in got[0].get("mavlink.gps_status.satellite_azimuth.scaled", [])]
    want = [a * 360 / 255 for a in range(0, 200, 10)]
    expect(len(scaled) == 20 and all(math.isclose(a, b) for a, b in zip(scaled, want)),
           "satellite_azimuth.scaled %r" % scaled)
    n = count_matching(env, env.pcap("arrays2", [udp(frames[0], 14550)]),
                       "mavlink.gps_status.satellite_prn == 17")
    expect(n == 1, "filter on an array element matched %d" % n)


def gps_raw_int(ext=True):
    return mavlink2.MAVLink_gps_raw_int_message(
        time_usec=1_700_000_000_123_456, fix_type=3, lat=473977418, lon=85455939, alt=488000,
        eph=121, epv=65535, vel=250, cog=35999, satellites_visible=11,
        alt_ellipsoid=530000 if ext else 0, h_acc=1500 if ext else 0, v_acc=2500 if ext else 0,
        vel_acc=300 if ext else 0, hdg_acc=100000 if ext else 0, yaw=36000 if ext else 0)


def check_extensions(env):
    v2 = pack2(gps_raw_int(), 1, 1, 1)
    v1 = pack1(mavlink1.MAVLink_gps_raw_int_message(1_700_000_000_123_456, 3, 473977418,
                                                    85455939, 488000, 121, 65535, 250, 35999,
                                                    11), 1, 1, 2)
    expect(v1[0] == 0xFE, "pymavlink made no MAVLink 1 frame")
    got = env.frames(env.pcap("extensions", [udp(v2, 14550), udp(v1, 14550)]))
    expect(len(got) == 2, "%d MAVLink items" % len(got))
    check_header(got[0], v2)
    check_message(got[0], decode(v2))
    check_header(got[1], v1, version=1)
    check_message(got[1], decode(v1, v1=True))
    for name in ("alt_ellipsoid", "h_acc", "v_acc", "vel_acc", "hdg_acc", "yaw"):
        expect(("mavlink.gps_raw_int." + name) in got[0], "MAVLink 2 frame lacks " + name)
        expect(("mavlink.gps_raw_int." + name) not in got[1], "MAVLink 1 frame shows " + name)
    eph = float(one(got[0], "mavlink.gps_raw_int.eph.scaled"))
    expect(math.isclose(eph, 1.21), "eph.scaled %r" % eph)


def check_zero_fill(env):
    frames = [pack2(gps_raw_int(ext=False), seq=1),
              pack2(mavlink2.MAVLink_sys_status_message(0x0F, 0x0F, 0x0D, 500, 12000, -1, 87,
                                                        0, 0, 0, 0, 0, 0, 0, 0), seq=2),
              pack2(mavlink2.MAVLink_heartbeat_message(0, 0, 0, 0, 0, 0), seq=3),
              pack2(autopilot_version(0x13, uid2=[0] * 18), seq=4)]
    for fr, full in zip(frames, (52, 43, 9, 78)):
        expect(fr[1] < full, "pymavlink did not truncate (len %d of %d)" % (fr[1], full))
    got = env.frames(env.pcap("zero_fill", [udp(fr, 14550) for fr in frames]))
    expect(len(got) == len(frames), "%d MAVLink items" % len(got))
    for flat, frame in zip(got, frames):
        check_header(flat, frame)
        check_message(flat, decode(frame))


def signed_frames():
    mav = mav2(11, 12)
    mav.signing.secret_key = bytes(range(32))
    mav.signing.link_id = 5
    mav.signing.timestamp = (1_700_000_000 - 1_420_070_400) * 100_000  # 10 us since 2015
    mav.signing.sign_outgoing = True
    one_ = bytes(heartbeat().pack(mav))
    two = bytes(mavlink2.MAVLink_attitude_message(5, 0.5, 0.25, -0.125, 0, 0, 0).pack(mav))
    return one_, two


def check_signed(env):
    frames = signed_frames()
    got = env.frames(env.pcap("signed", [udp(frames[0] + frames[1], 14550)]))
    expect(len(got) == 2, "%d MAVLink items" % len(got))
    for flat, frame in zip(got, frames):
        expect(frame[2] & 1 == 1, "pymavlink did not sign")
        check_header(flat, frame)
        check_message(flat, decode(frame))
        expect(one(flat, "mavlink.incompat_flags.signed") == "1", "signed flag")
        expect(one(flat, "mavlink.signature.link_id") == "5", "link_id")
        ts = int.from_bytes(frame[-12:-6], "little")
        expect(one(flat, "mavlink.signature.timestamp") == str(ts), "timestamp %s, want %d" % (
            flat.get("mavlink.signature.timestamp"), ts))
        sig = one(flat, "mavlink.signature.signature").replace(":", "")
        expect(sig == frame[-6:].hex(), "signature %s, want %s" % (sig, frame[-6:].hex()))


def check_v1(env):
    msgs = [mavlink1.MAVLink_heartbeat_message(6, 8, 0xC0, 77, 3, 3),
            mavlink1.MAVLink_attitude_message(10, 1.0, 2.0, 3.0, -1.0, -2.0, -3.0),
            mavlink1.MAVLink_sys_status_message(1, 2, 3, 4, 5, -1, 7, 8, 9, 10, 11, 12, 13)]
    frames = [pack1(m, 200, 100, i) for i, m in enumerate(msgs)]
    got = env.frames(env.pcap("v1", [udp(b"".join(frames), 14550)]))
    expect(len(got) == 3, "%d MAVLink items" % len(got))
    for flat, frame in zip(got, frames):
        check_header(flat, frame, version=1)
        check_message(flat, decode(frame, v1=True))
        expect("mavlink.incompat_flags" not in flat, "incompat_flags in a MAVLink 1 frame")


def check_multi_frame(env):
    a = pack2(heartbeat(), 1, 1, 1)
    b = pack2(mavlink2.MAVLink_attitude_message(5, 0.5, 0.25, -0.125, 0, 0, 0), 1, 1, 2)
    c = pack1(mavlink1.MAVLink_heartbeat_message(6, 8, 0, 0, 3, 3), 2, 2, 3)
    junk1, junk2 = b"\x00\x01\xfdjunk", b"\xfe\x03zz"
    got = env.packet_frames(env.pcap("multi", [udp(junk1 + a + b + junk2 + c + b"!", 14550)]))
    expect(len(got) == 1, "%d packets" % len(got))
    items = got[0]
    kinds = ["garbage" if "mavlink.garbage" in i else one(i, "mavlink.msgid") for i in items]
    expect(kinds == ["garbage", "0", "30", "garbage", "0", "garbage"], "items %r" % kinds)
    garbage = [one(i, "mavlink.garbage").replace(":", "") for i in items if "mavlink.garbage" in i]
    expect(garbage == [junk1.hex(), junk2.hex(), b"!".hex()], "garbage %r" % garbage)
    frames = [i for i in items if "mavlink.msgid" in i]
    for flat, frame, v in zip(frames, (a, b, c), (2, 2, 1)):
        check_header(flat, frame, version=v)
        check_message(flat, decode(frame, v1=(v == 1)))


def tcp_stream_frames():
    frames = [pack2(heartbeat(custom_mode=i), 1, 1, i) for i in range(3)]
    frames += [pack2(gps_raw_int(), 1, 1, 3), signed_frames()[1],
               pack1(mavlink1.MAVLink_heartbeat_message(6, 8, 0, 0, 3, 3), 2, 2, 5),
               pack2(autopilot_version(0x13), 1, 1, 6)]
    data = b"".join(frames)
    cuts = [0, 5, 12, 21 + 10, 21 * 3 + 3, len(data) - 40, len(data) - 39, len(data)]
    return frames, [data[a:b] for a, b in zip(cuts, cuts[1:])]


def check_tcp(env):
    frames, segments = tcp_stream_frames()
    stream = TcpStream(5760)
    for s in segments:
        stream.send(s)
    got = messages(env.frames(env.pcap("tcp", stream.packets)))
    expect(len(got) == len(frames), "%d frames decoded, want %d" % (len(got), len(frames)))
    for flat, frame in zip(got, frames):
        check_header(flat, frame, version=2 if frame[0] == 0xFD else 1)
        check_message(flat, decode(frame, v1=frame[0] == 0xFE))


def check_bad_crc(env):
    good = pack2(heartbeat(), 1, 1, 1)
    bad_crc = bytearray(pack2(heartbeat(custom_mode=99), 1, 1, 2))
    bad_crc[-1] ^= 0x5A
    bad_payload = bytearray(pack2(mavlink2.MAVLink_attitude_message(5, 0.5, 0.25, 0, 0, 0, 0),
                                  1, 1, 3))
    bad_payload[12] ^= 0x01
    bad_v1 = bytearray(pack1(mavlink1.MAVLink_heartbeat_message(6, 8, 0, 0, 3, 3), 2, 2, 4))
    bad_v1[-2] ^= 0xFF
    raw = env.run(env.pcap("bad_crc", [udp(bytes(bad_crc) + good, 14550),
                                       udp(bytes(bad_payload), 14550),
                                       udp(bytes(bad_v1) + good, 14550)]))
    pkts = [mavlink_items(p) for p in raw]
    statuses = [[one(i, "mavlink.crc.status") for i in p] for p in pkts]
    expect(statuses == [["bad", "good"], ["bad"], ["bad", "good"]], "statuses %r" % statuses)
    expect(one(pkts[0][0], "mavlink.heartbeat.custom_mode") == "99", "bad frame not decoded")
    experts = [json.dumps(p).count('"mavlink.expert.bad_crc"') for p in raw]
    expect(experts == [1, 1, 1], "bad checksum expert infos per packet: %r" % experts)
    crc = int.from_bytes(bad_crc[-2:], "little")
    expect(one(pkts[0][0], "mavlink.crc") == "0x%04x" % crc, "crc field")
    calc = int(one(pkts[0][0], "mavlink.crc.calculated"), 16)
    expect(calc == crc ^ 0x5A00, "calculated 0x%04x, received 0x%04x" % (calc, crc))


def check_unknown_msgid(env):
    payload = bytes(range(1, 12))
    frame = raw_v2(60000, payload, 0, 9, 9, 1)
    good = pack2(heartbeat(), 1, 1, 2)
    got = env.frames(env.pcap("unknown", [udp(frame + good, 14550)]))
    expect(len(got) == 2, "%d MAVLink items" % len(got))
    flat = got[0]
    expect(one(flat, "mavlink.msgid") == "60000", "msgid %s" % flat.get("mavlink.msgid"))
    expect(one(flat, "mavlink.payload").replace(":", "") == payload.hex(), "payload %s" % (
        flat.get("mavlink.payload")))
    expect(one(flat, "mavlink.crc.status") == "unverified", "status %s" % (
        flat.get("mavlink.crc.status")))
    expect(one(flat, "mavlink.sysid") == "9", "sysid")
    expect(one(got[1], "mavlink.crc.status") == "good", "next frame")
    # Unknown incompatibility flags: receivers drop the frame, here it is garbage.
    flagged = raw_v2(0, pack2(heartbeat())[10:-2], 50, incompat=0x02)
    items = env.packet_frames(env.pcap("incompat", [udp(flagged + good, 14550)]))[0]
    kinds = ["garbage" if "mavlink.garbage" in i else one(i, "mavlink.msgid") for i in items]
    expect(kinds == ["garbage", "0"], "incompat_flags 0x02: %r" % kinds)


def check_robustness(env):
    rng = random.Random(20240601)
    signed = signed_frames()[0]
    big = pack2(autopilot_version(0x13), 1, 1, 1)
    dgrams = []
    for _ in range(150):
        n = rng.randrange(1, 300)
        b = bytearray(rng.getrandbits(8) for _ in range(n))
        for _ in range(rng.randrange(0, 6)):
            b[rng.randrange(n)] = rng.choice((0xFD, 0xFE))
        dgrams.append(bytes(b))
    dgrams += [signed[:i] for i in range(1, len(signed))]
    dgrams += [big[:i] for i in range(1, len(big), 7)]
    dgrams += [bytes([0xFD, 0xFF, 0x01]), bytes([0xFD, 0x09, 0x01, 0, 0, 1, 1, 0, 0, 0]),
               bytes([0xFE]), bytes([0xFD]), bytes([0xFD, 0x00]),
               bytes([0xFD, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0]),
               bytes([0xFE, 0, 0, 1, 1, 0, 0, 0]),
               bytes([0xFD, 0, 0xFF, 0, 0, 1, 1, 0x60, 0xEA, 0, 0, 0]) + bytes(13),
               signed[:-5] + signed, b"\xfd" * 300, b"\xfe" * 300,
               bytes([0xFD, 1, 1]) + bytes(20)]
    pkts = [udp(d, 14550) for d in dgrams]
    stream = TcpStream(5760)
    for d in dgrams[:60]:
        stream.send(d)
    got = env.packet_frames(env.pcap("robust", pkts + stream.packets))
    expect(len(got) == len(pkts) + len(stream.packets), "%d packets" % len(got))
    for i in range(1, len(signed)):
        items = got[150 + i - 1]
        expect(items and "mavlink.truncated" in items[-1], "signed frame cut at %d: %r" % (
            i, [sorted(x) for x in items]))


def check_heuristic(env):
    hb = pack2(heartbeat(), 1, 1, 1)
    frames = tcp_stream_frames()[0]
    stream = TcpStream(40001)
    stream.send(hb)
    data = b"".join(frames)
    stream.send(data[:30]).send(data[30:90]).send(data[90:])
    stream.send(b"\x00" + hb)  # not a frame start: decoded only as part of the conversation
    # The heuristic claims the conversation: the second datagram comes from another port.
    pcap = env.pcap("heuristic", [udp(hb, 40000), udp(b"\x00" + hb, 40000, sport=45001),
                                  udp(b"\x00" + hb, 40000)] + stream.packets)
    pkts = env.packet_frames(pcap)
    expect(len(pkts[0]) == 1 and one(pkts[0][0], "mavlink.msgid") == "0", "UDP 40000: %r" % pkts[0])
    expect(pkts[1] == [], "the heuristic took a datagram not starting with a frame")
    expect(len(messages(pkts[2])) == 1, "UDP conversation not claimed: %r" % pkts[2])
    tcp = messages([f for p in pkts[3:] for f in p])
    want = [hb] + frames + [hb]
    expect(len(tcp) == len(want), "TCP 40001: %d frames, want %d" % (len(tcp), len(want)))
    for flat, frame in zip(tcp, want):
        check_header(flat, frame, version=2 if frame[0] == 0xFD else 1)
    n = len(env.run(pcap, "-Y", "mavlink", *NO_HEURISTICS))
    expect(n == 0, "%d packets decoded with the heuristics disabled" % n)


def check_decode_as(env):
    hb = pack2(heartbeat(), 1, 1, 1)
    stream = TcpStream(40004)
    stream.send(b"xx" + hb[:10]).send(hb[10:] + hb)
    pcap = env.pcap("decode_as", [udp(b"junk" + hb, 40002)] + stream.packets)
    expect(len(env.run(pcap, "-Y", "mavlink.heartbeat", *NO_HEURISTICS)) == 0,
           "decoded without Decode As")
    got = messages(env.frames(pcap, "-d", "udp.port==40002,mavlink",
                              "-d", "tcp.port==40004,mavlink", *NO_HEURISTICS))
    expect(len(got) == 3, "%d frames with Decode As, want 3" % len(got))
    for flat in got:
        check_header(flat, hb)


def check_default_ports(env):
    hb = pack2(heartbeat(), 1, 1, 1)
    stream = TcpStream(5760)
    stream.send(b"?" + hb[:5]).send(hb[5:])
    pcap = env.pcap("default_ports", [udp(b"?" + hb, 14550), udp(b"?" + hb, 14540),
                                      udp(b"?" + hb, 14541)] + stream.packets)
    pkts = env.packet_frames(pcap, *NO_HEURISTICS)
    decoded = [bool(messages(p)) for p in pkts]
    expect(decoded[:3] == [True, True, False], "UDP 14550, 14540, 14541: %r" % decoded[:3])
    expect(sum(decoded[3:]) == 1, "TCP 5760: %r" % decoded[3:])


def check_prefs_ports(env):
    hb = pack2(heartbeat(), 1, 1, 1)
    stream = TcpStream(40005)
    stream.send(b"?" + hb)
    old = TcpStream(5760, sport=46001)
    old.send(b"?" + hb)
    pcap = env.pcap("prefs_ports", [udp(b"?" + hb, 40003), udp(b"?" + hb, 14550)]
                    + stream.packets + old.packets)
    prefs = ("-o", "mavlink.udp_ports:40003", "-o", "mavlink.tcp_ports:40005")
    pkts = env.packet_frames(pcap, *prefs, *NO_HEURISTICS)
    decoded = [bool(messages(p)) for p in pkts]
    expect(decoded[:2] == [True, False], "UDP 40003, 14550: %r" % decoded[:2])
    expect(sum(decoded[2:6]) == 1 and sum(decoded[6:]) == 0, "TCP 40005, 5760: %r" % decoded[2:])


def check_our_encoder(env):
    msgs = [heartbeat(custom_mode=0xDEADBEEF, base_mode=0x81),
            autopilot_version(capabilities=(1 << 63) | (1 << 40) | 0x1FFFF),
            camera_image_captured(-1)]
    lines = "".join(json.dumps(decode(pack2(m)).to_dict()) + "\n" for m in msgs)
    p = subprocess.run([env.args.ferrolink, "mavlink", "encode", "--dialect",
                        os.path.join(env.args.dialect_dir, "common.xml")],
                       input=lines, capture_output=True, text=True)
    expect(p.returncode == 0, "ferrolink mavlink encode: %s" % p.stderr.strip())
    frames = [bytes.fromhex(h) for h in p.stdout.split()]
    expect(len(frames) == len(msgs), "%d frames encoded" % len(frames))
    got = env.frames(env.pcap("our_encoder", [udp(fr, 14550) for fr in frames]))
    expect(len(got) == len(frames), "%d MAVLink items" % len(got))
    for flat, frame, msg in zip(got, frames, msgs):
        check_header(flat, frame)
        expect(one(flat, "mavlink.crc.status") == "good", "checksum of our %s" % msg.get_type())
        ours = decode(frame)
        expect(ours.to_dict() == decode(pack2(msg)).to_dict(),
               "pymavlink reads our %s differently" % msg.get_type())
        check_message(flat, ours)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ferrolink", required=True)
    ap.add_argument("--dialect-dir", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--only", action="append", default=[])
    args = ap.parse_args()
    env = Env(args)
    passed = failed = 0
    for name in CHECKS:
        if args.only and name not in args.only and name != "generate":
            continue
        try:
            globals()["check_" + name](env)
            print("ok   %s" % name, flush=True)
            passed += 1
        except CheckSkipped as e:
            print("skip %s: %s" % (name, e), flush=True)
        except Exception as e:  # noqa: BLE001 - every failure is reported, the run goes on
            print("FAIL %s: %s" % (name, e), flush=True)
            failed += 1
    print("%d passed, %d failed" % (passed, failed), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
