#!/usr/bin/env bash
# Runs store_bench against SQLite and against a throwaway PostgreSQL 15 server
# (tests/support/pg_fixture.sh), then prints both tables. Builds nothing:
#
#   cmake --build BUILD_DIR --target store_bench
#   bench/run-store-bench.sh [BUILD_DIR] [store_bench options, e.g. --runs 3]
#
# BUILD_DIR defaults to ./build. Progress goes to stderr, tables to stdout.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
shift || true
bench="$build/bench/store_bench"
if [ ! -x "$bench" ]; then
  echo "$bench not found: build it with" \
       "'cmake --build $build --target store_bench'" >&2
  exit 1
fi

state=$(mktemp -d /tmp/arscout-bench-pg.XXXXXX)
trap '"$root/tests/support/pg_fixture.sh" stop "$state" >/dev/null 2>&1 || true' EXIT

# The figures depend on the machine and on what else it is doing.
echo "date:    $(date -u '+%Y-%m-%d %H:%M:%S UTC')"
echo "machine: $(nproc) CPUs, $(lscpu | sed -n 's/^Model name: *//p')," \
     "$(free -g | awk '/^Mem:/ {print $2}') GiB memory"
echo "load:    $(cut -d' ' -f1-3 /proc/loadavg) (1/5/15 min)"
echo

sqlite_out=$("$bench" --db sqlite: "$@")

"$root/tests/support/pg_fixture.sh" start "$state" >&2
pg_out="PostgreSQL not installed: skipped"
if [ -f "$state/url" ]; then
  pg_out=$("$bench" --db "$(cat "$state/url")" "$@")
fi

echo "$sqlite_out"
echo
echo "$pg_out"
echo
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg) (1/5/15 min)"
