#!/usr/bin/env bash
# The 3dtiles export of a synthetic street (make_street_site, POINTS
# points, default 20 million) against the official 3D Tiles 1.1 JSON schema
# and the specification's rules (tiles3d_schema_test.mjs --check-only): a
# tileset far deeper than fountain-P11's. CI runs it at 500,000 points;
# the 20-million-point street is `ctest -L long`.
#   tiles3d_street_schema_test.sh ARSCOUT_BINARY MAKE_STREET_SITE SHARED_DATA [POINTS]
# Exit 77 (skipped) without Node, the npm package or the schema files,
# except under CI=true, where that is a failure.
set -euo pipefail
bin=$(realpath "$1")
make_site=$(realpath "$2")
schema_dir="$3/3d-tiles-1.1-schema"
points=${4:-20000000}
repo=$(cd "$(dirname "$0")/../.." && pwd)
# shellcheck source=../support/serve_script.sh
source "$(dirname "$0")/../support/serve_script.sh"
command -v node > /dev/null || skip "node is not installed (deploy/install-deps.sh)"
[ -d "$repo/viewer/web/node_modules/ajv" ] ||
  skip "ajv is missing (npm ci --prefix viewer/web)"
[ -f "$schema_dir/tileset.schema.json" ] ||
  skip "the official 3D Tiles schema is not in $schema_dir (../shared/data/README.md)"

use_work_dir
db="sqlite:$work/arscout.db"
"$make_site" "$db" street "$points"
"$bin" export --db "$db" --site street --format 3dtiles -o "$work/street.zip"
node "$repo/tests/viewer/tiles3d_unzip.mjs" "$work/street.zip" "$work/tileset"
node "$repo/tests/viewer/tiles3d_schema_test.mjs" "$schema_dir" \
  "$work/tileset/street" --check-only
