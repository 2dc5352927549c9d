#!/usr/bin/env bash
# Times `arscout reconstruct` on a Strecha scene (default fountain-P11, with
# its gps.csv and K.txt), RUNS times (default 3), and prints per-stage
# totals, the whole run and the slowest single increment: the median over
# the runs, with the machine and the date. Builds nothing:
#
#   cmake --build BUILD_DIR --target arscout
#   bench/run-reconstruct-bench.sh [BUILD_DIR] [SCENE] [RUNS]
#
# SCENE is a folder under ../shared/data/strecha (or $ARSCOUT_SHARED_DATA).
# Use a Release build (-DCMAKE_BUILD_TYPE=Release) for figures to record.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
scene_name=${2:-fountain-P11}
runs=${3:-3}
data=${ARSCOUT_SHARED_DATA:-$root/../shared/data}
scene="$data/strecha/$scene_name"
cli="$build/cli/arscout"
[ -x "$cli" ] || { echo "$cli not found: build the 'arscout' target" >&2; exit 1; }
[ -d "$scene/images" ] || { echo "$scene/images not found" >&2; exit 1; }

work=$(mktemp -d /tmp/arscout-reconstruct-bench.XXXXXX)
trap 'rm -rf "$work"' EXIT

for run in $(seq 1 "$runs"); do
  echo "run $run of $runs" >&2
  "$cli" reconstruct --images "$scene/images" --gps-csv "$scene/gps.csv" \
    --camera "$scene/images/K.txt" --out "$work/out" > "$work/run$run.log"
  # One line per run: the sum of each stage over the images, the total and
  # the slowest increment.
  grep -E '^\[[0-9]+/[0-9]+\]' "$work/run$run.log" | grep -oE '\| decode.*s' |
    awk '{ for (i = 2; i < NF; i += 2) { sum[$i] += $(i + 1) }
           if ($(NF - 1) > worst) worst = $(NF - 1); n++ }
         END { printf "%d %.3f %.3f %.3f %.3f %.3f %.3f %.3f %.3f %.3f\n", n,
               sum["decode"], sum["undistort"], sum["features"], sum["match"],
               sum["pose"], sum["triang"], sum["ba"], sum["total"], worst }' \
    >> "$work/stages"
  grep -E '^registered' "$work/run$run.log" >&2
done

median() { sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
echo "arscout reconstruct, $scene_name, median of $runs runs"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "date: $(date -u +%Y-%m-%d)"
echo
echo "| stage | seconds (all images) |"
echo "|---|---|"
col=2
for stage in decode undistort features matching pose triangulation bundle_adjustment total; do
  echo "| $stage | $(cut -d' ' -f$col "$work/stages" | median) |"
  col=$((col + 1))
done
echo "| slowest increment | $(cut -d' ' -f10 "$work/stages" | median) |"
echo "| images | $(cut -d' ' -f1 "$work/stages" | median) |"
