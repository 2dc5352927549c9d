#!/usr/bin/env bash
# The glb tiles of the viewer_fountain fixture site's 3dtiles export
# through the Khronos glTF Validator (tiles3d_gltf_test.mjs, npm
# gltf-validator, run by Node; no browser): every tile valid glTF 2.0, no
# file missing or left over, as many vertices as the ecef-ply has points.
#   tiles3d_gltf_test.sh ARSCOUT_BINARY FIXTURE_DIR SHARED_DATA
# Exit 77 (skipped) without Node, the npm package or data, except under
# CI=true, where that is a failure.
set -euo pipefail
# shellcheck source=tiles3d_support.sh
source "$(dirname "$0")/tiles3d_support.sh"
tiles3d_setup "$@" gltf-validator

export_site_tileset
node "$repo/tests/viewer/tiles3d_gltf_test.mjs" "$tileset" "$ecef_ply"
