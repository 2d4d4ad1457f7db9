#!/usr/bin/env bash
# Benchmark (issue 7, "Done when"): a `full` virtual round (12 tire/rim combinations) through
# `tirebase run` end to end, in release, with wall time and peak RSS (/usr/bin/time -v), then the
# no-change rerun ("up to date", target < 1 s).
#
# Targets: end to end < 2 min wall and < 2 GiB peak RSS on 2 cores (JOBS=2).
# Usage: tests/benches/full_round.sh [path/to/release/tirebase]
#   (default: builds `cargo build --release --bin tirebase`; a cold release build of polars
#   takes ~30 min). Env: JOBS (default 2), KEEP=1 keeps the work directory.
set -euo pipefail
cd "$(dirname "$0")/../.."
BIN=${1:-}
if [[ -z "$BIN" ]]; then
  cargo build --release --bin tirebase
  BIN="${CARGO_TARGET_DIR:-target}/release/tirebase"
fi
JOBS=${JOBS:-2}
WORK=$(mktemp -d)
if [[ "${KEEP:-0}" != 1 ]]; then trap 'rm -rf "$WORK"' EXIT; else echo "work dir: $WORK"; fi

echo "== synth round --size full"
"$BIN" synth round --size full --out "$WORK/round" --jobs "$JOBS"

measure() { # label, log file, command...
  local label=$1 log=$2; shift 2
  set +e
  /usr/bin/time -v "$@" 2>"$log"
  local code=$?
  set -e
  local wall rss
  wall=$(sed -n 's/^\s*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$log")
  rss=$(sed -n 's/^\s*Maximum resident set size (kbytes): //p' "$log")
  printf '%-22s exit %s  wall %s  peak RSS %.1f MiB\n' "$label" "$code" "$wall" "$(echo "$rss / 1024" | bc -l)"
  return 0
}

echo "== tirebase run (cold store, --jobs $JOBS)"
measure "run (full round)" "$WORK/run1.log" \
  "$BIN" run --input "$WORK/round" --store "$WORK/store" --jobs "$JOBS"
grep -E '^(published|  )' "$WORK/run1.log" | grep -v -E '^\s+(Command|User|System|Percent|Elapsed|Average|Maximum|Major|Minor|Voluntary|Involuntary|Swaps|File|Socket|Signals|Page|Exit)' || true

echo "== tirebase run again (nothing changed)"
measure "run (up to date)" "$WORK/run2.log" \
  "$BIN" run --input "$WORK/round" --store "$WORK/store" --jobs "$JOBS"
grep -m1 'up to date' "$WORK/run2.log" || { echo "ERROR: second run was not up to date"; exit 1; }
