#!/usr/bin/env bash
# The web viewer in real headless Chromium (browser_test.mjs, playwright-core
# from viewer/web/node_modules, Debian's /usr/bin/chromium) against a server
# holding the fountain-P11 site of the viewer_fountain fixture: the site
# list's counts, the point cloud drawn, then one more capture uploaded
# through the API and the new model version shown without a page reload.
#   browser_test.sh ARSCOUT_BINARY FIXTURE_DIR SHARED_DATA
# Exit 77 (skipped) without Node, Chromium, npm packages or data, except
# under CI=true, where that is a failure.
set -euo pipefail
bin=$(realpath "$1")
fixture=$2
scene="$3/strecha/fountain-P11"
repo=$(cd "$(dirname "$0")/../.." && pwd)
chromium=${CHROMIUM:-/usr/bin/chromium}

# shellcheck source=browser_support.sh
source "$(dirname "$0")/browser_support.sh"
need_browser
[ -d "$scene/images" ] || skip "$scene not found"
copy_fixture_store "$fixture"
start_server "$work/server.log" --db "$db" --listen 127.0.0.1:0 --with-engine \
  --dense-long-side 480

# The photo kept back, with its row of gps.csv as the scout would send it.
row=$(grep '^0010.jpg,' "$scene/gps.csv")
IFS=, read -r _ lat lon alt hacc vacc <<< "$row"
meta=$(printf '{"capture_id":"0010.jpg","filename":"0010.jpg","camera":"fountain-p11","gps":{"lat":%s,"lon":%s,"alt":%s,"h_acc":%s,"v_acc":%s}}' \
  "$lat" "$lon" "$alt" "$hacc" "$vacc")
status=0
SERVER="$url" PLANNER_TOKEN=$(cat "$fixture/planner.token") \
  SCOUT_TOKEN=$(cat "$fixture/scout.token") EXPECT_CAPTURES=10 \
  EXPECT_REGISTERED=10 UPLOAD_IMAGE="$scene/images/0010.jpg" \
  UPLOAD_META="$meta" SCREENSHOT="$fixture/viewer.png" TIMEOUT_S=300 \
  CHROMIUM="$chromium" node "$repo/tests/viewer/browser_test.mjs" || status=$?
if [ "$status" -ne 0 ]; then
  echo "--- server log (last 40 lines)"; tail -40 "$work/server.log"
fi
exit "$status"
