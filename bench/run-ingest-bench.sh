#!/usr/bin/env bash
# Runs ingest_bench against SQLite and against a throwaway PostgreSQL 15 server
# (tests/support/pg_fixture.sh), then prints both tables. Builds nothing:
#
#   cmake --build BUILD_DIR --target ingest_bench
#   bench/run-ingest-bench.sh [BUILD_DIR] [ingest_bench options, e.g. --runs 5]
#
# BUILD_DIR defaults to ./build. The images are read from ../shared/data beside
# the source tree (or $ARSCOUT_SHARED_DATA). Progress goes to stderr, tables
# (each with the date, the machine and its load average) to stdout.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
shift || true
bench="$build/bench/ingest_bench"
if [ ! -x "$bench" ]; then
  echo "$bench not found: build it with" \
       "'cmake --build $build --target ingest_bench'" >&2
  exit 1
fi

state=$(mktemp -d /tmp/arscout-bench-pg.XXXXXX)
trap '"$root/tests/support/pg_fixture.sh" stop "$state" >/dev/null 2>&1 || true' EXIT

sqlite_out=$("$bench" --db sqlite: "$@")

"$root/tests/support/pg_fixture.sh" start "$state" >&2
pg_out="PostgreSQL not installed: skipped"
if [ -f "$state/url" ]; then
  pg_out=$("$bench" --db "$(cat "$state/url")" "$@")
fi

echo "$sqlite_out"
echo
echo "$pg_out"
