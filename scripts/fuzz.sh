#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz) in a separate clang build with
# AddressSanitizer + UndefinedBehaviorSanitizer, and runs each for SECONDS
# starting from its seed corpus (tests/fuzz/corpus/<target>/).
#
#   scripts/fuzz.sh [SECONDS=60] [TARGET...]
#
# The build dir is build-fuzz/ (PBGI_FUZZ_BUILD_DIR overrides); inputs the
# fuzzer finds go to a scratch corpus there (the committed seeds stay
# small). A crash leaves its input in build-fuzz/fuzz/artifacts/<target>/:
# copy it to tests/fuzz/regressions/<target>/ so the replay test keeps
# checking it. A summary (executions, exec/s, crashes per target) is printed
# and written to build-fuzz/fuzz/report.txt. Exit 1 if any target crashed.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECONDS_PER_TARGET="${1:-60}"
shift || true
TARGETS=("$@")
((${#TARGETS[@]})) || TARGETS=(fuzz_gather_request fuzz_page_reader fuzz_scene_stream fuzz_scene_entry fuzz_daemon_config)
BUILD="${PBGI_FUZZ_BUILD_DIR:-$ROOT/build-fuzz}"
CXX="${PBGI_FUZZ_CXX:-clang++-14}"
CC="${PBGI_FUZZ_CC:-clang-14}"
JOBS="${PBGI_JOBS:-2}"
export CCACHE_BASEDIR="$ROOT" CCACHE_NOHASHDIR=1

# libFuzzer ships with clang's runtime: check before a long build.
probe="$(mktemp -d)"
echo 'extern "C" int LLVMFuzzerTestOneInput(const unsigned char*, unsigned long) { return 0; }' > "$probe/p.cpp"
if ! "$CXX" -fsanitize=fuzzer,address,undefined "$probe/p.cpp" -o "$probe/p" 2> "$probe/err"; then
  echo "fuzz.sh: $CXX cannot link libFuzzer:"; cat "$probe/err"; rm -rf "$probe"; exit 2
fi
rm -rf "$probe"

LOGS="$BUILD/fuzz"
mkdir -p "$LOGS"
SAN="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER="$CC" -DCMAKE_CXX_COMPILER="$CXX" \
  -DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache \
  -DCMAKE_C_FLAGS="$SAN -fsanitize=fuzzer-no-link" -DCMAKE_CXX_FLAGS="$SAN -fsanitize=fuzzer-no-link" \
  -DCMAKE_EXE_LINKER_FLAGS="$SAN" -DPBGI_FUZZ=ON -DPBGI_BUILD_BENCHMARKS=OFF \
  -DPBGI_PYTHON="$ROOT/.venv/bin/python3" > "$LOGS/configure.log" 2>&1 \
  || { cat "$LOGS/configure.log"; exit 2; }

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
REPORT="$BUILD/fuzz/report.txt"
: > "$REPORT"
failed=0
for t in "${TARGETS[@]}"; do
  work="$BUILD/fuzz/corpus/$t"
  art="$BUILD/fuzz/artifacts/$t"
  mkdir -p "$work" "$art"
  seeds="$ROOT/tests/fuzz/corpus/$t"
  regress="$ROOT/tests/fuzz/regressions/$t"
  dirs=("$work")
  [ -d "$seeds" ] && dirs+=("$seeds")
  [ -d "$regress" ] && dirs+=("$regress")
  log="$BUILD/fuzz/$t.log"
  # Built one by one: a target that does not compile is reported, the
  # others still run.
  if ! cmake --build "$BUILD" -j "$JOBS" --target "$t" > "$BUILD/fuzz/$t.build.log" 2>&1; then
    grep -m5 -B2 -A8 'error:' "$BUILD/fuzz/$t.build.log" || tail -20 "$BUILD/fuzz/$t.build.log"
    echo "$t: BUILD FAILED (see $BUILD/fuzz/$t.build.log)" | tee -a "$REPORT"
    failed=1
    continue
  fi
  echo "[fuzz] $t for ${SECONDS_PER_TARGET}s"
  rc=0
  # -rss_limit_mb: the decoders must not allocate without bound either.
  "$BUILD/fuzz/$t" -max_total_time="$SECONDS_PER_TARGET" -print_final_stats=1 \
    -rss_limit_mb=2048 -timeout=10 -max_len=262144 -artifact_prefix="$art/" \
    "${dirs[@]}" > "$log" 2>&1 || rc=$?
  execs=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$log" | awk '{print $2}' | tail -1)
  rate=$(grep -oE 'stat::average_exec_per_sec: *[0-9]+' "$log" | awk '{print $2}' | tail -1)
  crashes=$(find "$art" -type f | wc -l)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | awk '{print $2}')
  line="$t: ${execs:-0} executions, ${rate:-0} exec/s, coverage ${cov:-?}, exit $rc, $crashes crash input(s)"
  echo "[fuzz] $line"
  echo "$line" >> "$REPORT"
  if [ "$rc" -ne 0 ] || [ "$crashes" -gt 0 ]; then
    failed=1
    grep -m1 -A30 -E 'ERROR: (AddressSanitizer|libFuzzer)|runtime error|==ERROR' "$log" || tail -40 "$log"
  fi
done
echo "[fuzz] report: $REPORT"
exit $failed
