#!/usr/bin/env bash
# Clean release build time of MAVLink common bindings: Ferrolink against the mavlink crate 0.21.
#
# Usage: benches/build_time.sh [path/to/common.xml]
#
# Two throwaway crates, each in its own temporary directory with its own target directory:
#   ferrolink: build.rs runs ferrolink_codegen on common.xml, lib.rs include!s the result
#              (ferrolink-runtime and ferrolink-codegen from this repository, by path; the
#              generator without default features, as docs/generator.md advises for a build.rs: no
#              formatting of what lands in OUT_DIR);
#   mavlink:   depends on mavlink 0.21, default features off, `dialect-common` + `std`
#              (one of `std`/`embedded` is required to compile).
# For each: a full build from scratch (dependencies included), then `cargo clean -p` of the
# crate that holds the generated code and a timed rebuild of just that crate (its build script
# included, since that is where the code is generated).
#
# Without an argument, common.xml is taken from pymavlink (dialects/v20/common.xml) as found by
# $PYTHON (default python3).
#
# Environment:
#   PYTHON               interpreter that has pymavlink (default: python3)
#   FERROLINK_CARGO_LOCK lock file serialising cargo runs (default: /tmp/ferrolink-cargo.lock);
#                        flock is skipped when it is not installed. Lock waits are not timed.
#   BUILD_TIME_RUNS      timed rebuilds of the generated crate per side (default: 1; the
#                        fastest is reported)
#   KEEP_WORKDIR=1       keep the temporary crates and their target directories
set -euo pipefail

die() {
    echo "build_time.sh: $*" >&2
    exit 1
}

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
lock=${FERROLINK_CARGO_LOCK:-/tmp/ferrolink-cargo.lock}
runs=${BUILD_TIME_RUNS:-1}
[[ $runs =~ ^[1-9][0-9]*$ ]] || die "BUILD_TIME_RUNS must be a positive integer"

