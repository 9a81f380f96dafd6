#!/usr/bin/env bash
# Builds the libFuzzer harnesses of tests/fuzz with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer in build-fuzz/, and runs each for SECONDS (default 60), two at a time
# on a 2-core machine (nproc at a time), from the seeds of shipped files. Exits nonzero when a
# harness finds an input that crashes, leaks, overflows, allocates past the limit or throws an
# exception other than a located rejection (tests/fuzz/fuzz_common.h); the input is saved in
# build-fuzz/findings/. docs/fuzzing.md: what each harness covers and how to replay a finding.
# Usage: tools/fuzz.sh [SECONDS] [HARNESS...]   (harnesses: problem_file csv mat parameter_file
#        equation; default all). libFuzzer's seed is GRAYBOX_FUZZ_SEED (default 1), so that a run
#        from the same corpus repeats; set another to explore further.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
graybox_install_packages
seconds=${1:-60}
shift || true
harnesses=("$@")
if [ ${#harnesses[@]} -eq 0 ]; then harnesses=(problem_file csv mat parameter_file equation); fi

build="$GRAYBOX_ROOT/build-fuzz"
graybox_configure_sanitized "$build"
targets=(--target make_mat_seeds)
for h in "${harnesses[@]}"; do targets+=(--target "${h}_fuzzer"); done
cmake --build "$build" -j "$(nproc)" "${targets[@]}"

# Seeds: shipped files (read only), plus MAT files written by graybox's own writer.
mkdir -p "$build/seeds/mat" "$build/findings"
"$build/tests/fuzz/make_mat_seeds" "$build/seeds/mat"
seeds_of() {
  case $1 in
    problem_file) echo "$GRAYBOX_ROOT/problems" ;;
    csv) echo "$GRAYBOX_ROOT/problems/equations" ;;
    mat) echo "$build/seeds/mat" ;;
    parameter_file) echo "$GRAYBOX_ROOT/tests/fuzz/seeds/parameters" ;;
    equation) echo "$GRAYBOX_ROOT/tests/fuzz/seeds/equations" ;;
    *) echo "fuzz.sh: unknown harness '$1'" >&2; return 1 ;;
  esac
}

run_one() {
  local h=$1 corpus="$build/corpus/$1"
  mkdir -p "$corpus"
  touch "$build/${h}.started"
  # The working corpus (new inputs go there) first, then the read-only seeds.
  if ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0 \
    UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    "$build/tests/fuzz/${h}_fuzzer" "$corpus" "$(seeds_of "$h")" -max_total_time="$seconds" \
    -seed="${GRAYBOX_FUZZ_SEED:-1}" -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=20 \
    -max_len=65536 -print_final_stats=1 \
    -artifact_prefix="$build/findings/${h}-" >"$build/${h}.log" 2>&1; then
    echo "fuzz: $h: no finding in ${seconds} s ($(grep -m1 -o 'stat::number_of_executed_units: *[0-9]*' "$build/${h}.log" | grep -o '[0-9]*$') runs)"
  else
    echo "fuzz: $h: FINDING (log: $build/${h}.log, input: $build/findings/${h}-*)" >&2
    tail -40 "$build/${h}.log" >&2
    # The input itself, so that a finding in a CI run whose tree is gone can be replayed:
    # base64 -d > input, then the harness on it (docs/fuzzing.md).
    for f in $(find "$build/findings" -name "${h}-*" -newer "$build/${h}.started"); do
      if [ "$(stat -c %s "$f")" -le 65536 ]; then
        echo "fuzz: $h: $(basename "$f") as base64:" >&2
        base64 -w 0 "$f" >&2
        echo >&2
      fi
    done
    return 1
  fi
}

failed=0
pids=()
running=0
for h in "${harnesses[@]}"; do
  seeds_of "$h" >/dev/null
  run_one "$h" &
  pids+=($!)
  running=$((running + 1))
  if [ "$running" -ge "$(nproc)" ]; then
    wait -n || failed=1
    running=$((running - 1))
  fi
done
while [ "$running" -gt 0 ]; do
  wait -n || failed=1
  running=$((running - 1))
done
exit "$failed"
