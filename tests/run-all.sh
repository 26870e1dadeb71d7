#!/usr/bin/env bash
# Runs every test of the workspace.
#
# The reference encoder, pymavlink 2.4.50, is installed into .venv first; the conformance tests
# generate their vectors with it, and the MAVLink tool tests compare against it. mavsdk and
# MAVProxy follow, for the router's checks with real ground-station software, and eclipse-zenoh,
# for the fleet test's Zenoh subscriber. Without network the install fails and those tests are skipped
# (and say so); everything else still runs.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! .venv/bin/python -c 'import pymavlink' 2>/dev/null; then
  echo "== installing pymavlink 2.4.50 into .venv"
  if python3 -m venv .venv && .venv/bin/pip install --quiet --disable-pip-version-check pymavlink==2.4.50; then
    :
  else
    echo "warning: pymavlink could not be installed; the pymavlink conformance tests will be skipped"
  fi
fi
if .venv/bin/python -c 'import pymavlink' 2>/dev/null; then
  export FERROLINK_PYTHON="$PWD/.venv/bin/python"
  export FERROLINK_REQUIRE_PYMAVLINK=1
  # Ground-station software for the router's end-to-end checks. MAVProxy without its GUI
  # dependencies (several hundred MB): the console, parameter and tlog parts need none of them.
  if ! .venv/bin/python -c 'import mavsdk, MAVProxy' 2>/dev/null; then
    echo "== installing mavsdk 4.1.0 and MAVProxy 1.8.75 into .venv"
    .venv/bin/pip install --quiet --disable-pip-version-check mavsdk==4.1.0 &&
      .venv/bin/pip install --quiet --disable-pip-version-check --no-deps MAVProxy==1.8.75 pyserial defusedxml ||
      echo "warning: mavsdk or MAVProxy could not be installed; their router checks will be skipped"
  fi
  if .venv/bin/python -c 'import mavsdk, MAVProxy' 2>/dev/null; then
    export FERROLINK_REQUIRE_GCS=1
  fi
  # A Zenoh client we did not write, for the fleet test. (-I: the crate folder zenoh/ in this
  # directory must not pass for the package.)
  if ! .venv/bin/python -I -c 'import zenoh; zenoh.Config' 2>/dev/null; then
    echo "== installing eclipse-zenoh 1.10.2 into .venv"
    .venv/bin/pip install --quiet --disable-pip-version-check eclipse-zenoh==1.10.2 ||
      echo "warning: eclipse-zenoh could not be installed; the fleet test's subscriber checks will be skipped"
  fi
  if .venv/bin/python -I -c 'import zenoh; zenoh.Config' 2>/dev/null; then
    export FERROLINK_REQUIRE_ZENOH=1
  fi
  # HTTP and WebSocket clients we did not write, for the router's web API.
  if ! .venv/bin/python -c 'import requests, aiohttp' 2>/dev/null; then
    echo "== installing requests and aiohttp into .venv"
    .venv/bin/pip install --quiet --disable-pip-version-check requests aiohttp ||
      echo "warning: requests or aiohttp could not be installed; the web API's checks will be skipped"
  fi
  if .venv/bin/python -c 'import requests, aiohttp' 2>/dev/null; then
    export FERROLINK_REQUIRE_HTTP_CLIENTS=1
  fi
fi

