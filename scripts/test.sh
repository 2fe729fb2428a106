#!/usr/bin/env bash
# Set up (install what is missing, build with warnings as errors), lint
# the change and run the whole test suite.
# Heavy stress runs stay behind PBGI_STRESS=1.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
T0=$(date +%s)
PBGI_CMAKE_ARGS="-DPBGI_WERROR=ON ${PBGI_CMAKE_ARGS:-}" "$ROOT/scripts/setup.sh"
# clang-format and clang-tidy on the lines changed since main (or the last
# commit's, on a clean clone of main): scripts/lint.sh. PBGI_LINT=0 skips it.
if [ "${PBGI_LINT:-1}" = 1 ]; then
  "$ROOT/scripts/lint.sh"
fi
cd "$ROOT/build"
ctest --output-on-failure -j "${PBGI_TEST_JOBS:-2}" "$@"
# Sanitizer step (separate clang builds, scripts/sanitizers.sh): the fuzz
# targets under ASan+UBSan for a few seconds each, clients leaving an
# instrumented daemon, the service's tests under TSan. PBGI_SANITIZERS=0
# skips it (a quick local run).
if [ "${PBGI_SANITIZERS:-1}" = 1 ]; then
  "$ROOT/scripts/sanitizers.sh" "${PBGI_FUZZ_SECONDS:-10}"
fi
echo "[test] total $(( $(date +%s) - T0 )) s"
