#!/usr/bin/env bash
# MAVLink 2 pack and parse+decode on a Cortex-M4 (thumbv7em-none-eabihf): instructions per
# operation of ferrolink (src/main.rs) against the MAVLink C library (c/bench_c.c), counted in
# the unicorn emulator by count.py, plus flash and static RAM of each firmware, and of a radio
# bridge that parses, routes and signs (src/router.rs against c/router_c.c).
#
# Usage: bash examples/mavlink-m4/measure.sh
#
#   ours:      opt-level "s" (release) and 3 (release-3), LTO, one codegen unit, the runtime's
#              `mavlink` feature only (512-byte CRC table)
#   C library: headers generated now by pymavlink's mavgen (MAVLink 2) from the same
#              definitions/mavlink/bench.xml, arm-none-eabi-gcc -O2 and -Os, newlib-nano's
#              memcpy/memset
#   flash      = .text + .rodata + .data (the vector table is listed apart)
#   static RAM = .data + .bss (stack not counted)
#
# Environment:
#   PYTHON                 Python with unicorn, pyelftools and pymavlink (default: the project's
#                          .venv/bin/python if there is one, else python3)
#   CC_ARM                 the C cross compiler (default: arm-none-eabi-gcc)
#   FERROLINK_CARGO_LOCK   lock file serialising cargo runs (default: /tmp/ferrolink-cargo.lock)
#   FRAMES=1               also print the packed frames (hex)
set -euo pipefail
cd "$(dirname "$0")"
here=$(pwd)
root=$(cd ../.. && pwd)

target=thumbv7em-none-eabihf
bin=ferrolink-example-mavlink-m4
lock=${FERROLINK_CARGO_LOCK:-/tmp/ferrolink-cargo.lock}
cc=${CC_ARM:-arm-none-eabi-gcc}
if [[ -z ${PYTHON:-} ]]; then
    if [[ -x $root/.venv/bin/python ]]; then PYTHON=$root/.venv/bin/python; else PYTHON=python3; fi
fi
build=$here/target/c
cflags=(-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16
    -ffunction-sections -fdata-sections -Wall -Wno-address-of-packed-member)

die() {
    echo "measure.sh: $*" >&2
    exit 1
}
note() { echo "measure.sh: $*" >&2; }

command -v readelf >/dev/null || die "readelf not found (install binutils)"
command -v cargo >/dev/null || die "cargo not found"
if ! rustup target list --installed 2>/dev/null | grep -qx "$target"; then
    rustup target add "$target" >&2 || die "the $target target is missing and could not be installed (rustup target add $target)"
fi

have_c=1
if ! command -v "$cc" >/dev/null; then
    note "$cc not found: no C library firmware (apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi)"
    have_c=0
elif ! "$PYTHON" -c 'import pymavlink' 2>/dev/null; then
    note "pymavlink not importable by $PYTHON: no C library firmware (pip install pymavlink)"
    have_c=0
fi
have_emu=1
if ! "$PYTHON" -c 'import unicorn, elftools' 2>/dev/null; then
    note "unicorn or pyelftools not importable by $PYTHON: no instruction counts, sizes only (pip install unicorn pyelftools)"
    have_emu=0
fi

locked() {
    if command -v flock >/dev/null; then flock "$lock" "$@"; else "$@"; fi
}

# --- builds -----------------------------------------------------------------------------------
rust_elfs=()
router_elfs=()
for profile in release release-3; do
    locked cargo build --quiet --profile "$profile" >&2
    rust_elfs+=("target/$target/$profile/$bin")
    router_elfs+=("target/$target/$profile/$bin-router")
done

c_elfs=()
c_router_elfs=()
if [[ $have_c == 1 ]]; then
    rm -rf "$build"
    mkdir -p "$build"
    "$PYTHON" -m pymavlink.tools.mavgen --lang=C --wire-protocol=2.0 --output "$build/include" \
        "$root/definitions/mavlink/bench.xml" >/dev/null
    libs=(-lc -lgcc)
    specs=(-specs=nano.specs)
    # Without newlib, the harness still needs memcpy/memset/memcmp: c/mem.c provides plain ones.
    if ! echo 'int main(void){return 0;}' | "$cc" "${cflags[@]}" "${specs[@]}" -x c -c -o /dev/null - 2>/dev/null ||
        ! "$cc" "${cflags[@]}" -print-file-name=libc_nano.a | grep -q /; then
        note "newlib-nano not found: using c/mem.c for memcpy/memset/memcmp (apt-get install libnewlib-arm-none-eabi)"
        libs=(-nostdlib c/mem.c -lgcc)
        specs=()
    fi
    for opt in O2 Os; do
        "$cc" "${cflags[@]}" "-$opt" "${specs[@]}" -nostartfiles -I"$build/include" -T c/link.ld \
            -Wl,--gc-sections -o "$build/bench_c_$opt.elf" c/bench_c.c "${libs[@]}"
        c_elfs+=("$build/bench_c_$opt.elf")
        "$cc" "${cflags[@]}" "-$opt" "${specs[@]}" -nostartfiles -I"$build/include" -T c/link.ld \
            -Wl,--gc-sections -o "$build/router_c_$opt.elf" c/router_c.c "${libs[@]}"
        c_router_elfs+=("$build/router_c_$opt.elf")
    done
