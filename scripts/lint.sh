#!/usr/bin/env bash
# Lints what a change touches: clang-format (--dry-run --Werror) and
# clang-tidy (.clang-tidy: bugprone, performance, modernize subsets) on the
# lines of C++ files changed since a base revision, so that the tree is
# never reformatted wholesale and old code is linted when it is edited.
#
#   scripts/lint.sh                 # changes since the base (below), uncommitted included
#   scripts/lint.sh --base REV      # changes since REV
#   scripts/lint.sh FILE...         # these files, every line
#   scripts/lint.sh --format-only   # skip clang-tidy (fast)
#   scripts/lint.sh --fix           # reformat the changed lines in place, then lint
#
# Base: $PBGI_LINT_BASE, else the merge base of HEAD with origin/main, else
# with main. When that is HEAD itself and nothing is uncommitted (a clean
# clone of main), the last commit's changes are checked. clang-tidy reads
# the compile commands of $PBGI_BUILD_DIR (default build/), which CMake
# writes (CMAKE_EXPORT_COMPILE_COMMANDS). Exits 1 when anything is found,
# 2 when a tool or the compile commands are missing.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${PBGI_BUILD_DIR:-$ROOT/build}"
JOBS="${PBGI_LINT_JOBS:-$(nproc)}"
cd "$ROOT"

base="${PBGI_LINT_BASE:-}"
tidy=1
fix=0
files=()
args_without_fix=()
for a in "$@"; do [ "$a" = --fix ] || args_without_fix+=("$a"); done
while (($#)); do
  case "$1" in
    --base) base="$2"; shift 2 ;;
    --format-only) tidy=0; shift ;;
    --fix) fix=1; shift ;;
    -h|--help) sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) files+=("$1"); shift ;;
  esac
done

pick() { for c in "$@"; do command -v "$c" >/dev/null && { echo "$c"; return; }; done; }
FORMAT="$(pick clang-format-14 clang-format)"
TIDY="$(pick clang-tidy-14 clang-tidy)"
if [ -z "$FORMAT" ] || { [ "$tidy" = 1 ] && [ -z "$TIDY" ]; }; then
  echo "[lint] clang-format-14 / clang-tidy-14 missing (scripts/setup.sh installs them)" >&2
  exit 2
fi

# Line ranges per file: "FILE START END" lines, whole files as "FILE 1 0".
ranges="$(mktemp)"
trap 'rm -f "$ranges"' EXIT
is_cxx() { case "$1" in *.cpp|*.cc|*.h|*.hpp) return 0 ;; *) return 1 ;; esac; }
if ((${#files[@]})); then
  for f in "${files[@]}"; do is_cxx "$f" && [ -f "$f" ] && echo "$f 1 0"; done > "$ranges"
else
  if [ -z "$base" ]; then
    for ref in origin/main main; do
      if git rev-parse -q --verify "$ref" >/dev/null; then base="$(git merge-base HEAD "$ref")"; break; fi
    done
  fi
  [ -n "$base" ] || base="HEAD"
  if [ "$(git rev-parse "$base")" = "$(git rev-parse HEAD)" ] && git diff --quiet HEAD &&
     git rev-parse -q --verify HEAD~1 >/dev/null; then
    base="HEAD~1"  # nothing of our own: the last commit's changes
  fi
  # Hunks of the change (committed since base and uncommitted) as added
  # line ranges; untracked C++ files count whole.
  git diff -U0 --no-color --diff-filter=AMR "$base" -- '*.cpp' '*.cc' '*.h' '*.hpp' |
    awk '/^\+\+\+ b\// { file = substr($0, 7) }
         /^@@/ { split($3, a, ","); start = substr(a[1], 2); n = (a[2] == "" ? 1 : a[2]);
                 if (n > 0) print file, start, start + n - 1 }' > "$ranges"
  git ls-files --others --exclude-standard -- '*.cpp' '*.cc' '*.h' '*.hpp' |
    while read -r f; do echo "$f 1 0"; done >> "$ranges"
fi
# Generated and third-party code is not ours to lint.
grep -vE '^(build[^/]*|\.venv|tests/fuzz/corpus)/' "$ranges" > "$ranges.keep" || true
mv "$ranges.keep" "$ranges"
if [ ! -s "$ranges" ]; then
  echo "[lint] no C++ lines changed${base:+ since $base}"
  exit 0
fi
mapfile -t changed < <(cut -d' ' -f1 "$ranges" | sort -u)
echo "[lint] ${#changed[@]} C++ file(s)${base:+ changed since $(git rev-parse --short "$base")}"

status=0
# 1. clang-format on the changed lines (--lines for each range). --fix
#    formats them in place, then lints again (line numbers may have moved).
for f in "${changed[@]}"; do
  args=()
  while read -r _ start end; do
    [ "$end" = 0 ] && { args=(); break; }
    args+=("--lines=$start:$end")
  done < <(awk -v f="$f" '$1 == f' "$ranges")
  if [ "$fix" = 1 ]; then
    "$FORMAT" -i "${args[@]}" "$f"
  elif ! "$FORMAT" --dry-run --Werror "${args[@]}" "$f"; then
    status=1
  fi
done
if [ "$fix" = 1 ]; then exec "$0" "${args_without_fix[@]}"; fi

# 2. clang-tidy on the changed lines of translation units in the compile
#    commands (headers are checked through the files that include them).
if [ "$tidy" = 1 ]; then
  db="$BUILD_DIR/compile_commands.json"
  if [ ! -f "$db" ]; then
    echo "[lint] $db missing: configure the build first (scripts/setup.sh)" >&2
    exit 2
  fi
  filter="$(python3 - "$ranges" "$ROOT" <<'EOF'
import json, sys, collections
ranges = collections.defaultdict(list)
for line in open(sys.argv[1]):
    f, a, b = line.split()
    ranges[f].append(None if b == "0" else [int(a), int(b)])
out = []
for f, rs in ranges.items():
    entry = {"name": sys.argv[2] + "/" + f}
    if None not in rs:
        entry["lines"] = rs
    out.append(entry)
print(json.dumps(out))
EOF
)"
  mapfile -t units < <(python3 - "$db" "${changed[@]}" <<'EOF'
import json, os, sys
known = {os.path.realpath(e["file"]) for e in json.load(open(sys.argv[1]))}
for f in sys.argv[2:]:
    if os.path.realpath(f) in known:
        print(f)
EOF
)
  if ((${#units[@]})); then
    echo "[lint] clang-tidy on ${#units[@]} file(s), $JOBS at a time"
    if ! printf '%s\n' "${units[@]}" |
         xargs -P "$JOBS" -I{} "$TIDY" -p "$BUILD_DIR" --quiet --warnings-as-errors='*' \
               --line-filter="$filter" {} 2>/dev/null; then
      status=1
    fi
  fi
fi
[ "$status" = 0 ] && echo "[lint] clean" || echo "[lint] problems found (above)" >&2
exit "$status"
