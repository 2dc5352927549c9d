#!/usr/bin/env bash
# Coverage guidance in the scout app (issue 38) in real headless Chromium
# with a phone viewport and touch (coverage_browser_test.mjs): the block
# scene rendered with one facade nobody photographed (`arscout render-site
# --leave-unseen`: the stretch of the walk that looks at one wall of the
# building it goes round is left out), its photos uploaded by `arscout
# scout` to a fresh `arscout serve --with-engine`, then the app, standing
# where the scout stopped, must mark that facade on its map and point its
# first suggestion at it.
#   coverage_browser_test.sh ARSCOUT_BINARY [SCREENSHOT_DIR]
# SEED (default 23) and VIEWS (default 70, a loop round one building) pick
# the scene. Exit 77 (skipped) without Node, Chromium or the npm packages,
# except under CI=true, where that is a failure.
set -euo pipefail
bin=$(realpath "$1")
shots=${2:-}
repo=$(cd "$(dirname "$0")/../.." && pwd)
chromium=${CHROMIUM:-/usr/bin/chromium}

# shellcheck source=browser_support.sh
source "$(dirname "$0")/browser_support.sh"
need_browser

use_work_dir
seed=${SEED:-23}
views=${VIEWS:-70}
"$bin" render-site --scene block --views "$views" --width 640 --height 480 \
  --seed "$seed" --leave-unseen --out "$work/site" > "$work/render.log"
tail -1 "$work/render.log"
db="sqlite:$work/arscout.db"
alice=$("$bin" token create --db "$db" --role scout --name alice)
# Sparse models only: coverage reads the poses and the tracks.
start_server "$work/server.log" --db "$db" --listen 127.0.0.1:0 --with-engine \
  --no-dense
"$bin" scout --server "$url" --token "$alice" --scout-name alice \
  --dir "$work/site/images" --gps-csv "$work/site/gps.csv" --camera block \
  --camera-k "$work/site/images/K.txt" > "$work/scout.log"
"$bin" summary --db "$db" --wait 600 > "$work/summary.log"
grep -m1 "captures" "$work/summary.log" || true

[ -n "$shots" ] && mkdir -p "$shots"
status=0
SERVER="$url" TOKEN="$alice" SITE_DIR="$work/site" SCREENSHOTS="$shots" \
  CHROMIUM="$chromium" node "$repo/tests/viewer/coverage_browser_test.mjs" ||
  status=$?
if [ "$status" -ne 0 ]; then
  echo "--- server log (last 40 lines)"; tail -40 "$work/server.log"
fi
exit "$status"
