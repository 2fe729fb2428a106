#!/usr/bin/env bash
# Measures the ingest memory requirement of issue 3: "peak daemon memory
# during ingest of a generated scene with 200 payload-loaded assets totalling
# 20M triangles stays below 1.5 GiB plus twice the largest chunk".
#
#   scripts/ingest_memory.sh [OUT_DIR] [SPACING]
#
# Writes the scene with scripts/gen_large_scene.py --kind assets into
# OUT_DIR (default /work/tmp/assets200; skipped if OUT_DIR/assets.usda
# exists), preloads it in pbgid through scripts/scale_build.sh (a short
# surfel build at SPACING, default 0.05 m: ~2M surfels; ingest is what is
# measured), then compares the daemon's VmHWM at the end of ingest with the
# bound, the largest chunk being the largest frame of the reader's stream
# (the daemon's "read '...'" log line). Exit status 1 if the bound is
# exceeded.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${1:-/work/tmp/assets200}"
SPACING="${2:-0.05}"
SCENE="$OUT/assets.usda"

if [ ! -f "$SCENE" ]; then
  "$ROOT/.venv/bin/python" "$ROOT/scripts/gen_large_scene.py" --kind assets --assets 200 --triangles 20e6 \
    --out "$SCENE"
fi
rm -rf "$OUT/cache"
summary=$("$ROOT/scripts/scale_build.sh" "$SCENE" "$OUT/cache" "$SPACING")
echo "$summary"

largest=$(grep -o "largest frame [0-9]* bytes" "$OUT/cache/scale.log" | awk '{print $3}')
ingest_gib=$(echo "$summary" | sed -n 's/.*pbgid VmHWM then \([0-9.]*\) GiB.*/\1/p')
if [ -z "$largest" ] || [ -z "$ingest_gib" ]; then
  echo "no read line or ingest peak in $OUT/cache/scale.log" >&2
  exit 1
fi
awk -v p="$ingest_gib" -v l="$largest" 'BEGIN {
  bound = 1.5 + 2 * l / 1073741824
  printf "ingest bound   1.5 GiB + 2 x %d B (largest chunk) = %.3f GiB; measured %.3f GiB: %s\n",
         l, bound, p, p < bound ? "within" : "EXCEEDED"
  exit p < bound ? 0 : 1
}'
