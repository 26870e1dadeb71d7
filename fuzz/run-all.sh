#!/usr/bin/env bash
# Runs every fuzz target (or those named) for SECONDS each, starting from the seed corpus in
# seeds/TARGET and the corpus kept in corpus/TARGET, and fails if any target crashes.
#
#   bash fuzz/run-all.sh [SECONDS] [TARGET...]      # SECONDS defaults to 30
#   FUZZ_JOBS=2 bash fuzz/run-all.sh 600            # a release campaign, two targets at a time
#
# Needs a nightly toolchain and cargo-fuzz. Prints a table: runs, coverage (edges), features,
# corpus size and the result per target; crash inputs land in artifacts/TARGET/.
set -euo pipefail
cd "$(dirname "$0")"
seconds=${1:-30}
shift || true
if [ $# -gt 0 ]; then
  targets=("$@")
else
  mapfile -t targets < <(cargo +nightly fuzz list)
fi
jobs=${FUZZ_JOBS:-1}
mkdir -p logs
echo "== building ${#targets[@]} fuzz target(s)"
cargo +nightly fuzz build -O >/dev/null

run_one() {
  local target=$1 seconds=$2
  mkdir -p "corpus/$target"
  local dirs=("corpus/$target")
  [ -d "seeds/$target" ] && dirs+=("seeds/$target")
  if cargo +nightly fuzz run -O "$target" "${dirs[@]}" -- \
      -max_total_time="$seconds" -print_final_stats=1 >"logs/$target.log" 2>&1; then
    echo "ok" >"logs/$target.result"
  else
    echo "CRASH" >"logs/$target.result"
  fi
}
export -f run_one
printf '%s\n' "${targets[@]}" | xargs -P "$jobs" -I{} bash -c "run_one {} $seconds"

failed=0
printf '\n%-18s %12s %8s %8s %8s  %s\n' target runs cov ft corpus result
for t in "${targets[@]}"; do
  log="logs/$t.log"
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  line=$(grep -E '^#[0-9]+' "$log" | grep -E 'cov: [0-9]+' | tail -1)
  cov=$(grep -o 'cov: [0-9]*' <<<"$line" | grep -o '[0-9]*' || true)
  ft=$(grep -o 'ft: [0-9]*' <<<"$line" | grep -o '[0-9]*' || true)
  corpus=$(grep -o 'corp: [0-9]*' <<<"$line" | grep -o '[0-9]*' || true)
  result=$(cat "logs/$t.result")
  printf '%-18s %12s %8s %8s %8s  %s\n' "$t" "${runs:-?}" "${cov:-?}" "${ft:-?}" "${corpus:-?}" "$result"
  if [ "$result" != ok ]; then
    failed=1
    grep -E 'panicked|ERROR|Test unit written' "$log" | head -5 || true
  fi
done
exit $failed
