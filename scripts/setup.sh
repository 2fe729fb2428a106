#!/usr/bin/env bash
# Installs what is missing (Debian packages, a project-local Python venv with
# usd-core), then configures and builds pbgi (CMake, Release) into build/.
# Idempotent: a second run installs nothing and rebuilds only what changed.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
BUILD_DIR="${PBGI_BUILD_DIR:-$ROOT/build}"
JOBS="${PBGI_JOBS:-$(nproc)}"

log() { printf '\033[1m[setup]\033[0m %s\n' "$*"; }

# 1. Debian packages.
DEB_PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libembree-dev libopenvdb-dev libboost-iostreams-dev libosd-dev
  libopenexr-dev libopencolorio-dev libdraco-dev libtbb-dev
  libgrpc++-dev libprotobuf-dev protobuf-compiler protobuf-compiler-grpc
  libgtest-dev libgmock-dev libbenchmark-dev
  libspdlog-dev libfmt-dev libcli11-dev libtomlplusplus-dev libxxhash-dev libzstd-dev libpng-dev
  libopenimageio-dev libhwy-dev libjemalloc-dev
  python3 python3-venv openimageio-tools ccache
  clang-14 libclang-rt-14-dev llvm-14
  clang-format-14 clang-tidy-14
)
missing=()
for p in "${DEB_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  log "installing Debian packages: ${missing[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  log "Debian packages: all present"
fi

# 2. Python venv with Pixar's USD (usd-core needs Python >= 3.11) and the
#    protobuf runtime matching Debian's protoc 3.21.
PY_REQ="$ROOT/scripts/requirements.txt"
VENV="$ROOT/.venv"
pick_python() {
  for c in python3.13 python3.12 python3.11 python3; do
    if command -v "$c" >/dev/null && "$c" -c 'import sys; sys.exit(0 if sys.version_info >= (3,11) else 1)' 2>/dev/null; then
      echo "$c"; return; fi
  done
  echo "no Python >= 3.11 found (usd-core needs it)" >&2; exit 1
}
if [ ! -x "$VENV/bin/python3" ]; then
  PY="$(pick_python)"
  log "creating venv with $PY"
  "$PY" -m venv "$VENV"
fi
STAMP="$VENV/.requirements.sha"
want="$(sha256sum "$PY_REQ" | cut -d' ' -f1)"
if [ ! -f "$STAMP" ] || [ "$(cat "$STAMP")" != "$want" ]; then
  log "installing Python packages into .venv"
  "$VENV/bin/pip" install -q --disable-pip-version-check -r "$PY_REQ"
  echo "$want" > "$STAMP"
else
  log "Python packages: current"
fi

# 3. Configure (once) and build. ccache makes a fresh clone's build (CI, a
#    second worktree) reuse objects compiled before on this machine;
#    CCACHE_BASEDIR keeps its keys independent of where the clone lives.
#    PBGI_CMAKE_ARGS adds cache settings (scripts/test.sh: -DPBGI_WERROR=ON);
#    given to an existing build directory, they update its cache.
export CCACHE_BASEDIR="$ROOT" CCACHE_NOHASHDIR=1
read -r -a EXTRA_CMAKE_ARGS <<< "${PBGI_CMAKE_ARGS:-}"
if [ ! -f "$BUILD_DIR/build.ninja" ]; then
  log "configuring $BUILD_DIR"
  cmake -S "$ROOT" -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release \
        -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache \
        -DPBGI_PYTHON="$VENV/bin/python3" "${EXTRA_CMAKE_ARGS[@]}"
elif ((${#EXTRA_CMAKE_ARGS[@]})); then
  cmake -S "$ROOT" -B "$BUILD_DIR" "${EXTRA_CMAKE_ARGS[@]}" >/dev/null
fi
log "building ($JOBS jobs)"
cmake --build "$BUILD_DIR" -j "$JOBS"
log "built: $BUILD_DIR/bin/pbgid, $BUILD_DIR/bin/pbgi (and pbgi-tools, which it runs for bench, inspect, reference)"
