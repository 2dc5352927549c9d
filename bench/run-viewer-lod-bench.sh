#!/usr/bin/env bash
# The web viewer's level of detail at several cloud sizes: for each size,
# tests/viewer/lod_browser_test.sh (headless Chromium, software WebGL) on
# the synthetic street, and a table of its figures: the time to open the
# site (the server's octree build included), points drawn, the median frame
# time against 0.5 million points drawn whole, the page's memory and the
# measurements.
#   bench/run-viewer-lod-bench.sh BUILD_DIR [POINTS...]
# BUILD_DIR holds the test build (arscout and make_street_site); sizes
# default to 2, 5, 10 and 20 million.
set -euo pipefail
build=$(realpath "${1:?usage: run-viewer-lod-bench.sh BUILD_DIR [POINTS...]}")
shift
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(2000000 5000000 10000000 20000000)
repo=$(cd "$(dirname "$0")/.." && pwd)
figures=$(mktemp)
trap 'rm -f "$figures"' EXIT

printf '| points | open (s) | drawn | frame (ms) | 0.5 M whole (ms) | ratio | renderer+GPU PSS (MiB) | edge (m) | height (m) | roof (m²) |\n'
printf '|---|---|---|---|---|---|---|---|---|---|\n'
for n in "${sizes[@]}"; do
  FIGURES="$figures" "$repo/tests/viewer/lod_browser_test.sh" \
    "$build/cli/arscout" "$build/tests/viewer/make_street_site" "$n" \
    > "$figures.log" 2>&1 || { tail -20 "$figures.log"; exit 1; }
  sed 's/^figures: //' "$figures" | node -e '
    const f = JSON.parse(require("fs").readFileSync(0, "utf8"));
    const r = (v, d) => v.toFixed(d);
    console.log(`| ${f.big_points.toLocaleString("en")} | ${r(f.big_open_s, 1)} | ${f.big_drawn.toLocaleString("en")} | ` +
      `${r(f.big_frame_ms, 0)} | ${r(f.small_frame_ms, 0)} | ${r(f.ratio, 2)} | ${r(f.page_pss_mb, 0)} | ` +
      `${r(f.edge_m, 3)} | ${r(f.height_m, 3)} | ${r(f.roof_plan_m2, 2)} |`);'
done
rm -f "$figures.log"
