#!/usr/bin/env bash
# The glb tiles of the viewer_fountain fixture site's 3dtiles export
# through the Khronos glTF Validator (tiles3d_gltf_test.mjs, npm
# gltf-validator, run by Node; no browser): every tile valid glTF 2.0, no
# file missing or left over, as many vertices as the ecef-ply has points.
#   tiles3d_gltf_test.sh ARSCOUT_BINARY FIXTURE_DIR SHARED_DATA
# Exit 77 (skipped) without Node, the npm package or data, except under
# CI=true, where that is a failure.
set -euo pipefail
bin=$(realpath "$1")
fixture=$2
scene="$3/strecha/fountain-P11"
repo=$(cd "$(dirname "$0")/../.." && pwd)

# serve_script.sh for skip and use_work_dir (no server is started here).
# shellcheck source=../support/serve_script.sh
source "$(dirname "$0")/../support/serve_script.sh"
# shellcheck source=tiles3d_support.sh
source "$(dirname "$0")/tiles3d_support.sh"
command -v node > /dev/null || skip "node is not installed (deploy/install-deps.sh)"
[ -d "$repo/viewer/web/node_modules/gltf-validator" ] ||
  skip "gltf-validator is missing (npm ci --prefix viewer/web)"
[ -d "$scene/images" ] || skip "$scene not found"

export_site_tileset
node "$repo/tests/viewer/tiles3d_gltf_test.mjs" "$tileset" "$ecef_ply"
