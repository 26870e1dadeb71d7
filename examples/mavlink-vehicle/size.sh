#!/usr/bin/env bash
# Flash and RAM of the MAVLink vehicle firmware (src/main.rs) on thumbv7em-none-eabihf, by
# section, and the code of each service, from the release build (opt-level "s", LTO).
#
# Usage: bash examples/mavlink-vehicle/size.sh
#
#   flash      = .vector_table + .text + .rodata + .data (the initial image of .data is in flash)
#   static RAM = .data + .bss + .uninit; the stack has the rest of RAM
#
# The budget is memory.x's: FLASH and RAM lengths, and the stack reserve the link keeps free.
# The link fails when the firmware does not fit, so a build that this script can measure fits.
# How much stack the firmware really uses is measured at run time: the read-only parameter
# SYS_STACK_USED (check.sh prints it).
#
# Code by service: every symbol of .vector_table, .text and .rodata (binutils nm, demangled
# with c++filt), grouped by its path: the runtime's service module and this firmware's code
# for it (`vehicle::Vehicle::command_*`, `params::`, `files::`, ...). Code the optimiser inlined
# goes with the function it was inlined into.
#
# Environment:
#   FERROLINK_CARGO_LOCK lock file serialising cargo runs (default: /tmp/ferrolink-cargo.lock);
#                        flock is skipped when it is not installed.
#   SIZE_SYMBOLS=1       also list the 25 largest symbols.
set -euo pipefail
cd "$(dirname "$0")"

target=thumbv7em-none-eabihf
bin=ferrolink-example-mavlink-vehicle
elf=${CARGO_TARGET_DIR:-target}/$target/release/$bin
lock=${FERROLINK_CARGO_LOCK:-/tmp/ferrolink-cargo.lock}

die() {
    echo "size.sh: $*" >&2
    exit 1
}

# binutils for ARM if installed, the host's otherwise (both read ARM ELF files).
tool() {
    if command -v "arm-none-eabi-$1" >/dev/null; then echo "arm-none-eabi-$1"; else echo "$1"; fi
}
readelf=$(tool readelf)
nm=$(tool nm)
cxxfilt=$(tool c++filt)
for t in "$readelf" "$nm" "$cxxfilt"; do
    command -v "$t" >/dev/null || die "$t not found (install binutils)"
done

locked() {
    if command -v flock >/dev/null; then flock "$lock" "$@"; else "$@"; fi
}

locked cargo build --quiet --release >&2

# Prints "name size" (size in decimal) for every section of the ELF file.
sections() {
    "$readelf" -S --wide "$elf" | sed -n 's/^ *\[ *[0-9]*\] *//p' |
        while read -r name _type _addr _off size _rest; do
            [[ $name == .* ]] && echo "$name $((16#$size))"
        done
}

# Size of section $1 (0 when absent).
size_of() {
    awk -v s="$1" '$1 == s { print $2; found = 1 } END { if (!found) print 0 }' <<<"$list"
}

# A LENGTH in memory.x (e.g. "32K") in bytes; $1 is the region.
length_of() {
    local v
    v=$(sed -n "s/^ *$1 *:.*LENGTH *= *\([0-9]*[KM]\?\).*/\1/p" memory.x)
    [[ -n $v ]] || die "no LENGTH for $1 in memory.x"
    case $v in
    *K) echo $((${v%K} * 1024)) ;;
    *M) echo $((${v%M} * 1048576)) ;;
    *) echo "$v" ;;
    esac
}
reserve=$(sed -n 's/^ *_stack_reserve *= *\([0-9]*\)K *;.*/\1/p' memory.x)
reserve=$((${reserve:-0} * 1024))

list=$(sections)
vt=$(size_of .vector_table)
text=$(size_of .text)
rodata=$(size_of .rodata)
data=$(size_of .data)
bss=$(size_of .bss)
uninit=$(size_of .uninit)
flash=$((vt + text + rodata + data))
ram=$((data + bss + uninit))
flash_len=$(length_of FLASH)
ram_len=$(length_of RAM)
stack=$((ram_len - ram))

pct() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f %%", 100 * a / b }'; }

