#!/usr/bin/env bash
# The 3dtiles export of the viewer_fountain fixture's site, loaded by a
# third-party client, 3d-tiles-renderer (npm) on three.js, in real headless
# Chromium (tiles3d_browser_test.mjs, playwright-core and Debian's
# /usr/bin/chromium): every tile must load, and every point, placed in ECEF
# by the library's own tile transforms and glTF axis handling, must lie
# within 0.01 m of a point of the site's ecef-ply export, with the same
# point count. This is what a Cesium user downloading the zip relies on.
#   tiles3d_browser_test.sh ARSCOUT_BINARY FIXTURE_DIR SHARED_DATA
# Exit 77 (skipped) without Node, Chromium, npm packages or data, except
# under CI=true, where that is a failure.
set -euo pipefail
chromium=${CHROMIUM:-/usr/bin/chromium}

# shellcheck source=browser_support.sh
source "$(dirname "$0")/browser_support.sh"
# shellcheck source=tiles3d_support.sh
source "$(dirname "$0")/tiles3d_support.sh"
tiles3d_setup "$@" 3d-tiles-renderer
need_browser

export_site_tileset
TILESET_DIR="$tileset" ECEF_PLY="$ecef_ply" TOLERANCE_M=0.01 \
  SCREENSHOT="$fixture/tiles3d.png" CHROMIUM="$chromium" TIMEOUT_S=90 \
  node "$repo/tests/viewer/tiles3d_browser_test.mjs"
