#!/usr/bin/env bash
# Renders a scene of --kind instances (scripts/gen_large_scene.py) and its
# flattened twin through one pbgid and compares the images (pbgi compare):
# instancing must not change what is rendered beyond surfel sampling noise.
#
#   scripts/instancing_render_compare.sh OUT_DIR [INSTANCES] [PROTO_TRIANGLES] [WIDTH] [HEIGHT]
#
# Writes OUT_DIR/inst/inst.usda and OUT_DIR/flat/inst.usda (skipped if
# present), OUT_DIR/render/{inst,flat}.exr and the daemon's log.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="$(realpath -m "$1")"
N="${2:-20}"
TRIS="${3:-2000}"
W="${4:-192}"
H="${5:-108}"
for kind in inst flat; do
  if [ ! -f "$OUT/$kind/inst.usda" ]; then
    flag=""; [ "$kind" = flat ] && flag="--flatten"
    "$ROOT/.venv/bin/python" "$ROOT/scripts/gen_large_scene.py" --kind instances --instances "$N" \
      --proto-triangles "$TRIS" $flag --out "$OUT/$kind/inst.usda"
  fi
done
RUN="$OUT/render"
rm -rf "$RUN"; mkdir -p "$RUN"
SOCK="$RUN/pbgid.sock"
nice "$ROOT/build/bin/pbgid" --listen "unix:$SOCK" --scene-root "$OUT" --cache-dir "$RUN/cache" >"$RUN/pbgid.log" 2>&1 &
PID=$!
trap 'kill -KILL "$PID" 2>/dev/null || true' EXIT
for _ in $(seq 1 300); do [ -S "$SOCK" ] && break; sleep 0.1; done
for kind in inst flat; do
  "$ROOT/build/bin/pbgi" render --server "unix:$SOCK" "$OUT/$kind/inst.usda" --camera /World/Camera \
    --width "$W" --height "$H" --out "$RUN/$kind.exr" --no-png --quiet
done
"$ROOT/build/bin/pbgi" compare "$RUN/inst.exr" "$RUN/flat.exr" --no-perceptual
grep -h "read '\|ray scene of\|built page set" "$RUN/pbgid.log" || true
