#!/usr/bin/env bash
# The lint step of the test suite (tests/run_all.sh runs it after the
# default build): every C++ file formatted as .clang-format says, and
# clang-tidy (.clang-tidy: bugprone-*, consistent parameter names) clean on
# the production code of every library. Any finding fails it.
#
#   tests/lint.sh [--format-only] [BUILD_DIR]
#                          (default build; clang-tidy needs its
#                           compile_commands.json)
set -euo pipefail
cd "$(dirname "$0")/.."
format_only=0
if [ "${1:-}" = --format-only ]; then
  format_only=1
  shift
fi
build=${1:-build}
echo "== clang-format: every tracked C++ file"
git ls-files -z '*.cpp' '*.h' '*.cu' '*.mm' |
  xargs -0 clang-format --dry-run --Werror
[ "$format_only" = 1 ] && { echo "lint: formatting clean"; exit 0; }

[ -f "$build/compile_commands.json" ] || {
  echo "lint: $build/compile_commands.json is missing (configure $build first)" >&2
  exit 2
}

echo "== clang-tidy: the libraries' and the executable's sources"
libraries='util|documents|db|http|metadata|ingest|scout|engine|viewer|cli'
jobs=$(nproc)
run-clang-tidy -p "$build" -j "$jobs" -quiet \
  "$PWD/($libraries)/.*\\.cpp\$" > "$build/clang-tidy.log" 2>&1 || {
  grep -E 'error:|warning:' "$build/clang-tidy.log" | sort -u | head -100 >&2
  echo "lint: clang-tidy found the above (full log: $build/clang-tidy.log)" >&2
  exit 1
}
echo "lint: clean"
