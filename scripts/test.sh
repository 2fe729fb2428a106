#!/usr/bin/env bash
# Set up (install what is missing, build) and run the whole test suite.
# Heavy stress runs stay behind PBGI_STRESS=1.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
T0=$(date +%s)
"$ROOT/scripts/setup.sh"
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
