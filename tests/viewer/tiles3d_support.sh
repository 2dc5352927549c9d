# Shared by the 3D Tiles tests (tiles3d_browser_test.sh,
# tiles3d_gltf_test.sh, tiles3d_schema_test.sh). Sources serve_script.sh
# (skip, use_work_dir).
#
# tiles3d_setup ARSCOUT_BINARY FIXTURE_DIR SHARED_DATA NPM_PACKAGE: sets
# $bin, $fixture, $scene and $repo from the test's arguments; skips (fails
# under CI=true) without Node, viewer/web/node_modules/NPM_PACKAGE or the
# fountain-P11 data.
#
# export_site_tileset: in a fresh $work (use_work_dir from
# ../support/serve_script.sh), a copy of the fixture's database, so that
# the export cannot touch the fixture the other viewer tests read; then the
# one site's `arscout export --format 3dtiles` extracted into
# $work/tileset (sets $tileset, the folder holding tileset.json) and its
# `--format ecef-ply` in $work/site.ecef.ply (sets $ecef_ply). Both come
# from the CLI, the same bytes as GET /v1/sites/{id}/export
# (fountain_site_test.cpp checks that), so what a Cesium user downloads is
# what is tested.
#
# The variables read here are set, and those set here read, by the script
# that sources this file: hence SC2154 and SC2034 off.
# shellcheck shell=bash disable=SC2154,SC2034

# shellcheck source=../support/serve_script.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/serve_script.sh"

tiles3d_setup() {
  bin=$(realpath "$1")
  fixture=$2
  scene="$3/strecha/fountain-P11"
  repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
  command -v node > /dev/null || skip "node is not installed (deploy/install-deps.sh)"
  [ -d "$repo/viewer/web/node_modules/$4" ] ||
    skip "$4 is missing (npm ci --prefix viewer/web)"
  [ -d "$scene/images" ] || skip "$scene not found"
}

export_site_tileset() {
  copy_fixture_store "$fixture"
  # The fixture holds exactly one site (make_fountain_site.sh); `db ls`
  # prints PATH<TAB>KIND<TAB>vVERSION per document.
  local sites
  sites=$("$bin" db ls "$db" '/sites/*' | cut -f1 | sed -n 's|^/sites/\([^/]*\)$|\1|p')
  [ "$(printf '%s\n' "$sites" | grep -c .)" -eq 1 ] || {
    echo "FAIL: expected one site in the fixture, found: ${sites:-none}"; exit 1; }
  site=$sites
  "$bin" export --db "$db" --site "$site" --format 3dtiles -o "$work/site.zip"
  "$bin" export --db "$db" --site "$site" --format ecef-ply -o "$work/site.ecef.ply"
  node "$repo/tests/viewer/tiles3d_unzip.mjs" "$work/site.zip" "$work/tileset"
  # The zip holds SITE/tileset.json and SITE/tiles/*.glb (docs/frames.md).
  tileset="$work/tileset/$site"
  [ -f "$tileset/tileset.json" ] || {
    echo "FAIL: the zip has no $site/tileset.json"; find "$work/tileset" | head; exit 1; }
  ecef_ply="$work/site.ecef.ply"
}
