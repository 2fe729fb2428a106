#!/usr/bin/env bash
# Builds the page set of one USD scene the way the daemon does (pbgid
# --preload) and measures it: wall time, the build line of the daemon's log
# (surfels/s of sampling+shading and of the tree, bytes/surfel), and the
# peak RSS of the daemon (VmHWM) and of its USD reader child (sampled every
# 0.2 s from /proc, since the child exits before the build ends). The
# daemon's VmHWM is also read when its "read '<scene>'" line appears (end of
# ingest: the stream is decoded, surfel sampling not started), which gives
# the ingest peak to within one sampling period, next to the largest frame
# (chunk) the reader sent; scripts/ingest_memory.sh checks it against the
# bound of issue 3. Likewise at the "ray scene of ... built" line (scene +
# Embree BVH complete, before surfels); with STOP_AFTER_RAY_SCENE=1 the
# daemon is stopped there (instancing measurements: memory of scene + BVH
# without waiting for a surfel build).
#
#   scripts/scale_build.sh SCENE.usda CACHE_DIR SPACING [MEMORY_BUDGET] [SAMPLER]
#
# e.g. scripts/scale_build.sh /tmp/city/city.usda /tmp/city/cache 0.05 2GiB
# (scene from scripts/gen_large_scene.py). STAGING_QUOTA (default the
# daemon's, 32GiB) bounds the build's staging directory: a billion surfels
# stage ~22 GB of sort runs beside ~19 GB of pages. MAX_SURFELS (default
# the daemon's limits.max_surfels, 200 M) lets a larger build through.
# Runs under nice; the daemon is
# stopped with SIGTERM once the scene is preloaded. Output: CACHE_DIR/scale.log
# (the daemon's log) and a summary on stdout.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SCENE="$(realpath "$1")"
CACHE="$2"
SPACING="$3"
BUDGET="${4:-2GiB}"
SAMPLER="${5:-uniform}"
PBGID="${PBGID:-$ROOT/build/bin/pbgid}"

mkdir -p "$CACHE"
CACHE="$(realpath "$CACHE")"
CONFIG="$CACHE/scale.toml"
cat >"$CONFIG" <<EOF
scene_roots = ["$(dirname "$SCENE")"]
cache_dir = "$CACHE"
memory_budget = "$BUDGET"
log_level = "info"
[build]
surfel_spacing = $SPACING
EOF
[ "$SAMPLER" = uniform ] || echo "sampler = \"$SAMPLER\"" >>"$CONFIG"
[ -z "${STAGING_QUOTA:-}" ] || sed -i "1i staging_quota = \"$STAGING_QUOTA\"" "$CONFIG"
[ -z "${MAX_SURFELS:-}" ] || printf '[limits]\nmax_surfels = %s\n' "$MAX_SURFELS" >>"$CONFIG"

LOG="$CACHE/scale.log"
: >"$LOG"
start=$(date +%s.%N)
nice -n 10 "$PBGID" --config "$CONFIG" --listen "unix:$CACHE/scale.sock" --preload "$SCENE" 2>"$LOG" &
daemon=$!
child_peak_kb=0
daemon_peak_kb=0
ingest_peak_kb=0
ingest_end=""
rays_peak_kb=0
while kill -0 "$daemon" 2>/dev/null; do
  if [ -z "$ingest_end" ] && grep -q "\] read '" "$LOG"; then
    ingest_end=$(date +%s.%N)
    ingest_peak_kb=$(awk '/^VmHWM/ {print $2}' "/proc/$daemon/status" 2>/dev/null || echo 0)
  fi
  if [ "$rays_peak_kb" = 0 ] && grep -q "ray scene of '" "$LOG"; then
    rays_peak_kb=$(awk '/^VmHWM/ {print $2}' "/proc/$daemon/status" 2>/dev/null || echo 0)
    if [ "${STOP_AFTER_RAY_SCENE:-0}" = 1 ]; then break; fi
  fi
  if grep -q "preloaded '" "$LOG"; then break; fi
  if grep -q "\[error\]\|\[critical\]" "$LOG"; then
    echo "pbgid failed:" >&2
    tail -5 "$LOG" >&2
    kill "$daemon" 2>/dev/null || true
    exit 1
  fi
  for c in $(pgrep -P "$daemon" || true); do
    kb=$(awk '/^VmRSS/ {print $2}' "/proc/$c/status" 2>/dev/null || echo 0)
    ((kb > child_peak_kb)) && child_peak_kb=$kb
  done
  kb=$(awk '/^VmHWM/ {print $2}' "/proc/$daemon/status" 2>/dev/null || echo 0)
  ((kb > daemon_peak_kb)) && daemon_peak_kb=$kb
  sleep 0.2
done
end=$(date +%s.%N)
kb=$(awk '/^VmHWM/ {print $2}' "/proc/$daemon/status" 2>/dev/null || echo 0)
((kb > daemon_peak_kb)) && daemon_peak_kb=$kb
# A daemon stopped at the ray scene is in the middle of a build, which
# SIGTERM lets finish (drain): kill it outright then.
if [ "${STOP_AFTER_RAY_SCENE:-0}" = 1 ]; then
  kill -KILL "$daemon" 2>/dev/null || true
else
  kill -TERM "$daemon" 2>/dev/null || true
fi
wait "$daemon" 2>/dev/null || true
# A daemon that exited on its own before the preload (a refused scene: too
# many surfels, over the staging quota or the budget) failed.
if [ "${STOP_AFTER_RAY_SCENE:-0}" != 1 ] && ! grep -q "preloaded '" "$LOG"; then
  echo "pbgid stopped before the scene was preloaded:" >&2
  tail -3 "$LOG" >&2
  exit 1
fi

grep "\] read '\|ray scene of\|built page set\|preloaded" "$LOG" || true
awk -v s="$start" -v e="$end" -v i="${ingest_end:-0}" -v ip="$ingest_peak_kb" -v d="$daemon_peak_kb" \
    -v c="$child_peak_kb" -v r="$rays_peak_kb" 'BEGIN {
  if (r > 0) printf "ray scene      pbgid VmHWM when the BVH was built %.3f GiB\n", r / 1048576
  if (i > 0) printf "ingest         %.1f s (start to the read line), pbgid VmHWM then %.3f GiB\n", i - s, ip / 1048576
  printf "wall           %.1f s (start to preloaded)\n", e - s
  printf "peak RSS       pbgid %.3f GiB (VmHWM), USD reader child %.3f GiB (sampled)\n", d / 1048576, c / 1048576
}'
