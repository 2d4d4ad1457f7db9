#!/usr/bin/env bash
# Benchmark: one tire x pressure full fit (spring rate, PAC2002 incl. the de-lagged refit,
# relaxation, thermal) on one core, through the real `tirebase fit` command.
#
# Builds a virtual demo round (default realism), ingests it, runs `tirebase fit --jobs 1` and
# prints the per-group `timing:` lines (wall time per stage, PAC2002 fits and model
# evaluations). "all stages" excludes `load` (reading Parquet; slow in debug builds, where
# polars is not optimised); the fitting code (tirebase-core) is built at opt-level 3 even in
# debug. Usage: tests/benches/fit_group.sh [path/to/tirebase] (default: cargo run).
# Env: SIZE=demo|full (default demo; full = the 12 tire/rim round, 48 groups).
set -euo pipefail
BIN=${1:-}
if [[ -z "$BIN" ]]; then
  cargo build -q
  BIN="${CARGO_TARGET_DIR:-target}/debug/tirebase"
fi
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
"$BIN" synth round --size "${SIZE:-demo}" --out "$WORK/round" 2>/dev/null
"$BIN" ingest "$WORK/round/raw" --store "$WORK/store" --catalog "$WORK/round/catalog.toml" 2>/dev/null
"$BIN" fit --store "$WORK/store" --out "$WORK/out" --jobs 1 2>&1 | grep '^timing:'