if [[ $# -gt 1 || ${1:-} == -h || ${1:-} == --help ]]; then
    sed -n '2,/^set -e/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'
    exit 0
fi

if [[ $# -eq 1 ]]; then
    common_xml=$1
else
    python=${PYTHON:-python3}
    pymavlink_dir=$("$python" -c 'import pymavlink, os; print(os.path.dirname(pymavlink.__file__))') ||
        die "no common.xml given and '$python' cannot import pymavlink (set PYTHON or pass a path)"
    common_xml=$pymavlink_dir/dialects/v20/common.xml
fi
[[ -f $common_xml ]] || die "not a file: $common_xml"
common_xml=$(cd "$(dirname "$common_xml")" && pwd)/$(basename "$common_xml")
command -v cargo >/dev/null || die "cargo not found"

if command -v flock >/dev/null; then
    have_flock=1
else
    have_flock=0
    echo "note: flock not found, running cargo without $lock" >&2
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/ferrolink-build-time.XXXXXX")
if [[ ${KEEP_WORKDIR:-0} == 1 ]]; then
    echo "keeping $work" >&2
else
    trap 'rm -rf "$work"' EXIT
fi

export BUILD_TIME_LOG=$work/cargo.log

# Runs "$@" under the lock.
locked() {
    if [[ $have_flock == 1 ]]; then flock "$lock" "$@"; else "$@"; fi
}

# Runs `cargo "$@"` in directory $1 under the lock and prints the seconds it took (lock wait
# excluded). Cargo's own output goes to $work/cargo.log.
timed_cargo() {
    local dir=$1
    shift
    local script='s=$(date +%s%N); cargo "$@" >>"$BUILD_TIME_LOG" 2>&1 || exit $?; e=$(date +%s%N); echo $(( (e - s) / 1000000 ))'
    local ms
    ms=$(cd "$dir" && locked bash -c "$script" timed "$@") ||
        die "cargo $* failed in $dir; see the end of $work/cargo.log (set KEEP_WORKDIR=1 to keep it)"
    awk -v ms="$ms" 'BEGIN { printf "%.1f", ms / 1000 }'
}

# --- The two throwaway crates --------------------------------------------------------------

ours=$work/ferrolink-common
mkdir -p "$ours/src"
cat >"$ours/Cargo.toml" <<EOF
[package]
name = "build-time-ferrolink"
version = "0.0.0"
edition = "2021"
publish = false

[workspace]

[dependencies]
ferrolink-runtime = { path = "$repo/runtime", default-features = false, features = ["mavlink"] }

[build-dependencies]
ferrolink-codegen = { path = "$repo/codegen", default-features = false }
EOF
cat >"$ours/build.rs" <<EOF
fn main() {
    let xml = "$common_xml";
    println!("cargo:rerun-if-changed={xml}");
    ferrolink_codegen::Config::new()
        .input(xml)
        .compile()
        .unwrap_or_else(|e| panic!("{e}"));
}
EOF
# Both libraries also get one function that decodes any common message and frames it again, so
# the build compiles every message's encoder and decoder (Ferrolink's are `#[inline]` and would
# otherwise only be compiled by a user of the crate).
cat >"$ours/src/lib.rs" <<'EOF'
#![allow(dead_code, missing_docs)]
pub mod dialects {
    include!(concat!(env!("OUT_DIR"), "/ferrolink.rs"));
}

use ferrolink_runtime::mavlink::{v2, Dialect, Header};

/// Decodes a common message and encodes it as a MAVLink 2 frame into `out`.
pub fn reframe(id: u32, payload: &[u8], out: &mut [u8; v2::MAX_FRAME_LEN]) -> usize {
    match dialects::common::Message::decode(id, payload) {
        Ok(msg) => v2::encode_dialect(Header::new(0, 1, 1), &msg, out).unwrap_or(0),
        Err(_) => 0,
    }
}
EOF

theirs=$work/mavlink-common
mkdir -p "$theirs/src"
cat >"$theirs/Cargo.toml" <<'EOF'
[package]
name = "build-time-mavlink"
version = "0.0.0"
edition = "2021"
publish = false

[workspace]

[dependencies]
mavlink = { version = "0.21", default-features = false, features = ["dialect-common", "std"] }
EOF
cat >"$theirs/src/lib.rs" <<'EOF'
pub use mavlink::dialects::common;

use mavlink::{MAVLinkV2MessageRaw, MavHeader, MavlinkVersion, Message};

/// Decodes a common message and encodes it as a MAVLink 2 frame into `out`.
pub fn reframe(id: u32, payload: &[u8], out: &mut MAVLinkV2MessageRaw) -> usize {
    match common::MavMessage::parse(MavlinkVersion::V2, id, payload) {
        Ok(msg) => {
            let header = MavHeader { system_id: 1, component_id: 1, sequence: 0 };
            out.serialize_message(header, &msg);
            out.raw_bytes().len()
        }
        Err(_) => 0,
    }
}
EOF

# Start from the repository's lock file so shared dependencies get the versions the project
# builds with; cargo drops what these crates do not use.
if [[ -f $repo/Cargo.lock ]]; then
    cp "$repo/Cargo.lock" "$ours/Cargo.lock"
    cp "$repo/Cargo.lock" "$theirs/Cargo.lock"
fi

echo "common.xml:  $common_xml" >&2
echo "workdir:     $work" >&2
echo "fetching dependencies..." >&2
timed_cargo "$ours" fetch >/dev/null
timed_cargo "$theirs" fetch >/dev/null

# $1 crate dir, $2 package holding the generated code. Sets `full` and `crate_only`.
measure() {
    local dir=$1 pkg=$2
    echo "building $pkg from scratch..." >&2
    full=$(timed_cargo "$dir" build --release --offline)
    crate_only=
    local i t
    for ((i = 0; i < runs; i++)); do
        timed_cargo "$dir" clean --release --offline -p "$pkg" >/dev/null
        echo "rebuilding $pkg ($((i + 1))/$runs)..." >&2
        t=$(timed_cargo "$dir" build --release --offline)
        if [[ -z $crate_only ]] || awk -v a="$t" -v b="$crate_only" 'BEGIN { exit !(a < b) }'; then
            crate_only=$t
        fi
    done
}

measure "$ours" build-time-ferrolink
ours_full=$full ours_crate=$crate_only
measure "$theirs" mavlink
theirs_full=$full theirs_crate=$crate_only

# --- Generated code size -------------------------------------------------------------------

newest() { find "$1" -path "$2" -type f -printf '%T@ %p\n' 2>/dev/null | sort -n | tail -1 | cut -d' ' -f2-; }
ours_rs=$(newest "$ours/target/release/build" '*/out/ferrolink.rs')
theirs_rs=$(newest "$theirs/target/release/build" '*/out/common.rs')
[[ -n $ours_rs && -n $theirs_rs ]] || die "generated files not found under the target directories"

lines() { wc -l <"$1" | tr -d ' '; }
bytes() { wc -c <"$1" | tr -d ' '; }
# mavlink writes its code unformatted (without its `format-generated-code` feature), so lines
# are also counted after rustfmt, on a copy, to compare like with like.
fmt_lines() {
    if command -v rustfmt >/dev/null; then
        local copy=$work/fmt-$(basename "$1")
        cp "$1" "$copy"
        if rustfmt --edition 2021 "$copy" 2>/dev/null; then lines "$copy"; else echo "n/a"; fi
    else
        echo "n/a"
    fi
}
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { if (b > 0) printf "%.2f", a / b; else print "n/a" }'; }

# Message counts of the XML each side compiled (common.xml plus what it includes).
count_messages() {
    local dir=$1 total=0 f
    for f in common.xml standard.xml minimal.xml; do
        [[ -f $dir/$f ]] && total=$((total + $(grep -c '<message ' "$dir/$f" || true)))
    done
    echo "$total"
}
mavlink_src=$(cd "$theirs" && locked cargo metadata --format-version 1 --offline 2>/dev/null |
    grep -o '"manifest_path":"[^"]*/mavlink-0\.21\.[0-9]*/Cargo.toml"' | head -1 |
    sed 's/"manifest_path":"//; s/Cargo.toml"$//')
theirs_xml_dir=${mavlink_src}mavlink/message_definitions/v1.0

cat <<EOF

## Build time: MAVLink common bindings, release profile

- Ferrolink: \`$(basename "$common_xml")\` from \`$(dirname "$common_xml")\` ($(count_messages "$(dirname "$common_xml")") messages with its includes)
- mavlink 0.21: its bundled common.xml ($(count_messages "$theirs_xml_dir") messages with its includes), features \`dialect-common\`, \`std\`
- rustc: $(rustc --version), $(nproc 2>/dev/null || echo '?') CPUs; crate-only: fastest of $runs

| | Ferrolink | mavlink 0.21 | Ferrolink / mavlink |
|---|---:|---:|---:|
| full clean build (s) | $ours_full | $theirs_full | $(ratio "$ours_full" "$theirs_full") |
| generated crate only (s) | $ours_crate | $theirs_crate | $(ratio "$ours_crate" "$theirs_crate") |
| generated lines (as written) | $(lines "$ours_rs") | $(lines "$theirs_rs") | |
| generated lines (rustfmt) | $(fmt_lines "$ours_rs") | $(fmt_lines "$theirs_rs") | |
| generated bytes | $(bytes "$ours_rs") | $(bytes "$theirs_rs") | $(ratio "$(bytes "$ours_rs")" "$(bytes "$theirs_rs")") |

"generated crate only" is the rebuild after \`cargo clean --release -p\` of build-time-ferrolink
(its build script runs the generator) and of mavlink (likewise), dependencies already built.
EOF
