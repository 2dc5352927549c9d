#!/usr/bin/env bash
# The README's main job, deploy/main-job.sh, end to end without
# ../shared/data: a server with an engine, a scout uploading a rendered
# synthetic street over HTTP, the summary. It must end with one site whose
# model holds every photo, and the PLY files it names.
#   main_job_test.sh ARSCOUT_BINARY
set -euo pipefail
bin=$(realpath "$1")
repo=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
ARSCOUT_BIN="$bin" ARSCOUT_MAIN_JOB_DIR="$work/job" ARSCOUT_DATA="$work/none" \
  "$repo/deploy/main-job.sh" > "$work/out.log" 2>&1 || {
  cat "$work/out.log"; echo "main job failed"; exit 1; }
cat "$work/out.log"
grep -q "^1 site in sqlite:" "$work/out.log" || { echo "FAIL: not one site"; exit 1; }
grep -q "captures 10: 10 registered" "$work/out.log" || {
  echo "FAIL: not all 10 photos registered"; exit 1; }
grep -Eq "model version [0-9]+: 10 registered" "$work/out.log" || {
  echo "FAIL: no model with 10 registered"; exit 1; }
for f in "$work"/job/models/*/sparse.ply "$work"/job/models/*/dense.ply; do
  [ -s "$f" ] || { echo "FAIL: $f missing or empty"; exit 1; }
  head -c 3 "$f" | grep -q ply || { echo "FAIL: $f is not a PLY"; exit 1; }
done
echo "main job passed"
