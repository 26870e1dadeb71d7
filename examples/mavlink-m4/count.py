#!/usr/bin/env python3
"""Counts the instructions that MAVLink 2 pack and parse+decode take on a Cortex-M4, ours
(src/main.rs) against the MAVLink C library (c/bench_c.c), by running each function of the
firmware ELF files in the unicorn emulator.

    count.py --ours 's=RUST.elf' [--ours ...] --c 'O2=C.elf' [--c ...]

Each function is called directly: the sections of the ELF file are loaded at their run
addresses (so .data is as after start-up), the arguments go into r0..r3 (buffers in RAM), the
stack pointer is set to the top of RAM and LR to a stop address; every instruction executed
until the function returns to it is counted. Each function is called twice and the second call
is reported (the parsers keep state between calls; the counts of both calls are checked to be
equal for the packers).

Checks: the Rust and C packers produce byte-identical frames for the same fields and sequence
numbers; every parser returns the fields the frame was packed from.

Prints a markdown table: operation, instructions per firmware, ratios of the first Rust
firmware to each C firmware. Instruction counts, not cycles: unicorn models no pipeline,
no flash wait states and no bus.
"""

import argparse
import struct
import sys

try:
    from unicorn import Uc, UcError, UC_ARCH_ARM, UC_MODE_THUMB, UC_HOOK_CODE
    from unicorn.arm_const import (
        UC_ARM_REG_R0, UC_ARM_REG_R1, UC_ARM_REG_R2, UC_ARM_REG_R3, UC_ARM_REG_SP,
        UC_ARM_REG_LR, UC_ARM_REG_C1_C0_2, UC_ARM_REG_FPEXC,
    )
except ImportError:
    sys.exit("count.py: the unicorn module is missing (pip install unicorn pyelftools)")
try:
    from elftools.elf.elffile import ELFFile
    from elftools.elf.sections import SymbolTableSection
except ImportError:
    sys.exit("count.py: the pyelftools module is missing (pip install unicorn pyelftools)")

FLASH, FLASH_LEN = 0x0800_0000, 1024 * 1024
RAM, RAM_LEN = 0x2000_0000, 128 * 1024
STOP = 0x1000_0000  # a page of its own; LR points here (Thumb bit set)
STACK_TOP = RAM + RAM_LEN

# Buffers, between the firmware's statics (bottom of RAM) and the stack (top).
BUF_OUT = RAM + 0x8000  # encoded frame
BUF_FRAME = RAM + 0x8200  # frame fed to a parser
BUF_FIELDS = RAM + 0x8400  # BENCH_248 fields (packer input)
BUF_DECODED = RAM + 0x8600  # BENCH_248 fields (decoder output)
BUF_MSG = RAM + 0x9000  # Rust: Message; C: mavlink_message_t
BUF_PARSER = RAM + 0xA000  # Rust: Parser
SLOT = 0x1000

FRAME_BUF = 280  # v2::MAX_UNSIGNED_FRAME_LEN


def fields_248():
    """BENCH_248 field values and their wire (= C struct) bytes."""
    time_usec = 0x0123_4567_89AB_CDEF
    d = [1.5, -2.25, 3.125e-3, 6.02214076e23]
    f = [0.5 * i - 7.25 for i in range(40)]
    label = b"ferrolink vs MAVLink C, M4 bench"[:32].ljust(32, b"\0")
    raw = bytes(range(0xF0, 0x100))
    blob = struct.pack("<Q4d40f", time_usec, *d, *f) + label + raw
    assert len(blob) == 248
    return blob


