#!/usr/bin/env bash
# The viewer_fountain fixture site's 3dtiles export: tileset.json against
# the official 3D Tiles 1.1 JSON schema (SHARED_DATA/3d-tiles-1.1-schema)
# with ajv, plus the specification's rules the schema leaves to its prose
# and the tree rules (tiles3d_schema_test.mjs, Node only). Then broken
# copies on disk, the ones the issue names among them (geometricError
# missing, a wrong asset.version, a refine outside ADD/REPLACE, a box of 11
# numbers, a child's error above its parent's), which must be rejected.
#   tiles3d_schema_test.sh ARSCOUT_BINARY FIXTURE_DIR SHARED_DATA
# Exit 77 (skipped) without Node, the npm package, the data or the schema
# files, except under CI=true, where that is a failure.
set -euo pipefail
# shellcheck source=tiles3d_support.sh
source "$(dirname "$0")/tiles3d_support.sh"
tiles3d_setup "$@" ajv
schema_dir="$3/3d-tiles-1.1-schema"
[ -f "$schema_dir/tileset.schema.json" ] ||
  skip "the official 3D Tiles schema is not in $schema_dir (../shared/data/README.md)"

export_site_tileset
check="$repo/tests/viewer/tiles3d_schema_test.mjs"
node "$check" "$schema_dir" "$tileset"

# broken_copy NAME EXPECTED JS: $tileset copied to $work/NAME, its
# tileset.json changed by JS (a function body given `t`, the parsed JSON);
# the check must exit 1 and print EXPECTED.
broken_copy() {
  local copy="$work/$1"
  cp -r "$tileset" "$copy"
  node -e "const fs = require('fs'); const file = process.argv[1];
           const t = JSON.parse(fs.readFileSync(file, 'utf8')); $3;
           fs.writeFileSync(file, JSON.stringify(t));" "$copy/tileset.json"
  local status=0 output
  output=$(node "$check" "$schema_dir" "$copy" --check-only) || status=$?
  printf '%s\n' "$output" | sed "s|^|  $1: |"
  [ "$status" -eq 1 ] || { echo "FAIL: broken copy $1: exit status $status, expected 1"; exit 1; }
  grep -q -- "$2" <<< "$output" || { echo "FAIL: broken copy $1 did not report: $2"; exit 1; }
}
broken_copy no-root-error "FAIL: schema: /root must have required property 'geometricError'" \
  'delete t.root.geometricError'
broken_copy child-error-above-parent "root/children/0: geometricError 100 exceeds its parent's" \
  't.root.children[0].geometricError = 100'
broken_copy asset-version-2 "FAIL: asset.version 2.0, the export writes 1.1" \
  't.asset.version = "2.0"'
broken_copy refine-merge 'FAIL: root: refine "MERGE" is neither ADD nor REPLACE' \
  't.root.refine = "MERGE"'
broken_copy box-of-11 "FAIL: schema: /root/boundingVolume/box must NOT have fewer than 12 items" \
  't.root.boundingVolume.box.pop()'
echo "PASS: every broken copy rejected"
