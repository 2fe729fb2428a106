#!/usr/bin/env bash
# Set up (install what is missing, build) and run the whole test suite.
# Heavy stress runs stay behind PBGI_STRESS=1.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
T0=$(date +%s)
"$ROOT/scripts/setup.sh"
cd "$ROOT/build"
ctest --output-on-failure -j "${PBGI_TEST_JOBS:-2}" "$@"
echo "[test] total $(( $(date +%s) - T0 )) s"
