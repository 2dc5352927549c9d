#!/usr/bin/env bash
# The mesh exports of a synthetic site (make_mesh_site: two textured
# height-field tiles with their levels of detail, stored as the engine's
# mesh phase stores them), made by `arscout export` as a user gets them,
# read by third-party code (docs/mesh.md, "Exports"):
#   gltf     the stored levels, the glb export and every tile of the
#            3dtiles-mesh export through the Khronos glTF Validator
#            (mesh_gltf_test.mjs): no error, no warning;
#   schema   the 3dtiles-mesh tileset.json against the official 3D Tiles
#            1.1 JSON schema and the specification's prose and tree rules
#            (tiles3d_schema_test.mjs --refine=REPLACE), and a copy with a
#            child's error above its parent's, which must be rejected;
#   browser  the 3dtiles-mesh tileset loaded by 3d-tiles-renderer in
#            headless Chromium (mesh_tiles3d_browser_test.mjs).
#   mesh_export_test.sh MODE ARSCOUT_BINARY MAKE_MESH_SITE SHARED_DATA
# Exit 77 (skipped) without Node, Chromium (browser), the npm packages or
# the schema files (schema), except under CI=true, where that is a failure.
set -euo pipefail
mode=$1
bin=$(realpath "$2")
make_site=$(realpath "$3")
schema_dir="$4/3d-tiles-1.1-schema"
repo=$(cd "$(dirname "$0")/../.." && pwd)
chromium=${CHROMIUM:-/usr/bin/chromium}
# shellcheck source=browser_support.sh
source "$(dirname "$0")/browser_support.sh"

command -v node > /dev/null || skip "node is not installed (deploy/install-deps.sh)"
case $mode in
  gltf) package=gltf-validator ;;
  schema) package=ajv
    [ -f "$schema_dir/tileset.schema.json" ] ||
      skip "the official 3D Tiles schema is not in $schema_dir (../shared/data/README.md)" ;;
  browser) package=3d-tiles-renderer; need_browser ;;
  *) echo "usage: mesh_export_test.sh gltf|schema|browser ARSCOUT MAKE_MESH_SITE SHARED_DATA"; exit 2 ;;
esac
[ -d "$repo/viewer/web/node_modules/$package" ] ||
  skip "$package is missing (npm ci --prefix viewer/web)"

use_work_dir
db="sqlite:$work/arscout.db"
"$make_site" "$db" mesh "$work/levels"
"$bin" export --db "$db" --site mesh --format 3dtiles-mesh -o "$work/mesh-3dtiles.zip"
node "$repo/tests/viewer/tiles3d_unzip.mjs" "$work/mesh-3dtiles.zip" "$work/tileset"
tileset="$work/tileset/mesh"
[ -f "$tileset/tileset.json" ] || { echo "FAIL: the zip has no mesh/tileset.json"; exit 1; }

case $mode in
  gltf)
    "$bin" export --db "$db" --site mesh --format glb -o "$work/mesh.glb"
    node "$repo/tests/viewer/mesh_gltf_test.mjs" "$work/levels" "$work/mesh.glb" "$tileset" ;;
  schema)
    check="$repo/tests/viewer/tiles3d_schema_test.mjs"
    node "$check" "$schema_dir" "$tileset" --check-only --refine=REPLACE
    # A child's error above its parent's must be caught.
    cp -r "$tileset" "$work/broken"
    node -e "const fs = require('fs'); const file = process.argv[1];
             const t = JSON.parse(fs.readFileSync(file, 'utf8'));
             t.root.children[0].children[0].geometricError = 1000;
             fs.writeFileSync(file, JSON.stringify(t));" "$work/broken/tileset.json"
    status=0
    output=$(node "$check" "$schema_dir" "$work/broken" --check-only --refine=REPLACE) || status=$?
    printf '%s\n' "$output" | sed 's|^|  broken: |'
    if [ "$status" -ne 1 ] || ! grep -q "exceeds its parent's" <<< "$output"; then
      echo "FAIL: a child's error above its parent's was not rejected"; exit 1
    fi
    echo "PASS: the broken copy was rejected" ;;
  browser)
    TILESET_DIR="$tileset" ECEF_JSON="$work/levels/finest_ecef.json" TOLERANCE_M=0.01 \
      SCREENSHOT="${MESH_SCREENSHOT:-}" CHROMIUM="$chromium" TIMEOUT_S=90 \
      node "$repo/tests/viewer/mesh_tiles3d_browser_test.mjs" ;;
esac
