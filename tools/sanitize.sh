#!/usr/bin/env bash
# Builds the test suite with clang, AddressSanitizer and UndefinedBehaviorSanitizer (the tree of
# tools/fuzz.sh, build-fuzz/: every translation unit instrumented, -O1 -g1) and runs it: any
# out-of-bounds access, use after free, leak, signed overflow or other undefined behaviour fails
# the test that caused it. docs/testing.md: what it covers and how long it takes.
# Usage: tools/sanitize.sh [--skip-long] [LABEL...]   labels are the test folders (expr models
#        estimators diagnosis withheld apps); default: all of them, the whole suite.
#        --skip-long leaves out the tests also labelled "long" (minutes under the sanitizers).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
graybox_install_packages
exclude=()
if [ "${1:-}" = "--skip-long" ]; then
  exclude=(-LE '^long$')
  shift
fi
labels=("$@")
if [ ${#labels[@]} -eq 0 ]; then labels=(expr models estimators diagnosis withheld apps); fi
build="$GRAYBOX_ROOT/build-fuzz"
graybox_configure_sanitized "$build"
for label in "${labels[@]}"; do
  if [ ! -d "$GRAYBOX_ROOT/tests/$label" ]; then
    echo "sanitize.sh: unknown label '$label' (expected one of: expr models estimators diagnosis withheld apps)" >&2
    exit 2
  fi
done
# The command the apps tests run, then the test folders asked for.
if printf '%s\n' "${labels[@]}" | grep -qx apps; then
  cmake --build "$build" -j "$(nproc)" --target graybox
fi
for label in "${labels[@]}"; do
  cmake --build "$build/tests/$label" -j "$(nproc)"
done
regex="^($(IFS='|'; echo "${labels[*]}"))\$"
ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0 \
  UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
  ctest --test-dir "$build" --output-on-failure -j "$(nproc)" -L "$regex" "${exclude[@]}"
