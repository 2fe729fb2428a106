#!/usr/bin/env bash
# Daemon-level out-of-core render: starts pbgid with a page cache budget,
# renders SCENE once (cold: builds or opens the page set, fills the cache)
# and again (warm), and reports the warm render's wall time, the daemon's
# CPU seconds during it (utime + stime from /proc) and the daemon's status
# (page cache counters). The page set lives in CACHE_DIR and is shared by
# every budget (the build key does not depend on the budget).
#
#   scripts/ooc_render.sh SCENE.usda CACHE_DIR SPACING BUDGET [WIDTH HEIGHT [METHOD]]
#
# e.g. scripts/ooc_render.sh /work/tmp/city/city.usda /work/tmp/city/cache 0.05 8MiB 64 48 fpbgi
# BUDGET "0" means unlimited (the daemon's default budget is not used).
# JOBS (environment, default 4 as `pbgi render`): tile requests in flight.
# RENDER_ARGS (environment): more `pbgi render` flags, word-split (e.g.
# "--upper-page-levels 10": a build option, so another page set).
# DAEMON_ARGS (environment): more `pbgid` flags, word-split (e.g.
# "--max-surfels 0" for a set above the default limit of 200 M surfels).
# CACHE_ONLY=1 (environment): BUDGET is the page cache's budget alone
# (--page-cache-limit under an unbounded --memory-budget), whatever the
# scene is charged: "1/8 of the page set" means a page cache of 1/8 of its
# bytes on disk, while --memory-budget bounds the whole daemon.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SCENE="$(realpath "$1")"
CACHE="$2"
SPACING="$3"
BUDGET="$4"
WIDTH="${5:-64}"
HEIGHT="${6:-48}"
METHOD="${7:-fpbgi}"
PBGID="${PBGID:-$ROOT/build/bin/pbgid}"
PBGI="${PBGI:-$ROOT/build/bin/pbgi}"

mkdir -p "$CACHE"
CACHE="$(realpath "$CACHE")"
SOCK="$CACHE/ooc-$$.sock"
LOG="$CACHE/ooc-$$.log"
[ "$BUDGET" = 0 ] && BUDGET=1TiB
args=(--memory-budget "$BUDGET")
if [ "${CACHE_ONLY:-0}" = 1 ] && [ "$BUDGET" != 1TiB ]; then
  args=(--memory-budget 1TiB --page-cache-limit "$BUDGET")
fi
nice -n 10 "$PBGID" --listen "unix:$SOCK" --scene-root "$(dirname "$SCENE")" --cache-dir "$CACHE" \
  "${args[@]}" ${DAEMON_ARGS:-} 2>"$LOG" &
daemon=$!
trap 'kill -TERM "$daemon" 2>/dev/null || true; wait "$daemon" 2>/dev/null || true; rm -f "$SOCK"' EXIT
for _ in $(seq 100); do [ -S "$SOCK" ] && break; sleep 0.1; done

cpu_ticks() { awk '{print $14 + $15}' "/proc/$daemon/stat"; }
render() {
  "$PBGI" render --server "unix:$SOCK" "$SCENE" --camera /World/Camera --surfel-spacing "$SPACING" \
    --width "$WIDTH" --height "$HEIGHT" --method "$METHOD" --jobs "${JOBS:-4}" ${RENDER_ARGS:-} -q -o "$CACHE/ooc-$1.exr" >/dev/null
}
render cold
# The cache counters after the cold render (warm = final - these).
"$PBGI" status --server "unix:$SOCK" | grep -i "^cache" | sed 's/^/after cold: /' || true
# STRESS=DURATION (environment, e.g. 60s): instead of warm renders, `pbgi
# stress` with CLIENTS (default 8) clients for DURATION, random TILE x TILE
# tiles (default 16) of the WIDTH x HEIGHT image, the render's spacing and
# method; its JSON report (throughput, latency percentiles, errors, the
# daemon's peak RSS) is
# printed, then the cache counters.
if [ -n "${STRESS:-}" ]; then
  "$PBGI" stress --server "unix:$SOCK" --scene "$SCENE" --camera /World/Camera --surfel-spacing "$SPACING" \
    --method "$METHOD" --clients "${CLIENTS:-8}" --duration "$STRESS" --image "${WIDTH}x${HEIGHT}" \
    --tile "${TILE:-16}" --daemon-pid "$daemon" --json -q || true
  "$PBGI" status --server "unix:$SOCK" | grep -i "cache\|page\|hit\|miss\|read\|held\|budget" || true
awk '/^VmHWM/ {printf "daemon peak RSS %.3f GiB (VmHWM)\n", $2 / 1048576}' "/proc/$daemon/status" || true
  exit 0
fi
# WARM (environment, default 1): warm renders, each reported on its own
# line (take the median).
# DROP_OS_CACHE=1 (environment): before each warm render, ask the kernel to
# drop the page files from its page cache (posix_fadvise DONTNEED, no root
# needed), so that the render's misses start from the disk, not from memory
# the budget does not count.
drop_os_cache() {
  find "$CACHE" -name '*.pbgp' -print0 | xargs -0 -r python3 -c '
import os, sys
for p in sys.argv[1:]:
    fd = os.open(p, os.O_RDONLY)
    os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
    os.close(fd)'
}
hz=$(getconf CLK_TCK)
for n in $(seq "${WARM:-1}"); do
  [ "${DROP_OS_CACHE:-0}" = 1 ] && drop_os_cache
  ticks0=$(cpu_ticks)
  start=$(date +%s.%N)
  render warm
  end=$(date +%s.%N)
  ticks1=$(cpu_ticks)
  awk -v s="$start" -v e="$end" -v t0="$ticks0" -v t1="$ticks1" -v hz="$hz" -v b="$BUDGET" -v w="$WIDTH" -v h="$HEIGHT" -v n="$n" \
    'BEGIN { printf "warm render %d budget %s, %dx%d: %.1f s wall, %.2f s daemon CPU\n", n, b, w, h, e - s, (t1 - t0) / hz }'
done
"$PBGI" status --server "unix:$SOCK" | grep -i "cache\|page\|hit\|miss\|read\|held\|budget" || true
awk '/^VmHWM/ {printf "daemon peak RSS %.3f GiB (VmHWM)\n", $2 / 1048576}' "/proc/$daemon/status" || true
