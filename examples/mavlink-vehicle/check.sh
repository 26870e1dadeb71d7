#!/usr/bin/env bash
# Builds the vehicle firmware, starts it in QEMU on a free port and checks it end to end with
# tests/mavlink/firmware_qemu.py (MAVSDK, our CLI and pymavlink through `ferrolink mavlink
# router`); QEMU is stopped on exit, whatever happens.
#
# Usage: bash examples/mavlink-vehicle/check.sh [firmware_qemu.py options, e.g. --only stack]
#
# Exits with firmware_qemu.py's status: 0 when every check passed. The firmware's Rust target
# (thumbv7em-none-eabihf) is added with rustup when it is not installed.
#
# Environment:
#   FERROLINK            the ferrolink binary (default: target/debug/ferrolink of the main
#                        workspace, built with `cargo build -p ferrolink-cli` when missing;
#                        `cargo test -p ferrolink-cli --test firmware_qemu` passes its own)
#   PYTHON               a Python with mavsdk and pymavlink (default: the main workspace's
#                        .venv/bin/python, else python3)
#   FERROLINK_CARGO_LOCK lock file serialising cargo runs (default: /tmp/ferrolink-cargo.lock);
#                        flock is skipped when it is not installed.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
lock=${FERROLINK_CARGO_LOCK:-/tmp/ferrolink-cargo.lock}

locked() {
    if command -v flock >/dev/null; then flock "$lock" "$@"; else "$@"; fi
}

die() {
    echo "check.sh: $*" >&2
    exit 1
}

# The firmware's target, for the toolchain that builds it (the one of its directory).
target=thumbv7em-none-eabihf
libdir=$(cd "$here" && rustc --print target-libdir --target "$target" 2>/dev/null) || libdir=
if [[ -z $libdir || ! -d $libdir ]]; then
    command -v rustup >/dev/null || die "the $target target is not installed, and there is no rustup to add it"
    (cd "$here" && rustup target add "$target") >&2 || die "rustup could not add the $target target"
fi

python=${PYTHON:-$root/.venv/bin/python}
[[ -x $python ]] || python=python3
ferrolink=${FERROLINK:-$root/target/debug/ferrolink}
if [[ -z ${FERROLINK:-} && ! -x $ferrolink ]]; then
    (cd "$root" && locked cargo build --quiet -p ferrolink-cli)
fi
[[ -x $ferrolink ]] || die "$ferrolink is not an executable"

(cd "$here" && locked cargo build --quiet --release)

port=$("$python" -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
log=$(mktemp)
SKIP_BUILD=1 bash "$here/run.sh" "$port" >"$log" 2>&1 &
qemu=$!
stop() {
    kill "$qemu" 2>/dev/null || true
    wait "$qemu" 2>/dev/null || true
    rm -f "$log"
}
trap stop EXIT

# Wait for QEMU's socket (a connection that is closed at once costs the firmware nothing).
for _ in $(seq 50); do
    if "$python" -c 'import socket, sys; socket.create_connection(("127.0.0.1", int(sys.argv[1])), 0.2).close()' "$port" 2>/dev/null; then
        break
    fi
    if ! kill -0 "$qemu" 2>/dev/null; then
        echo "check.sh: QEMU exited:" >&2
        cat "$log" >&2
        exit 1
    fi
    sleep 0.1
done

echo "firmware in QEMU on 127.0.0.1:$port (pid $qemu)"
"$python" "$root/tests/mavlink/firmware_qemu.py" --ferrolink "$ferrolink" --firmware-port "$port" "$@"