class Firmware:
    def __init__(self, path, rust):
        self.path = path
        self.rust = rust
        self.uc = Uc(UC_ARCH_ARM, UC_MODE_THUMB)
        # Enable the FPU: CPACR full access to CP10/CP11, FPEXC.EN.
        self.uc.reg_write(UC_ARM_REG_C1_C0_2, self.uc.reg_read(UC_ARM_REG_C1_C0_2) | (0xF << 20))
        self.uc.reg_write(UC_ARM_REG_FPEXC, 0x4000_0000)
        self.uc.mem_map(FLASH, FLASH_LEN)
        self.uc.mem_map(RAM, RAM_LEN)
        self.uc.mem_map(STOP, 0x1000)
        self.uc.mem_write(STOP, b"\xfe\xe7")  # b .
        self.symbols = {}
        with open(path, "rb") as fh:
            elf = ELFFile(fh)
            for sec in elf.iter_sections():
                if not sec["sh_flags"] & 2 or sec["sh_size"] == 0:  # SHF_ALLOC
                    continue
                if sec["sh_type"] == "SHT_NOBITS":
                    self.uc.mem_write(sec["sh_addr"], b"\0" * sec["sh_size"])
                else:
                    self.uc.mem_write(sec["sh_addr"], sec.data())
            for sec in elf.iter_sections():
                if isinstance(sec, SymbolTableSection):
                    for sym in sec.iter_symbols():
                        if sym["st_info"]["type"] == "STT_FUNC":
                            self.symbols[sym.name] = sym["st_value"]
        self.count = 0
        self.uc.hook_add(UC_HOOK_CODE, self._step)

    def _step(self, uc, address, size, user):
        self.count += 1

    def func(self, name):
        """Address (Thumb bit set) of `name`: exact for C, by mangled name for Rust."""
        if not self.rust:
            return self.symbols[name] | 1
        key = f"{len(name)}{name}17h"
        hits = [a for s, a in self.symbols.items() if key in s]
        if len(hits) != 1:
            raise SystemExit(f"count.py: {self.path}: {len(hits)} symbols for {name}")
        return hits[0] | 1

    def call(self, name, *args):
        """Calls `name` with up to four integer arguments; returns (r0, instructions)."""
        regs = [UC_ARM_REG_R0, UC_ARM_REG_R1, UC_ARM_REG_R2, UC_ARM_REG_R3]
        for reg, value in zip(regs, args):
            self.uc.reg_write(reg, value)
        self.uc.reg_write(UC_ARM_REG_SP, STACK_TOP)
        self.uc.reg_write(UC_ARM_REG_LR, STOP | 1)
        self.count = 0
        try:
            self.uc.emu_start(self.func(name), STOP, count=10_000_000)
        except UcError as e:
            raise SystemExit(f"count.py: {self.path}: {name}: {e}")
        return self.uc.reg_read(UC_ARM_REG_R0), self.count

    def write(self, addr, data):
        self.uc.mem_write(addr, bytes(data))

    def read(self, addr, n):
        return bytes(self.uc.mem_read(addr, n))


def measure(fw, blob):
    """Runs every operation twice; returns ({op: instructions}, {op: frame bytes})."""
    res, frames = {}, {}
    fw.write(BUF_FIELDS, blob)
    if fw.rust:
        fw.call("parser_init", BUF_PARSER)
        fw.call("message_init", BUF_MSG)
    for op, args, check in [
        ("pack_bench_1", (0x5A,), None),
        ("pack_bench_248", (BUF_FIELDS,), None),
    ]:
        counts = []
        for seq in (7, 8):
            fw.write(BUF_OUT, b"\xAA" * FRAME_BUF)
            n, c = fw.call(op, *args, seq, BUF_OUT)
            counts.append(c)
            frames[(op, seq)] = fw.read(BUF_OUT, n)
        if counts[0] != counts[1]:
            raise SystemExit(f"count.py: {fw.path}: {op} took {counts} instructions")
        res[op] = counts[1]
    if not fw.rust:
        for op, arg in [("pack_only_bench_1", 0x5A), ("pack_only_bench_248", BUF_FIELDS)]:
            for seq in (7, 8):
                _, c = fw.call(op, arg, seq, BUF_MSG)
            res[op] = c
    return res, frames


