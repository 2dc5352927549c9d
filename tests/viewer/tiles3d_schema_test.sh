#!/usr/bin/env bash
# The viewer_fountain fixture site's 3dtiles export: tileset.json against
# tiles3d_tileset.schema.json (JSON Schema 2020-12 written here from the
# 3D Tiles 1.1 specification's prose; the official schema files could not
# be obtained) with ajv, plus the specification's tree rules
# (tiles3d_schema_test.mjs, Node only). Then two broken copies on disk,
# the root's geometricError dropped and a child's error above its
# parent's, which must be rejected.
#   tiles3d_schema_test.sh ARSCOUT_BINARY FIXTURE_DIR SHARED_DATA
# Exit 77 (skipped) without Node, the npm package or data, except under
# CI=true, where that is a failure.
set -euo pipefail
# shellcheck source=tiles3d_support.sh
source "$(dirname "$0")/tiles3d_support.sh"
tiles3d_setup "$@" ajv

export_site_tileset
check="$repo/tests/viewer/tiles3d_schema_test.mjs"
node "$check" "$tileset"

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
  output=$(node "$check" "$copy" --check-only) || status=$?
  printf '%s\n' "$output" | sed "s|^|  $1: |"
  [ "$status" -eq 1 ] || { echo "FAIL: broken copy $1: exit status $status, expected 1"; exit 1; }
  grep -q -- "$2" <<< "$output" || { echo "FAIL: broken copy $1 did not report: $2"; exit 1; }
}
broken_copy no-root-error "FAIL: schema: /root must have required property 'geometricError'" \
  'delete t.root.geometricError'
broken_copy child-error-above-parent "root/children/0: geometricError 100 exceeds its parent's" \
  't.root.children[0].geometricError = 100'
echo "PASS: both broken copies rejected"