echo "Flash ($flash_len B):"
echo
echo "| section | bytes |"
echo "|---|---:|"
echo "| .vector_table | $vt |"
echo "| .text | $text |"
echo "| .rodata | $rodata |"
echo "| .data (initial image) | $data |"
echo "| **total** | **$flash** ($(pct "$flash" "$flash_len"), $((flash_len - flash)) B free) |"
echo
echo "RAM ($ram_len B):"
echo
echo "| section | bytes |"
echo "|---|---:|"
echo "| .data | $data |"
echo "| .bss | $bss |"
echo "| .uninit | $uninit |"
echo "| **static** | **$ram** ($(pct "$ram" "$ram_len")) |"
echo "| stack (the rest; memory.x keeps at least $reserve) | $stack |"
echo

# Symbols of the flash sections, "hex-size name", demangled (local symbols such as
# `.Lswitch.table._ZN...` too), without hashes and crate disambiguators.
symbols=$("$nm" --print-size "$elf" | awk '$3 ~ /^[tTrR]$/ { print $2, $4 }' |
    sed 's/ \.L[A-Za-z_.]*\._ZN/ _ZN/' | "$cxxfilt" |
    sed 's/::h[0-9a-f]\{16\}//; s/\[[0-9a-f]\{16\}\]//g')

group() {
    case $1 in
    *service::command::* | *Vehicle::command_*) echo command ;;
    *service::param::* | *Vehicle::param_* | *mavlink_vehicle::params::*) echo param ;;
    *service::mission::* | *Vehicle::mission_* | *mavlink_vehicle::missions::*) echo mission ;;
    *service::peers::* | *Vehicle::peers_*) echo peers ;;
    *service::ftp::* | *Vehicle::ftp_* | *mavlink_vehicle::files::* | *FileSystem*) echo ftp ;;
    *mavlink::parser::* | *mavlink::v2::* | *ferrolink_runtime::crc::* | *ferrolink_runtime::framing::* | \
        *ferrolink_runtime::wire::* | *mavlink::decode_variant* | *microservices::* | *mavlink_vehicle::link::*)
        echo framing ;;
    compiler_builtins::mem::* | __aeabi_mem* | memcpy | memmove | memset | memcmp | bcmp | \
        *mavlink_vehicle::mem::*) echo mem ;;
    compiler_builtins::float::* | __aeabi_[dfilu]*2[dfilu]* | __aeabi_d* | \
        ferrolink_runtime::mavlink::service::mul_round | ferrolink_runtime::mavlink::service::div_f* | \
        ferrolink_runtime::mavlink::service::widen) echo float ;;
    *) echo rest ;;
    esac
}

declare -A bytes=()
total=0
while read -r hex name; do
    size=$((16#$hex))
    g=$(group "$name")
    bytes[$g]=$((${bytes[$g]:-0} + size))
    total=$((total + size))
done <<<"$symbols"

echo "Code by service (flash, from symbols):"
echo
echo "| part | bytes |"
echo "|---|---:|"
echo "| command (server, ARM/DISARM and calibration) | ${bytes[command]:-0} |"
echo "| param (server, store, the 64-entry table) | ${bytes[param]:-0} |"
echo "| mission (server, store) | ${bytes[mission]:-0} |"
echo "| peers (HEARTBEAT table, data link loss) | ${bytes[peers]:-0} |"
echo "| ftp (server, the file table, param.pck) | ${bytes[ftp]:-0} |"
echo "| MAVLink framing, CRC, message encode/decode | ${bytes[framing]:-0} |"
echo "| memcpy, memmove, memset, memcmp (src/mem.rs, a byte at a time) | ${bytes[mem]:-0} |"
echo "| the services' f64 conversions, in integers (no f64 in software) | ${bytes[float]:-0} |"
echo "| the rest (main loop, HEARTBEAT, hw, vectors, constants) | ${bytes[rest]:-0} |"
echo "| not in a symbol (alignment) | $((flash - total)) |"
echo
echo "Bytes; opt-level \"s\", LTO, one codegen unit, panic = \"abort\"."

if [[ ${SIZE_SYMBOLS:-0} == 1 ]]; then
    echo
    echo "Largest symbols:"
    while read -r hex name; do echo "$((16#$hex)) $name"; done <<<"$symbols" | sort -n | tail -n 25
fi
