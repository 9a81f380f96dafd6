#!/usr/bin/env bash
# The main job: set up, build, and run graybox on the shipped default problem.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
graybox_install_packages
graybox_build "$GRAYBOX_ROOT/build"
"$GRAYBOX_ROOT/build/examples/expr_hello"
