#!/usr/bin/env bash
# Sets up the Python log readers we compare against in a venv of their own (target/bench-python),
# builds and installs our wheel beside them, and runs logs.py: one table, the machine printed.
#
#   bash benches/python/run.sh [--size-mb N]
set -euo pipefail
cd "$(dirname "$0")/../.."
venv=target/bench-python
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
pip=("$venv/bin/pip" install --quiet --disable-pip-version-check)
# pymavlog holds numpy below 2, which pyarrow 22 and later refuse.
"${pip[@]}" 'maturin>=1.7,<2' pymavlink==2.4.50 pymavlog==0.4.2 mavkit==0.3.0 pandas 'pyarrow<22'
# fasttlogparser builds its C++ from source, with the build tools of the venv.
"$venv/bin/python" -c 'import fasttlogparser' 2>/dev/null || {
  "${pip[@]}" scikit-build-core pybind11 cmake ninja &&
    "${pip[@]}" --no-build-isolation fasttlogparser==1.1.1
} || echo "note: fasttlogparser could not be built; its rows say so"
rm -rf target/bench-wheels
"$venv/bin/maturin" build --quiet --release -m python/Cargo.toml --out target/bench-wheels
"${pip[@]}" --force-reinstall --no-deps target/bench-wheels/ferrolink-*.whl
exec "$venv/bin/python" benches/python/logs.py "$@"
