#!/usr/bin/env bash
# A golden-metric regression test (tests/golden/CMakeLists.txt, docs/bench.md "Golden metrics"):
# runs SUITE with `graybox bench` into OUT and compares it with BASELINE. Exit: 0 when every value
# is within the suite's tolerances, 4 on a regression (the findings and the command that accepts
# the run are printed), 1 when the run itself failed, 77 (skipped) without the shared data.
#   run_golden.sh GRAYBOX SUITE BASELINE OUT JOBS DATA_DIR
set -uo pipefail
graybox=$1 suite=$2 baseline=$3 out=$4 jobs=$5 data=$6
if [ ! -d "$data/emps" ]; then
  echo "skipped: no shared data at $data"
  exit 77
fi
if ! "$graybox" bench "$suite" --out "$out" --jobs "$jobs" >"$out.log" 2>&1; then
  tail -n 30 "$out.log"
  echo "golden: graybox bench $suite failed (log: $out.log)"
  exit 1
fi
grep -E '^[0-9]+ cases, ' "$out.log"
"$graybox" bench compare "$out" --baseline "$baseline"
