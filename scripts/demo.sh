#!/usr/bin/env bash
# The main job: set up, start pbgid on the embedded default scene (the
# Cornell box), render it through the daemon tile by tile, write out/.
#   scripts/demo.sh [WIDTH] [HEIGHT]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
WIDTH="${1:-256}"
HEIGHT="${2:-256}"
T0=$(date +%s.%N)

"$ROOT/scripts/setup.sh"
T1=$(date +%s.%N)

BIN="$ROOT/build/bin"
RUN_DIR="$(mktemp -d "${TMPDIR:-/tmp}/pbgid.XXXXXX")"
SOCK="$RUN_DIR/pbgid.sock"
mkdir -p "$ROOT/out" "$ROOT/cache"

echo "[demo] starting pbgid on unix:$SOCK"
"$BIN/pbgid" --listen "unix:$SOCK" --scene-root "$ROOT/scenes" --cache-dir "$ROOT/cache" \
  > "$RUN_DIR/pbgid.log" 2>&1 &
PID=$!
cleanup() {
  kill -TERM "$PID" 2>/dev/null && wait "$PID" 2>/dev/null || true
  rm -rf "$RUN_DIR"
}
trap cleanup EXIT
for _ in $(seq 1 300); do
  [ -S "$SOCK" ] && break
  kill -0 "$PID" 2>/dev/null || { cat "$RUN_DIR/pbgid.log"; echo "[demo] pbgid exited" >&2; exit 1; }
  sleep 0.1
done
[ -S "$SOCK" ] || { cat "$RUN_DIR/pbgid.log"; echo "[demo] pbgid did not start" >&2; exit 1; }

"$BIN/pbgi" render --server "unix:$SOCK" "$ROOT/scenes/cornell.usda" --camera /Camera \
  --width "$WIDTH" --height "$HEIGHT" --out "$ROOT/out/cornell.exr" --png "$ROOT/out/cornell.png"
T2=$(date +%s.%N)
awk -v a="$T0" -v b="$T1" -v c="$T2" \
  'BEGIN { printf "[demo] set-up %.1f s, daemon + render %.1f s, total %.1f s\n", b-a, c-b, c-a }'
echo "[demo] images: $ROOT/out/cornell.exr (linear, multi-layer), $ROOT/out/cornell.png (display)"
