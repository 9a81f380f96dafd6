#!/usr/bin/env bash
# The main job: set up, build, and run graybox on the shipped default problem.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
graybox_install_packages
# Only the command-line tool: the tests, benchmarks and examples are tools/test.sh's.
GRAYBOX_TARGETS=graybox graybox_build "$GRAYBOX_ROOT/build"
cd "$GRAYBOX_ROOT"
"$GRAYBOX_ROOT/build/apps/graybox" fit problems/emps/emps_idim.toml --out out/emps_idim
