#!/usr/bin/env bash
# The scout app (viewer/web/scout) in real headless Chromium with a phone
# viewport and touch (scout_app_test.mjs) against a fresh
# `arscout serve --with-engine` on SQLite: two scouts, fountain-P11's
# photos through a fake camera, the network cut and the page reloaded
# mid-queue, withdrawal, a refused photo and a revoked token.
#   scout_app_test.sh ARSCOUT_BINARY SHARED_DATA [SCREENSHOT_DIR]
# Exit 77 (skipped) without Node, Chromium, npm packages or data, except
# under CI=true, where that is a failure.
set -euo pipefail
bin=$(realpath "$1")
scene="$2/strecha/fountain-P11"
shots=${3:-}
repo=$(cd "$(dirname "$0")/../.." && pwd)
chromium=${CHROMIUM:-/usr/bin/chromium}

# shellcheck source=browser_support.sh
source "$(dirname "$0")/browser_support.sh"
need_browser
[ -d "$scene/images" ] || skip "$scene not found"

use_work_dir
db="sqlite:$work/arscout.db"
alice=$("$bin" token create --db "$db" --role scout --name alice)
bob=$("$bin" token create --db "$db" --role scout --name bob)
admin=$("$bin" token create --db "$db" --role admin --name ops)
start_server "$work/server.log" --db "$db" --listen 127.0.0.1:0 --with-engine \
  --dense-long-side 480 --mesh

[ -n "$shots" ] && mkdir -p "$shots"
status=0
SERVER="$url" ALICE_TOKEN="$alice" BOB_TOKEN="$bob" ADMIN_TOKEN="$admin" \
  SCENE="$scene" SCREENSHOTS="$shots" CHROMIUM="$chromium" \
  node "$repo/tests/viewer/scout_app_test.mjs" || status=$?
if [ "$status" -ne 0 ]; then
  echo "--- server log (last 60 lines)"; tail -60 "$work/server.log"
fi
exit "$status"