fi

# --- instructions -----------------------------------------------------------------------------
if [[ $have_emu == 1 ]]; then
    args=(--ours "\"s\"=${rust_elfs[0]}" --ours "3=${rust_elfs[1]}")
    if [[ $have_c == 1 ]]; then
        args+=("--c=-O2=${c_elfs[0]}" "--c=-Os=${c_elfs[1]}")
    fi
    [[ ${FRAMES:-0} == 1 ]] && args+=(--frames)
    "$PYTHON" count.py "${args[@]}"
    echo
fi

# --- flash and RAM ----------------------------------------------------------------------------
# Prints "name size" (size in decimal) for every section of ELF file $1.
sections() {
    readelf -S --wide "$1" | sed -n 's/^ *\[ *[0-9]*\] *//p' |
        while read -r name _type _addr _off size _rest; do
            [[ $name == .* ]] && echo "$name $((16#$size))"
        done
}

# Size of section $2 in the listing $1 (0 when absent).
size_of() {
    awk -v s="$2" '$1 == s { print $2; found = 1 } END { if (!found) print 0 }' <<<"$1"
}

echo "| firmware | flash (.text + .rodata + .data) | .text | .rodata | .data | .bss | static RAM (.data + .bss) | .vector_table |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|"
row() {
    local list text rodata data bss vt
    list=$(sections "$2")
    text=$(size_of "$list" .text)
    rodata=$(size_of "$list" .rodata)
    data=$(size_of "$list" .data)
    bss=$(size_of "$list" .bss)
    vt=$(size_of "$list" .vector_table)
    echo "| $1 | $((text + rodata + data)) | $text | $rodata | $data | $bss | $((data + bss)) | $vt |"
}
row 'ours, opt-level "s"' "${rust_elfs[0]}"
row 'ours, opt-level 3' "${rust_elfs[1]}"
if [[ $have_c == 1 ]]; then
    row 'C library, -O2' "${c_elfs[0]}"
    row 'C library, -Os' "${c_elfs[1]}"
fi
echo
echo "Bytes. Each firmware holds the harness's functions (both packers, both parsers) and what"
echo "they pull in; static RAM is the parser state (ours: one Parser and one decoded Message in"
echo "statics; C: the library's per-channel status and receive buffers)."

echo
echo "A radio bridge that parses, routes and signs (src/router.rs, c/router_c.c):"
echo
echo "| firmware | flash (.text + .rodata + .data) | .text | .rodata | .data | .bss | static RAM (.data + .bss) | .vector_table |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|"
row 'ours, opt-level "s"' "${router_elfs[0]}"
row 'ours, opt-level 3' "${router_elfs[1]}"
if [[ $have_c == 1 ]]; then
    row 'C library, -O2' "${c_router_elfs[0]}"
    row 'C library, -Os' "${c_router_elfs[1]}"
fi
echo
echo "Bytes. Both: two UARTs, a parser each, routes for 8 (system, component) pairs, signatures"
echo "checked on the radio link and unsigned frames signed on their way to it, SHA-256 included."
echo "Ours keeps per-link and per-source counters besides; the C library keeps its channel"
echo "status for all of its MAVLINK_COMM_NUM_BUFFERS channels."

# --- versions ---------------------------------------------------------------------------------
echo
rt=$(awk '/^name = "cortex-m-rt"$/ { getline; print $3 }' Cargo.lock | tr -d '"')
echo "- host: $(uname -m), $(uname -s) $(uname -r)"
echo "- $(rustc --version), cortex-m-rt $rt, target $target"
if [[ $have_c == 1 ]]; then
    echo "- $("$cc" --version | head -n 1)"
    echo "- pymavlink $("$PYTHON" -c 'import importlib.metadata as m; print(m.version("pymavlink"))') (mavgen, MAVLink 2 C headers)"
fi
if [[ $have_emu == 1 ]]; then
    echo "- unicorn $("$PYTHON" -c 'import unicorn; print(unicorn.__version__)'), Python $("$PYTHON" -c 'import platform; print(platform.python_version())')"
fi
