#!/usr/bin/env bash
# Sanitizer builds (clang) and their short runs, part of the test command:
#
#   1. ASan + UBSan (build-fuzz/, shared with scripts/fuzz.sh): every
#      libFuzzer target for FUZZ_SECONDS from its seed corpus, then the
#      tests where clients leave mid-request (tests/reliability,
#      ClientLeaves): the instrumented daemon must stop the work, and
#      LeakSanitizer at its exit fails the test if anything was not freed.
#   2. TSan (build-tsan/): the service's tests (scene registry, admission
#      gate, handlers), where requests race by design.
#
#   scripts/sanitizers.sh [FUZZ_SECONDS=10]
#
# Each build compiles only the targets it runs; ccache (scripts/setup.sh)
# makes later runs cheap. Exit 1 if any step fails.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FUZZ_SECONDS="${1:-10}"
JOBS="${PBGI_JOBS:-$(nproc)}"
CXX="${PBGI_SAN_CXX:-clang++-14}"
CC="${PBGI_SAN_CC:-clang-14}"
export CCACHE_BASEDIR="$ROOT" CCACHE_NOHASHDIR=1
log() { printf '\033[1m[sanitizers]\033[0m %s\n' "$*"; }
failed=0

# 1. ASan + UBSan: fuzzing, then clients leaving.
log "ASan+UBSan: fuzz targets, ${FUZZ_SECONDS}s each"
"$ROOT/scripts/fuzz.sh" "$FUZZ_SECONDS" || failed=1
ASAN_BUILD="${PBGI_FUZZ_BUILD_DIR:-$ROOT/build-fuzz}"
log "ASan+UBSan: daemon with clients that leave (build-fuzz)"
if cmake --build "$ASAN_BUILD" -j "$JOBS" --target pbgid pbgi test_reliability_faults \
     > "$ASAN_BUILD/fuzz/reliability.build.log" 2>&1; then
  # The reader process is Python: LeakSanitizer is for the daemon only.
  ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:exitcode=66" \
  UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
    ctest --test-dir "$ASAN_BUILD" --output-on-failure -R 'ClientLeaves' || failed=1
else
  tail -30 "$ASAN_BUILD/fuzz/reliability.build.log"; failed=1
fi

# 2. TSan: the service under concurrent requests, and the page cache that
#    concurrent gathers share.
TSAN_BUILD="${PBGI_TSAN_BUILD_DIR:-$ROOT/build-tsan}"
mkdir -p "$TSAN_BUILD"
log "TSan: service and page cache tests (build-tsan)"
if [ ! -f "$TSAN_BUILD/build.ninja" ]; then
  TSAN="-fsanitize=thread -fno-omit-frame-pointer"
  cmake -S "$ROOT" -B "$TSAN_BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER="$CC" -DCMAKE_CXX_COMPILER="$CXX" \
    -DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache \
    -DCMAKE_C_FLAGS="$TSAN" -DCMAKE_CXX_FLAGS="$TSAN" -DCMAKE_EXE_LINKER_FLAGS="$TSAN" \
    -DPBGI_BUILD_BENCHMARKS=OFF -DPBGI_PYTHON="$ROOT/.venv/bin/python3" \
    > "$TSAN_BUILD/configure.log" 2>&1 || { cat "$TSAN_BUILD/configure.log"; exit 2; }
fi
if cmake --build "$TSAN_BUILD" -j "$JOBS" --target test_server_service test_storage_cache > "$TSAN_BUILD/build.log" 2>&1; then
  # TBB's scheduler is not instrumented: its own hand-offs are suppressed
  # (tests/sanitizers/tsan.supp); races in pbgi code are not.
  for t in test_server_service test_storage_cache; do
    TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$ROOT/tests/sanitizers/tsan.supp" \
      "$TSAN_BUILD/tests/$t" --gtest_brief=1 || failed=1
  done
else
  grep -m5 -B2 -A8 'error:' "$TSAN_BUILD/build.log" || tail -30 "$TSAN_BUILD/build.log"; failed=1
fi

exit $failed
