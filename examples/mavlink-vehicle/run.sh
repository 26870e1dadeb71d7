#!/usr/bin/env bash
# Builds the vehicle firmware and runs it in QEMU's mps2-an386 (Cortex-M4), UART0 on a TCP
# socket.
#
# Usage: bash examples/mavlink-vehicle/run.sh [PORT]
#
# PORT is the argument, else $VEHICLE_PORT, else 5760. QEMU listens on 127.0.0.1:PORT for one
# client at a time, which may come and go (while none is connected, what the firmware sends is
# dropped). Talk to it with `ferrolink mavlink ... tcpout://127.0.0.1:PORT`, or put
# `ferrolink mavlink router tcpout://127.0.0.1:PORT udpin://...` in front for several clients.
#
# QEMU runs with -nographic and no monitor, does not read stdin and prints nothing, so the
# script can run in the background from a test. It execs QEMU, whose process id is then the
# script's:
#
#   bash examples/mavlink-vehicle/run.sh 5760 & qemu=$!
#   ...
#   kill "$qemu"
#
# Environment:
#   VEHICLE_PORT         the port when no argument is given (default 5760)
#   QEMU                 the emulator (default qemu-system-arm)
#   SKIP_BUILD=1         run the firmware as last built, without cargo
#   FERROLINK_CARGO_LOCK lock file serialising cargo runs (default: /tmp/ferrolink-cargo.lock);
#                        flock is skipped when it is not installed.
set -euo pipefail
cd "$(dirname "$0")"

port=${1:-${VEHICLE_PORT:-5760}}
qemu=${QEMU:-qemu-system-arm}
elf=${CARGO_TARGET_DIR:-target}/thumbv7em-none-eabihf/release/ferrolink-example-mavlink-vehicle
lock=${FERROLINK_CARGO_LOCK:-/tmp/ferrolink-cargo.lock}

die() {
    echo "run.sh: $*" >&2
    exit 1
}

[[ $port =~ ^[0-9]+$ ]] || die "not a port: $port"
command -v "$qemu" >/dev/null || die "$qemu not found (install qemu-system-arm)"

if [[ ${SKIP_BUILD:-0} != 1 ]]; then
    if command -v flock >/dev/null; then
        flock "$lock" cargo build --quiet --release
    else
        cargo build --quiet --release
    fi
fi
[[ -f $elf ]] || die "$elf not found (build it first)"

# nodelay: the UART writes a byte at a time; without it each small TCP segment can wait for
# the peer's delayed ACK (40 ms), and a 100-item mission takes seconds instead of a fraction.
exec "$qemu" -M mps2-an386 -nographic -monitor none \
    -serial "tcp:127.0.0.1:$port,server=on,wait=off,nodelay=on" \
    -kernel "$elf" </dev/null
