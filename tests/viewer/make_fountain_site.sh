#!/usr/bin/env bash
# CTest fixture for the viewer tests: a SQLite store holding the
# fountain-P11 site built the way scouts build it. `arscout serve
# --with-engine --mesh` runs (the textured mesh is made in the dense lane
# with the dense tiles, so waiting for the dense cloud waits for it too); a
# scout uploads 10 of the 11 photos (0010.jpg is kept
# back for the browser test to upload) with `--overlay`, so the scout's AR
# overlay path is exercised too; `arscout summary --wait` waits for the
# engine; the server stops; the model must name a mesh (mesh_tiles). Leaves in OUT: arscout.db, scout.token,
# planner.token, overlays/, ready.
#   make_fountain_site.sh ARSCOUT_BINARY OUT SHARED_DATA
# Exit 77 (skipped) without the data, except under CI=true.
set -euo pipefail
bin=$(realpath "$1")
out=$2
scene="$3/strecha/fountain-P11"
if [ ! -d "$scene/images" ]; then
  if [ "${CI:-}" = true ]; then
    echo "FAIL: $scene is missing (CI=true requires ../shared/data)"; exit 1
  fi
  echo "SKIP: $scene not found"; exit 77
fi
rm -rf "$out"
mkdir -p "$out/photos"
for f in "$scene"/images/*.jpg; do
  [ "$(basename "$f")" = 0010.jpg ] || ln -s "$f" "$out/photos/"
done
db="sqlite:$out/arscout.db"
"$bin" token create --db "$db" --role scout --name alice > "$out/scout.token"
"$bin" token create --db "$db" --role planner --name pat > "$out/planner.token"

"$bin" serve --db "$db" --listen 127.0.0.1:0 --with-engine \
  --dense-long-side 480 --mesh > "$out/server.log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null || true' EXIT
url=""
for _ in $(seq 100); do
  url=$(sed -n 's/^arscout serving .* at \(http[^ ]*\)$/\1/p' "$out/server.log")
  [ -n "$url" ] && break
  sleep 0.1
done
[ -n "$url" ] || { cat "$out/server.log"; echo "FAIL: no server"; exit 1; }

"$bin" scout --server "$url" --token "$(cat "$out/scout.token")" \
  --scout-name alice --dir "$out/photos" --gps-csv "$scene/gps.csv" \
  --camera fountain-p11 --camera-k "$scene/images/K.txt" \
  --overlay "$out/overlays" --overlay-timeout 300 | tee "$out/scout.log"
"$bin" summary --db "$db" --wait 600 | tee "$out/summary.log"
kill -TERM $server
wait $server || true
trap - EXIT

grep -q "captures 10: 10 registered" "$out/summary.log" || {
  echo "FAIL: not all 10 photos registered"; exit 1; }
# The scout saved an overlay per photo once the engine had registered it.
grep -q "^10 overlays saved in $out/overlays" "$out/scout.log" || {
  echo "FAIL: the scout did not save 10 overlays"; exit 1; }
# Each photo's verdict with the model version that holds it.
[ "$(grep -c '^[0-9]*\.jpg  registered · site .* · model v[1-9][0-9]*$' "$out/scout.log")" -eq 10 ] || {
  echo "FAIL: the scout did not print 10 'registered · site S · model vN' lines"; exit 1; }
for f in "$out"/overlays/*.overlay.jpg; do
  head -c 3 "$f" | od -An -tx1 | grep -q "ff d8 ff" || {
    echo "FAIL: $f is not a JPEG"; exit 1; }
done
# The textured mesh, made with the dense cloud.
grep -q "^  mesh: [1-9][0-9]* tiles\?, [1-9][0-9]* triangles" "$out/summary.log" || {
  echo "FAIL: the model has no textured mesh (mesh_tiles with levels)"; exit 1; }
touch "$out/ready"
echo "fountain site ready in $out"
