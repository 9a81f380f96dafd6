#!/usr/bin/env bash
# Fails when a tracked C++ file differs from .clang-format. Pass --fix to rewrite in place.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
if ! command -v clang-format >/dev/null; then
  if [ "$(id -u)" -eq 0 ]; then
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends clang-format >/dev/null
  else
    echo "check_format: clang-format is missing (apt-get install clang-format)" >&2
    exit 1
  fi
fi
mapfile -t files < <(git ls-files '*.h' '*.cc' '*.cpp' 2>/dev/null || true)
[ ${#files[@]} -eq 0 ] && exit 0
if [ "${1:-}" = "--fix" ]; then
  clang-format -i "${files[@]}"
  exit 0
fi
clang-format --dry-run --Werror "${files[@]}"
echo "check_format: ${#files[@]} files clean"
