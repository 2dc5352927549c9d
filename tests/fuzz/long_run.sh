#!/usr/bin/env bash
# The long fuzz runs of RESULTS.md: every target for RUNS executions
# (default 1,000,000) from a scratch copy of its seed corpus, one target
# after the other at low priority, then a Markdown table of the runs.
# Exits non-zero when a target failed; its log and crashing input stay in
# the scratch directory, which the table names.
# usage: tests/fuzz/long_run.sh BUILD_DIR [RUNS [TARGET...]]
# (TARGET: document_path, json_document, ...; all of them by default)
set -uo pipefail

build=${1:?usage: long_run.sh BUILD_DIR [RUNS [TARGET...]]}
runs=${2:-1000000}
shift $(($# < 2 ? $# : 2))
here=$(cd "$(dirname "$0")" && pwd)
targets=(document_path json_document http_request multipart exif_gps gps_csv
  gpx ply)
if [ $# -gt 0 ]; then
  targets=("$@")
fi

scratch=$(mktemp -d "${TMPDIR:-/tmp}/arscout-fuzz-long.XXXXXX")
rows=()
failed=0
for name in "${targets[@]}"; do
  target=fuzz_$name
  binary=$build/tests/fuzz/$target
  work=$scratch/$name
  mkdir -p "$work"
  cp -R "$here/corpus/$target" "$work/corpus"
  args=(-runs="$runs" -timeout=30 -rss_limit_mb=2048 -print_final_stats=1
    -artifact_prefix="$work/")
  if [ -f "$here/$target.dict" ]; then
    args+=(-dict="$here/$target.dict")
  fi
  echo "== $target: $runs runs (log: $work/log)" >&2
  start=$(date +%s.%N)
  nice -n 10 "$binary" "${args[@]}" "$work/corpus" > "$work/log" 2>&1
  status=$?
  end=$(date +%s.%N)

  executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/log")
  peak_rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$work/log")
  files=$(find "$work/corpus" -type f | wc -l)
  kib=$(du -sk --apparent-size "$work/corpus" | cut -f1)
  seconds=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.0f", b - a }')
  rate=$(awk -v n="${executions:-0}" -v a="$start" -v b="$end" \
    'BEGIN { printf "%.0f", n / (b - a) }')
  if [ "$status" -eq 0 ] && [ "${executions:-0}" -ge "$runs" ]; then
    result="no crash"
  else
    result="FAILED (exit $status, see $work)"
    failed=1
  fi
  rows+=("| $target | ${executions:-?} | $seconds | $rate | $files files, \
$kib KiB | ${peak_rss:-?} | $result |")
done

echo
echo "| target | executions | seconds | exec/s | corpus after | peak RSS MB | result |"
echo "|---|---:|---:|---:|---|---:|---|"
printf '%s\n' "${rows[@]}"
echo
echo "scratch directory: $scratch"
exit "$failed"
