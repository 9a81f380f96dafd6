#!/usr/bin/env bash
# Set up, build, and run the whole test suite: the Release build with all tests, a format check,
# an AddressSanitizer + UndefinedBehaviorSanitizer build of the libexpr tests, and a consumer
# project built against the installed package.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
graybox_install_packages
jobs=$(nproc)

echo "== format check"
"$GRAYBOX_ROOT/tools/check_format.sh"

echo "== Release build and tests"
graybox_build "$GRAYBOX_ROOT/build"
ctest --test-dir "$GRAYBOX_ROOT/build" --output-on-failure -j "$jobs"

echo "== AddressSanitizer + UndefinedBehaviorSanitizer build of the libexpr tests"
graybox_build "$GRAYBOX_ROOT/build-asan" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DGRAYBOX_SANITIZE=ON \
  -DGRAYBOX_BUILD_BENCHMARKS=OFF -DGRAYBOX_BUILD_EXAMPLES=OFF
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
  ctest --test-dir "$GRAYBOX_ROOT/build-asan" --output-on-failure -j "$jobs" -L expr

echo "== install and find_package(graybox) consumer"
prefix="$GRAYBOX_ROOT/build/install-test"
rm -rf "$prefix" "$GRAYBOX_ROOT/build/consumer"
cmake --install "$GRAYBOX_ROOT/build" --prefix "$prefix" >/dev/null
cmake -S "$GRAYBOX_ROOT/tests/consumer" -B "$GRAYBOX_ROOT/build/consumer" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$GRAYBOX_ROOT/build/consumer" -j "$jobs"
"$GRAYBOX_ROOT/build/consumer/consumer"
echo "== all checks passed"
