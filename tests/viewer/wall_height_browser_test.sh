#!/usr/bin/env bash
# The fountain wall's height measured in the web viewer from three
# viewpoints (wall_height_browser_test.mjs; playwright-core from
# viewer/web/node_modules, Debian's /usr/bin/chromium) against a server
# holding the fountain-P11 site of the viewer_fountain fixture.
#   wall_height_browser_test.sh ARSCOUT_BINARY FIXTURE_DIR SHARED_DATA
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
start_server "$work/server.log" --db "$db" --listen 127.0.0.1:0
status=0
SERVER="$url" PLANNER_TOKEN=$(cat "$fixture/planner.token") \
  SCREENSHOT="$fixture/wall-height.png" CHROMIUM="$chromium" \
  node "$repo/tests/viewer/wall_height_browser_test.mjs" || status=$?
if [ "$status" -ne 0 ]; then
  echo "--- server log (last 40 lines)"; tail -40 "$work/server.log"
fi
exit "$status"
