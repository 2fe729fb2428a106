#!/usr/bin/env bash
# Soak run: a pbgid on a fresh cache under `pbgi stress` (random tiles of the
# Cornell box from N concurrent clients), sampling the daemon's RSS. Writes
# into OUT (default build/soak/): stress.json, stress.txt, rss.csv, rss.png.
# Fails (exit 1) on any request error or an RSS above --max-rss.
#
#   scripts/soak.sh            short: 30 s, 4 clients (what CI's
#                              test_reliability_soak does, as a script)
#   scripts/soak.sh --full     the long soak: 10 minutes, 16 clients (not in CI)
# Options: --build DIR  --out DIR  --clients N  --duration T (30s, 10m)
#          --scene PATH --image WxH --tile S --memory-budget SIZE --max-rss SIZE
#          --deadline SECONDS (per RenderTile call, default 300 as pbgi render)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${PBGI_BUILD_DIR:-$ROOT/build}"
OUT=""
CLIENTS=4
DURATION=30s
SCENE="$ROOT/scenes/cornell.usda"
IMAGE=256x256
TILE=32
BUDGET=512MiB
MAX_RSS=2GiB
# Per-call deadline: the same 300 s per tile that `pbgi render` allows (on a
# small shared machine 16 clients queue for seconds per tile; a timeout
# there measures the machine, not the daemon).
DEADLINE=300
while (($#)); do
  case "$1" in
    --full) CLIENTS=16; DURATION=10m ;;
    --build) BUILD="$2"; shift ;;
    --out) OUT="$2"; shift ;;
    --clients) CLIENTS="$2"; shift ;;
    --duration) DURATION="$2"; shift ;;
    --scene) SCENE="$2"; shift ;;
    --image) IMAGE="$2"; shift ;;
    --tile) TILE="$2"; shift ;;
    --memory-budget) BUDGET="$2"; shift ;;
    --max-rss) MAX_RSS="$2"; shift ;;
    --deadline) DEADLINE="$2"; shift ;;
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    *) echo "soak.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
OUT="${OUT:-$BUILD/soak}"
mkdir -p "$OUT"
for b in pbgid pbgi; do
  [ -x "$BUILD/bin/$b" ] || { echo "soak.sh: $BUILD/bin/$b missing (build it first)" >&2; exit 2; }
done

WORK="$(mktemp -d /tmp/pbgi-soak-XXXXXX)"
PID=""
cleanup() {
  [ -n "$PID" ] && kill "$PID" 2>/dev/null && wait "$PID" 2>/dev/null || true
  rm -rf "$WORK"
}
trap cleanup EXIT

SOCK="$WORK/pbgid.sock"
"$BUILD/bin/pbgid" --listen "unix:$SOCK" --cache-dir "$WORK/cache" \
  --scene-root "$(dirname "$SCENE")" --memory-budget "$BUDGET" --log-level warn \
  > "$OUT/pbgid.stdout" 2> "$OUT/pbgid.stderr" &
PID=$!
for _ in $(seq 1 600); do
  grep -q "pbgid listening on" "$OUT/pbgid.stdout" 2>/dev/null && break
  kill -0 "$PID" 2>/dev/null || { echo "soak.sh: pbgid exited:"; cat "$OUT/pbgid.stderr"; exit 2; }
  sleep 0.1
done
echo "[soak] pbgid $PID, $CLIENTS clients for $DURATION, budget $BUDGET, output in $OUT"

status=0
"$BUILD/bin/pbgi" stress --server "unix:$SOCK" --scene "$SCENE" --clients "$CLIENTS" \
  --duration "$DURATION" --image "$IMAGE" --tile "$TILE" --light-samples 4 \
  --target-surfels 50000 --build-light-samples 4 \
  --deadline "$DEADLINE" --daemon-pid "$PID" --rss-csv "$OUT/rss.csv" --rss-interval 1 --max-rss "$MAX_RSS" \
  --json > "$OUT/stress.json" || status=$?
cat "$OUT/stress.json"

# The curve as a PNG (matplotlib from the project venv).
PY="$ROOT/.venv/bin/python3"
if [ -x "$PY" ] && [ -s "$OUT/rss.csv" ]; then
  "$PY" - "$OUT/rss.csv" "$OUT/rss.png" "$OUT/stress.json" <<'PYEOF'
import csv, json, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
rows = list(csv.DictReader(open(sys.argv[1])))
t = [float(r["seconds"]) for r in rows]
mib = [float(r["rss_mib"]) for r in rows]
report = json.load(open(sys.argv[3]))
fig, ax = plt.subplots(figsize=(8, 4))
ax.plot(t, mib, lw=1.2)
ax.set_xlabel("seconds since start (scene open, then load)")
ax.set_ylabel("pbgid RSS (MiB)")
lat = report.get("latency_ms", {})
ax.set_title("pbgid soak: {} clients, {} requests, {} errors, p99 {:.0f} ms".format(
    report.get("clients"), report.get("requests"), report.get("errors"), lat.get("p99") or 0))
ax.set_ylim(bottom=0)
ax.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
print("[soak] plot:", sys.argv[2])
PYEOF
fi
kill -TERM "$PID"; wait "$PID" || { echo "[soak] pbgid did not exit cleanly"; status=1; }
PID=""
echo "[soak] $( [ $status -eq 0 ] && echo PASS || echo FAIL )"
exit $status