# Wireshark's tshark (with Lua 5.2), Lua 5.2 and 5.4 compilers, Chromium and QEMU, from Debian's
# packages: for the generated dissectors' checks, the documentation site's browser check and
# the vehicle firmware's checks.
# Without them (no root, no network) those checks are skipped and say so.
missing=()
command -v tshark >/dev/null 2>&1 || missing+=(tshark)
command -v luac5.2 >/dev/null 2>&1 || missing+=(lua5.2)
command -v luac5.4 >/dev/null 2>&1 || missing+=(lua5.4)
command -v chromium >/dev/null 2>&1 || missing+=(chromium)
# QEMU's Cortex-M4 board and the ARM binutils, for the MAVLink vehicle firmware's checks.
command -v qemu-system-arm >/dev/null 2>&1 || missing+=(qemu-system-arm)
command -v arm-none-eabi-nm >/dev/null 2>&1 || missing+=(binutils-arm-none-eabi)
# A TrueType font for `ferrolink mavlink stats --plot FILE.png`.
dejavu=/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf
[ -f "$dejavu" ] || missing+=(fonts-dejavu-core)
if [ ${#missing[@]} -gt 0 ]; then
  echo "== installing ${missing[*]} from Debian's packages"
  sudo=""
  [ "$(id -u)" = 0 ] || sudo="sudo -n"
  { $sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq \
      --no-install-recommends "${missing[@]}" >/dev/null; } ||
    echo "warning: ${missing[*]} could not be installed; their checks will be skipped"
fi
if command -v tshark >/dev/null 2>&1; then
  export FERROLINK_REQUIRE_TSHARK=1
fi
if command -v chromium >/dev/null 2>&1; then
  export FERROLINK_REQUIRE_CHROMIUM=1
fi
if [ -f "$dejavu" ]; then
  export FERROLINK_REQUIRE_FONTS=1
fi

# io_uring, which the link layer's UDP readers send and wait with where the kernel gives it
# (container sandboxes often refuse it): where a ring can be set up, its tests are required.
if [ "$(uname -s)" = Linux ] && python3 - 2>/dev/null <<'EOF'
import ctypes, os
libc = ctypes.CDLL(None, use_errno=True)
fd = libc.syscall(425, 4, ctypes.create_string_buffer(120))  # io_uring_setup
if fd < 0:
    raise SystemExit(1)
os.close(fd)
EOF
then
  export FERROLINK_REQUIRE_IO_URING=1
fi

# CI never writes snapshots.
export INSTA_UPDATE=no

echo "== the generator as a build.rs uses it (no default features)"
cargo test -p ferrolink-codegen --no-default-features --lib --test lean --quiet

echo "== doc tests"
cargo test --workspace --doc --all-features --quiet

# The Python package, as its users get it: a wheel built with maturin, installed into a fresh
# venv with what its pytest suite compares against (pymavlink 2.4.50, pandas, pyarrow, polars,
# DuckDB),
# and the CLI's Parquet export beside it. Without network (no maturin, no packages) it is
# skipped, and says so.
echo "== the Python package: wheel, fresh venv, pytest"
pyvenv=target/python-tests python_failed=0
if { .venv/bin/python -c 'import maturin' 2>/dev/null ||
     .venv/bin/pip install --quiet --disable-pip-version-check 'maturin>=1.7,<2'; } &&
   rm -rf target/wheels "$pyvenv" &&
   .venv/bin/maturin build --quiet --release -m python/Cargo.toml --out target/wheels &&
   python3 -m venv "$pyvenv" &&
   "$pyvenv/bin/pip" install --quiet --disable-pip-version-check target/wheels/ferrolink-*.whl \
     pymavlink==2.4.50 pytest pandas pyarrow polars duckdb; then
  cargo build --quiet --release -p ferrolink-cli
  # -I and a directory outside the checkout: the installed wheel is tested, not python/.
  (cd "$pyvenv" && FERROLINK_BIN="$OLDPWD/target/release/ferrolink" FERROLINK_REQUIRE_CLI=1 \
    bin/python -I -m pytest -q -p no:cacheprovider "$OLDPWD/python/tests") ||
    { python_failed=1; echo "error: the Python package's tests failed; the Rust tests run all the same" >&2; }
else
  echo "warning: the Python package could not be built or its test packages installed (no network?); its tests are skipped"
fi

echo "== tests"
# The Rust tests run even when the Python suite failed; the run fails if either did, and the
# test runner's summary stays the last thing printed.
rc=0
if cargo nextest --version >/dev/null 2>&1; then
  cargo nextest run --workspace --all-features --no-fail-fast || rc=$?
else
  cargo test --workspace --all-features --no-fail-fast || rc=$?
fi
if [ "$python_failed" = 1 ] && [ "$rc" = 0 ]; then
  rc=1
fi
exit "$rc"
