#!/usr/bin/env bash
# Runs every fuzz target (or those named) for SECONDS each, starting from the committed corpus
# in corpora/TARGET and the hand-written seeds in seeds/TARGET, and fails if any target crashes.
# New inputs land in corpus/TARGET (not committed), so the committed corpora only change when
# they are refreshed on purpose (FUZZ_MERGE=1, see README.md).
#
#   bash fuzz/run-all.sh [SECONDS] [TARGET...]      # SECONDS defaults to 30
#   FUZZ_JOBS=2 bash fuzz/run-all.sh 1200           # a campaign: 20 min each, two at a time
#   FUZZ_MERGE=1 bash fuzz/run-all.sh 0             # minimize corpus/ + corpora/ into corpora/
#
# A target's extra libFuzzer flags (e.g. a tighter -max_len) live in options/TARGET.
#
# Needs a nightly toolchain and cargo-fuzz. The targets are built once, then their binaries run
# directly, so editing the sources during a campaign changes nothing. Prints a table: runs,
# coverage (edges), features, corpus size and the result per target; crash inputs land in
# artifacts/TARGET/.
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
if [ -z "${FUZZ_NO_BUILD:-}" ]; then
  echo "== building ${#targets[@]} fuzz target(s)"
  cargo +nightly fuzz build -O >/dev/null
fi
bin_dir=$(pwd)/target/$(rustc +nightly -vV | sed -n 's/^host: //p')/release
export bin_dir

run_one() {
  local target=$1 seconds=$2
  mkdir -p "corpus/$target" "artifacts/$target"
  local dirs=("corpus/$target")
  [ -d "corpora/$target" ] && dirs+=("corpora/$target")
  [ -d "seeds/$target" ] && dirs+=("seeds/$target")
  local options=()
  [ -f "options/$target" ] && read -r -a options <"options/$target"
  if [ "$seconds" -gt 0 ] && ! "$bin_dir/$target" -max_total_time="$seconds" -print_final_stats=1 \
      "${options[@]}" -artifact_prefix="artifacts/$target/" "${dirs[@]}" >"logs/$target.log" 2>&1; then
    echo "CRASH" >"logs/$target.result"
    return
  fi
  [ "$seconds" -gt 0 ] || : >"logs/$target.log"
  echo "ok" >"logs/$target.result"
}
export -f run_one
printf '%s\n' "${targets[@]}" | xargs -P "$jobs" -I{} bash -c "run_one {} $seconds"

over_budget=0
# A target's corpus budget: at most this many inputs and bytes (README.md).
budget() {
  case $1 in
    router_config) echo "4000 $((5 * 512 * 1024))" ;;
    *) echo "2500 $((1024 * 1024))" ;;
  esac
}
if [ -n "${FUZZ_MERGE:-}" ]; then
  # What `cargo fuzz cmin` does (a merge into an empty directory), over the campaign's finds and
  # the committed corpus together, with libFuzzer's set-cover merge: the fewest inputs that keep
  # every feature, checked against the target's budget (README.md).
  for t in "${targets[@]}"; do
    fresh=$(mktemp -d)
    dirs=()
    for d in "corpora/$t" "corpus/$t"; do [ -d "$d" ] && dirs+=("$d"); done
    options=()
    [ -f "options/$t" ] && read -r -a options <"options/$t"
    "$bin_dir/$t" -set_cover_merge=1 "${options[@]}" "$fresh" "${dirs[@]}" >"logs/$t.merge.log" 2>&1
    read -r max_inputs max_bytes < <(budget "$t")
    if [ "$(find "$fresh" -type f -printf '%s\n' | awk '{s += $1} END {print s + 0}')" -gt "$max_bytes" ]; then
      # Over the byte budget: merge that again the classic way, smallest inputs first, which
      # keeps almost every feature (router_config: 33,856 of 33,887) in fewer bytes.
      smaller=$(mktemp -d)
      "$bin_dir/$t" -merge=1 "${options[@]}" "$smaller" "$fresh" >>"logs/$t.merge.log" 2>&1
      rm -rf "$fresh"
      fresh=$smaller
    fi
    rm -rf "corpora/$t"
    mkdir -p corpora
    mv "$fresh" "corpora/$t"
    inputs=$(find "corpora/$t" -type f | wc -l)
    bytes=$(find "corpora/$t" -type f -printf '%s\n' | awk '{s += $1} END {print s + 0}')
    echo "$t: $inputs inputs, $((bytes / 1024)) KiB in corpora/$t"
    if [ "$inputs" -gt "$max_inputs" ] || [ "$bytes" -gt "$max_bytes" ]; then
      echo "$t: over the corpus budget ($((max_bytes / 1024)) KiB, $max_inputs inputs)" >&2
      over_budget=1
    fi
  done
fi

failed=0
printf '\n%-18s %12s %8s %8s %8s  %s\n' target runs cov ft corpus result
for t in "${targets[@]}"; do
  log="logs/$t.log"
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1 || true)
  line=$(grep -E '^#[0-9]+' "$log" | grep -E 'cov: [0-9]+' | tail -1 || true)
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
exit $((failed | over_budget))
