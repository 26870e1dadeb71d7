#!/usr/bin/env bash
# Flash and static RAM of the no_std NDLCom node (src/main.rs) on thumbv7em-none-eabihf, for the
# default limits (payload 255, 256 addresses), the `small` ones (payload 64, 16 addresses) and
# the `bare` skeleton without NDLCom, each at opt-level "s" (release) and "z" (release-z).
#
# Usage: bash examples/ndlcom-node/size.sh
#
#   flash      = .vector_table + .text + .rodata + .data (the initial image of .data is in flash)
#   static RAM = .data + .bss (the stack, which takes the rest of RAM, is not counted)
#
# Section sizes are read with binutils' readelf (it reads ARM ELF files on any host).
#
# Environment:
#   FERROLINK_CARGO_LOCK lock file serialising cargo runs (default: /tmp/ferrolink-cargo.lock);
#                        flock is skipped when it is not installed.
#   SIZE_SYMBOLS=1       also list the largest symbols of each build (binutils nm).
#
# Exit status 3 when the default node at "z" is over the reference C implementation's figures:
# NDLCom's share of flash (over the `bare` skeleton) must stay under 3.2 kB (3200 B) and its
# static RAM at or under 1 kB (1024 B).
set -euo pipefail
cd "$(dirname "$0")"

target=thumbv7em-none-eabihf
bin=ferrolink-example-ndlcom-node
lock=${FERROLINK_CARGO_LOCK:-/tmp/ferrolink-cargo.lock}

die() {
    echo "size.sh: $*" >&2
    exit 1
}

command -v readelf >/dev/null || die "readelf not found (install binutils)"
if ! rustup target list --installed 2>/dev/null | grep -qx "$target"; then
    rustup target add "$target" >&2 || die "could not install the $target target"
fi

locked() {
    if command -v flock >/dev/null; then flock "$lock" "$@"; else "$@"; fi
}

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

rows=()
for variant in default small bare; do
    features=()
    [[ $variant != default ]] && features=(--features "$variant")
    for profile in release release-z; do
        locked cargo build --quiet --profile "$profile" "${features[@]}" >&2
        elf=target/$target/$profile/$bin
        list=$(sections "$elf")
        vt=$(size_of "$list" .vector_table)
        text=$(size_of "$list" .text)
        rodata=$(size_of "$list" .rodata)
        data=$(size_of "$list" .data)
        bss=$(size_of "$list" .bss)
        opt=s
        [[ $profile == release-z ]] && opt=z
        rows+=("$variant $opt $((vt + text + rodata + data)) $vt $text $rodata $data $bss $((data + bss))")
        if [[ ${SIZE_SYMBOLS:-0} == 1 ]]; then
            echo "--- $variant, opt-level $opt: largest symbols" >&2
            nm -S --size-sort -C "$elf" | tail -n 12 >&2
        fi
    done
done

describe() {
    case $1 in
    default) echo "node, payload 255, 256 addresses" ;;
    small) echo "node, payload 64, 16 addresses (\`small\`)" ;;
    bare) echo "skeleton without NDLCom (\`bare\`)" ;;
    esac
}

echo "| build | opt-level | flash | .vector_table | .text | .rodata | .data | .bss | static RAM |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|"
for row in "${rows[@]}"; do
    read -r variant opt flash vt text rodata data bss ram <<<"$row"
    echo "| $(describe "$variant") | \"$opt\" | $flash | $vt | $text | $rodata | $data | $bss | $ram |"
done
echo
echo "Bytes; flash = .vector_table + .text + .rodata + .data, static RAM = .data + .bss (stack not counted)."
echo "The NDLCom share of a build is its flash and RAM minus the \`bare\` row of the same opt-level."

# The budget: the reference C implementation's 3.2 kB of code and 1 kB of static RAM.
# Field $3 (1-based) of the row of variant $1 at opt-level $2.
field() { printf '%s\n' "${rows[@]}" | awk -v v="$1" -v o="$2" -v f="$3" '$1 == v && $2 == o { print $f }'; }
share=$(($(field default z 3) - $(field bare z 3)))
ram=$(field default z 9)
echo
if ((share < 3200 && ram <= 1024)); then
    echo "budget: NDLCom adds $share B of flash (< 3200) and $ram B of static RAM (<= 1024) at \"z\": ok"
else
    echo "budget: NDLCom adds $share B of flash and $ram B of static RAM at \"z\": over the reference C's 3200 B / 1024 B" >&2
    exit 3
fi
