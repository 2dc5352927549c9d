#!/usr/bin/env bash
# The web viewer's level of detail and measurement tools in headless
# Chromium (lod_browser_test.mjs) against a server holding synthetic street
# sites written by make_street_site: "street" with BIG_POINTS points
# (default 20 million), "street-small" with 500,000, drawn whole, and
# "street-parts" in two components with "street-parts-before" merged into it.
#   lod_browser_test.sh ARSCOUT_BINARY MAKE_STREET_SITE [BIG_POINTS]
# Exit 77 (skipped) without Node, Chromium or the npm packages, except
# under CI=true, where that is a failure. FIGURES=FILE keeps the figures
# line; SCREENSHOT=FILE the picture of the distance measurement.
set -euo pipefail
bin=$(realpath "$1")
make_site=$(realpath "$2")
big=${3:-20000000}
repo=$(cd "$(dirname "$0")/../.." && pwd)
chromium=${CHROMIUM:-/usr/bin/chromium}

# shellcheck source=browser_support.sh
source "$(dirname "$0")/browser_support.sh"
need_browser

use_work_dir
db="sqlite:$work/arscout.db"
"$make_site" "$db" street "$big"
"$make_site" "$db" street-small 500000
"$make_site" "$db" street-parts 20000 components
token=$("$bin" token create --db "$db" --role planner --name pat)
# The octree of 20 million points is built on the first request for it.
start_server "$work/server.log" --db "$db" --listen 127.0.0.1:0

status=0
SERVER="$url" PLANNER_TOKEN="$token" CHROMIUM="$chromium" \
  SCREENSHOT="${SCREENSHOT:-$work/measure.png}" \
  node "$repo/tests/viewer/lod_browser_test.mjs" | tee "$work/test.log" ||
  status=$?
[ -z "${FIGURES:-}" ] || grep '^figures: ' "$work/test.log" > "$FIGURES" || true
if [ "$status" -ne 0 ]; then
  echo "--- server log (last 40 lines)"; tail -40 "$work/server.log"
fi
exit "$status"
