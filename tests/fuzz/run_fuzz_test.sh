#!/bin/sh
# One CTest run of a fuzz target: every input of its seed corpus, then
# SECONDS of mutation. It works on a scratch copy of the corpus, so what the
# run adds never lands in the source tree; a crashing input is written to
# the test's working directory (crash-*, leak-*, timeout-*) and named in
# the output.
# usage: run_fuzz_test.sh TARGET CORPUS_DIR SECONDS [DICT]
set -eu
target=$1
corpus=$2
seconds=$3
dict=${4:-}

work=$(mktemp -d "${TMPDIR:-/tmp}/arscout-fuzz.XXXXXX")
trap 'rm -rf "$work"' EXIT
cp -R "$corpus" "$work/corpus"

set -- -max_total_time="$seconds" -timeout=30 -rss_limit_mb=2048 \
  -print_final_stats=1 -artifact_prefix="$PWD/"
if [ -n "$dict" ]; then
  set -- "$@" -dict="$dict"
fi
"$target" "$@" "$work/corpus"
