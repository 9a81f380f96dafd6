#!/usr/bin/env bash
# Set up, build, and run the whole test suite: a format check, the Release build with all tests,
# the Slurm test (a single-node cluster on localhost runs a suite as a job array and its merge),
# a clang AddressSanitizer + UndefinedBehaviorSanitizer build that runs the readers' libFuzzer
# harnesses for 60 s each (tools/fuzz.sh) and the libexpr tests (tools/sanitize.sh),
# and a consumer project built against the installed package. docs/testing.md.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
graybox_install_packages
jobs=$(nproc)
log_dir=$(mktemp -d)
trap 'rm -rf "$log_dir"' EXIT

echo "== format check"
"$GRAYBOX_ROOT/tools/check_format.sh"

echo "== Release build and tests (all but the full golden-metric set, label golden_full)"
graybox_build "$GRAYBOX_ROOT/build"
ctest --test-dir "$GRAYBOX_ROOT/build" --output-on-failure -j "$jobs" -LE golden_full | tee "$log_dir/release.log"

echo "== graybox bench --slurm on a single-node Slurm cluster started here (tools/slurm_test.sh)"
bash "$GRAYBOX_ROOT/tools/slurm_test.sh" "$GRAYBOX_ROOT/build"

echo "== clang AddressSanitizer + UndefinedBehaviorSanitizer build (build-fuzz/): the readers' fuzzers"
# Each harness for 60 s from the shipped seeds (a finding fails the run and prints the input).
bash "$GRAYBOX_ROOT/tools/fuzz.sh" 60
echo "== the same build: the libexpr tests under the sanitizers"
# The whole suite under the sanitizers is tools/sanitize.sh without labels (docs/testing.md); CI
# runs the folder that fits its 30 minutes beside the Release suite.
bash "$GRAYBOX_ROOT/tools/sanitize.sh" --skip-long expr | tee "$log_dir/asan.log"

echo "== install and find_package(graybox) consumer"
prefix="$GRAYBOX_ROOT/build/install-test"
rm -rf "$prefix" "$GRAYBOX_ROOT/build/consumer"
cmake --install "$GRAYBOX_ROOT/build" --prefix "$prefix" >/dev/null
cmake -S "$GRAYBOX_ROOT/tests/consumer" -B "$GRAYBOX_ROOT/build/consumer" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$GRAYBOX_ROOT/build/consumer" -j "$jobs"
"$GRAYBOX_ROOT/build/consumer/consumer"
# A user's own block from a plugin (tests/consumer/user_blocks.cc), fitted by the installed
# command: the cubic stiffness k3 (truth 200 N/m^3, from 100) within 2 %.
"$prefix/bin/graybox" fit "$GRAYBOX_ROOT/build/consumer/plugin_problem.toml" \
  --out "$GRAYBOX_ROOT/build/consumer/plugin_out" >"$log_dir/plugin.log" 2>&1 ||
  { cat "$log_dir/plugin.log"; echo "plugin fit failed"; exit 1; }
k3=$(grep -A1 '"spring.k3": {' "$GRAYBOX_ROOT/build/consumer/plugin_out/result.json" |
  sed -n 's/.*"value": \([-0-9.eE+]*\).*/\1/p')
awk -v k3="$k3" 'BEGIN { d = k3 / 200 - 1; if (d < 0) d = -d; exit !(d <= 0.02) }' ||
  { echo "plugin fit: k3 = $k3, expected 200 within 2 %"; exit 1; }
echo "consumer plugin: user.cubic_spring fitted, k3 = $k3 N/m^3"
# One closing line over both CTest runs (set -o pipefail has already stopped on any failure).
passed=0
failed=0
for f in "$log_dir"/release.log "$log_dir"/asan.log; do
  line=$(grep -E '^[0-9]+% tests passed, [0-9]+ tests failed out of [0-9]+' "$f" | tail -n 1)
  total=$(sed -E 's/.* out of ([0-9]+)/\1/' <<<"$line")
  bad=$(sed -E 's/.*passed, ([0-9]+) tests failed.*/\1/' <<<"$line")
  passed=$((passed + total - bad))
  failed=$((failed + bad))
done
echo "== all checks passed (format, Release tests, Slurm, fuzzers, sanitizer tests, install consumer)"
echo "tests: $passed passed, $failed failed"
