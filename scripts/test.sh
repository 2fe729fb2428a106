#!/usr/bin/env bash
# Set up (install what is missing, build) and run the whole test suite.
# Heavy stress runs stay behind PBGI_STRESS=1.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
T0=$(date +%s)
"$ROOT/scripts/setup.sh"
cd "$ROOT/build"
ctest --output-on-failure -j "${PBGI_TEST_JOBS:-2}" "$@"
# Opt-in sanitizer step (a separate clang build): each libFuzzer target under
# ASan+UBSan for a few seconds from its seed corpus.
if [ "${PBGI_CI_SANITIZERS:-0}" = 1 ]; then
  "$ROOT/scripts/fuzz.sh" "${PBGI_FUZZ_SECONDS:-10}"
fi
echo "[test] total $(( $(date +%s) - T0 )) s"
