#!/usr/bin/env bash
# Regenerates the seed corpora in tests/fuzz/corpus/<target>/ (small files,
# committed; nothing is downloaded):
#   fuzz_gather_request, fuzz_page_reader  written by fuzz_make_corpus (requests,
#                                          pages and manifest of a tiny page set)
#   fuzz_daemon_config                     the example config and a few snippets
#   fuzz_scene_stream                      the USD reader's output on the small test scenes
#   fuzz_scene_entry                       those streams stored as .pbgiscene entries
#                                          (fuzz_make_corpus, after the streams)
# Usage: tests/fuzz/make_corpus.sh [BUILD_DIR]   (a build with fuzz_make_corpus built)
set -euo pipefail
cd "$(dirname "$0")/../.."
BUILD=${1:-build}
CORPUS=tests/fuzz/corpus
PY=${PBGI_PYTHON:-.venv/bin/python3}

mkdir -p "$CORPUS/fuzz_daemon_config"
cp config/pbgid.toml "$CORPUS/fuzz_daemon_config/pbgid_example.toml"
printf 'listen = "unix:/tmp/x.sock"\nmemory_budget = "512MiB"\nthreads = 2\n' \
  > "$CORPUS/fuzz_daemon_config/minimal.toml"
printf '[gather]\nmethod = "fpbgi"\nclusters = 50\nepsilon = 0.02\n[build]\ntarget_surfels = 1000\n[limits]\nmax_receivers = 10\n' \
  > "$CORPUS/fuzz_daemon_config/sections.toml"
printf 'scene_roots = ["/a", "/b"]\npreload = ["x.usda"]\nshutdown_grace_seconds = 1.5\n' \
  > "$CORPUS/fuzz_daemon_config/arrays.toml"

mkdir -p "$CORPUS/fuzz_scene_stream"
for scene in scenes/cornell.usda scenes/subdiv_test.usda; do
  PYTHONPATH="$BUILD/python" "$PY" server/ingest/usd_reader.py "$scene" > "$CORPUS/fuzz_scene_stream/$(basename "$scene" .usda).stream"
done

"$BUILD/fuzz/fuzz_make_corpus" "$CORPUS"
du -sh "$CORPUS"/*