def parse(fw, frame1, frame248, blob):
    """Parse+decode of the given frames, twice each; checks the results."""
    res = {}
    ops = [("parse_bench_1", frame1), ("parse_bench_248", frame248)]
    if fw.rust:
        ops += [("parse_bytes_bench_1", frame1), ("parse_bytes_bench_248", frame248)]
    for op, frame in ops:
        for _ in range(2):
            fw.write(BUF_FRAME, frame.ljust(FRAME_BUF, b"\0"))
            fw.write(BUF_DECODED, b"\0" * 248)
            if fw.rust:
                r, c = fw.call(op, BUF_PARSER, BUF_FRAME, len(frame), BUF_MSG)
            elif op.endswith("bench_1"):
                r, c = fw.call(op, BUF_FRAME, len(frame))
            else:
                r, c = fw.call(op, BUF_FRAME, len(frame), BUF_DECODED)
            if op.endswith("bench_1") and r != 0x5A:
                raise SystemExit(f"count.py: {fw.path}: {op} returned {r:#x}, not 0x5a")
            if op.endswith("bench_248"):
                if r != 1:
                    raise SystemExit(f"count.py: {fw.path}: {op} returned {r}, not 1")
                if fw.rust:
                    ok, _ = fw.call("export_bench_248", BUF_MSG, BUF_DECODED)
                    if ok != 1:
                        raise SystemExit(f"count.py: {fw.path}: no BENCH_248 decoded")
                if fw.read(BUF_DECODED, 248) != blob:
                    raise SystemExit(f"count.py: {fw.path}: {op} decoded other fields")
        res[op] = c
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ours", action="append", default=[], metavar="LABEL=ELF")
    ap.add_argument("--c", action="append", default=[], metavar="LABEL=ELF")
    ap.add_argument("--frames", action="store_true", help="print the packed frames (hex)")
    a = ap.parse_args()
    if not a.ours and not a.c:
        ap.error("need at least one firmware")
    blob = fields_248()
    cols = []  # (label, is_rust, results)
    reference = None
    for spec, rust in [(s, True) for s in a.ours] + [(s, False) for s in a.c]:
        label, _, path = spec.partition("=")
        fw = Firmware(path, rust)
        res, frames = measure(fw, blob)
        if reference is None:
            reference = frames
        elif frames != reference:
            for key in frames:
                if frames[key] != reference[key]:
                    print(f"{key}: {reference[key].hex()}\n   vs {frames[key].hex()}", file=sys.stderr)
            raise SystemExit(f"count.py: {path}: frames differ from the first firmware's")
        cols.append((label, rust, res, fw))
    # Every parser gets the same frames (the ones all packers agreed on).
    f1, f248 = reference[("pack_bench_1", 8)], reference[("pack_bench_248", 8)]
    for _, _, res, fw in cols:
        res.update(parse(fw, f1, f248, blob))
    if a.frames:
        for key, frame in sorted(reference.items()):
            print(f"{key[0]} seq {key[1]}: {frame.hex()}", file=sys.stderr)

    ours = [c for c in cols if c[1]]
    theirs = [c for c in cols if not c[1]]
    head = ["operation"]
    head += [f"ours {label} (instructions)" for label, *_ in ours]
    head += [f"C library {label} (instructions)" for label, *_ in theirs]
    if ours:
        head += [f"ratio ours {ours[0][0]} / C {label}" for label, *_ in theirs]
    print("| " + " | ".join(head) + " |")
    print("|---|" + "---:|" * (len(head) - 1))
    rows = [
        ("pack BENCH_1 (1-byte payload) into a frame buffer", "pack_bench_1", "pack_bench_1"),
        ("pack BENCH_248 (248-byte payload) into a frame buffer", "pack_bench_248", "pack_bench_248"),
        ("parse + decode BENCH_1 frame (13 bytes), whole frame fed at once", "parse_bench_1", "parse_bench_1"),
        ("parse + decode BENCH_248 frame (260 bytes), whole frame fed at once", "parse_bench_248", "parse_bench_248"),
        ("parse + decode BENCH_1 frame, fed one byte at a time", "parse_bytes_bench_1", "parse_bench_1"),
        ("parse + decode BENCH_248 frame, fed one byte at a time", "parse_bytes_bench_248", "parse_bench_248"),
        ("C only: `mavlink_msg_bench_1_pack` alone", None, "pack_only_bench_1"),
        ("C only: `mavlink_msg_bench_248_pack` alone", None, "pack_only_bench_248"),
    ]
    for title, rop, cop in rows:
        if (rop is None and not theirs) or (rop is not None and ours and rop not in ours[0][2]):
            continue
        cells = [title]
        cells += [str(r[rop]) if rop else "–" for _, _, r, _ in ours]
        cells += [str(r[cop]) for _, _, r, _ in theirs]
        for _, _, r, _ in theirs if ours else []:
            cells.append(f"{ours[0][2][rop] / r[cop]:.2f}" if rop else "–")
        print("| " + " | ".join(cells) + " |")
    print()
    print(f"Frames checked byte-identical across all {len(cols)} firmware builds "
          f"(BENCH_1: {len(f1)} bytes, BENCH_248: {len(f248)} bytes, seq 7 and 8); "
          "every parser decoded the packed fields.")


if __name__ == "__main__":
    main()
