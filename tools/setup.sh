#!/usr/bin/env bash
# graybox set-up: installs missing Debian 12 packages (when root), then configures and builds.
# Usage: tools/setup.sh [build-dir] [extra cmake args...]
# Sourced by tools/main.sh and tools/test.sh; safe to run repeatedly.
set -euo pipefail

GRAYBOX_PACKAGES=(
  g++ make cmake pkg-config git clang-format
  libeigen3-dev coinor-libipopt-dev libceres-dev libsuitesparse-dev libsundials-dev
  libmatio-dev libhdf5-dev zlib1g-dev libgtest-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev libtomlplusplus-dev
  # Tests only: headless rendering of report.html (tests/diagnosis/report_html_test.cc).
  chromium
  # Tests only: the libFuzzer harnesses and the sanitizer build (tools/fuzz.sh, tools/sanitize.sh).
  clang libclang-rt-14-dev
  # Tests only: a single-node Slurm cluster for graybox bench --slurm (tools/slurm_test.sh), and
  # jq to compare its records with a local run's.
  slurm-wlm munge jq
)

graybox_install_packages() {
  local missing=()
  for p in "${GRAYBOX_PACKAGES[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
      missing+=("$p")
    fi
  done
  if [ ${#missing[@]} -eq 0 ]; then
    return 0
  fi
  if [ "$(id -u)" -ne 0 ]; then
    echo "graybox: missing Debian packages: ${missing[*]}" >&2
    echo "graybox: run as root, or install them with: sudo apt-get install ${missing[*]}" >&2
    exit 1
  fi
  echo "graybox: installing ${#missing[@]} missing packages: ${missing[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# graybox_build DIR [cmake configure arguments...]: configures a Release build in DIR and builds
# every target, or only the targets named in GRAYBOX_TARGETS (space-separated).
graybox_build() {
  local build_dir=$1
  shift
  cmake -S "$GRAYBOX_ROOT" -B "$build_dir" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
  local targets=()
  for t in ${GRAYBOX_TARGETS:-}; do targets+=(--target "$t"); done
  cmake --build "$build_dir" -j "$(nproc)" "${targets[@]}"
}

# graybox_configure_sanitized DIR: configures DIR as the clang build of tools/fuzz.sh and
# tools/sanitize.sh: AddressSanitizer + UndefinedBehaviorSanitizer and libFuzzer's coverage
# instrumentation on every translation unit (-O1 -g1), the harnesses and the tests (built only as
# targets are asked for), no benchmarks or examples.
graybox_configure_sanitized() {
  cmake -S "$GRAYBOX_ROOT" -B "$1" -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" \
    -DGRAYBOX_FUZZ=ON -DGRAYBOX_WERROR=OFF -DGRAYBOX_BUILD_TESTS=ON \
    -DGRAYBOX_BUILD_BENCHMARKS=OFF -DGRAYBOX_BUILD_EXAMPLES=OFF >/dev/null
}

GRAYBOX_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
if [ "${BASH_SOURCE[0]}" = "$0" ]; then
  graybox_install_packages
  graybox_build "${1:-$GRAYBOX_ROOT/build}" "${@:2}"
fi
