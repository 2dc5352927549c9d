#!/usr/bin/env bash
# CTest fixture for the replay regression suite: records a scouting session
# from one of the ../shared/data scenes the way scouts make one, so no
# session file needs committing. `arscout serve` runs on a fresh SQLite
# store, a scout uploads the scene's photos with `arscout scout`, the server
# stops and `arscout session export` writes OUT/SCENE.session (the store
# is then deleted).
#   record_session.sh SCENE ARSCOUT_BINARY OUT SHARED_DATA
# SCENE: entry-P10 (Strecha; simulated fixes from gps.csv, calibrated K) or
# lund (OpenSfM phone photos; the fixes are the server's reading of EXIF).
# Exit 77 (skipped) without the data, except under CI=true.
#
# The server runs without an engine: a session holds only the scouts'
# inputs (docs/sessions.md), so reconstructing here would cost CI a second
# reconstruction per scene and change nothing in the file; the replay test
# is where the engine runs.
set -euo pipefail
name=$1
bin=$(realpath "$2")
out=$3
data=$4
case "$name" in
  entry-P10)
    scene="$data/strecha/entry-P10"
    scout_args=(--gps-csv "$scene/gps.csv" --camera entry-p10
                --camera-k "$scene/images/K.txt")
    cameras=1
    ;;
  lund)
    scene="$data/opensfm/lund"
    scout_args=()
    cameras=0
    ;;
  *) echo "FAIL: unknown scene '$name'"; exit 2 ;;
esac
if [ ! -d "$scene/images" ]; then
  if [ "${CI:-}" = true ]; then
    echo "FAIL: $scene is missing (CI=true requires ../shared/data)"; exit 1
  fi
  echo "SKIP: $scene not found"; exit 77
fi
rm -rf "$out"
mkdir -p "$out/photos"
photos=0
for f in "$scene"/images/*.jpg; do
  ln -s "$f" "$out/photos/"
  photos=$((photos + 1))
done
db="sqlite:$out/arscout.db"
"$bin" token create --db "$db" --role scout --name alice > "$out/scout.token"

# Created before the server starts: the loop below reads it at once.
: > "$out/server.log"
"$bin" serve --db "$db" --listen 127.0.0.1:0 > "$out/server.log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null || true' EXIT
url=""
for _ in $(seq 100); do
  url=$(sed -n 's/^arscout serving .* at \(http[^ ]*\)$/\1/p' "$out/server.log")
  [ -n "$url" ] && break
  sleep 0.1
done
[ -n "$url" ] || { cat "$out/server.log"; echo "FAIL: no server"; exit 1; }

# Half a second apart, a brisk scout: the replay paces the inputs by these
# gaps, so they must be real, but long ones would only make CI wait.
"$bin" scout --server "$url" --token "$(cat "$out/scout.token")" \
  --scout-name alice --dir "$out/photos" --interval 0.5 \
  ${scout_args[@]+"${scout_args[@]}"} | tee "$out/scout.log"
kill -TERM $server
wait $server || true
trap - EXIT

"$bin" session export --db "$db" -o "$out/$name.session" |
  tee "$out/export.log"
# Every photo is an input, and so is the camera where the scout put one.
inputs=$((photos + cameras))
grep -q " $inputs inputs, " "$out/export.log" || {
  echo "FAIL: expected $inputs inputs in the session"; exit 1; }
# The session holds everything the store did that matters here; the store
# itself would only double the fixture's footprint in the build tree.
rm -f "$out"/arscout.db*
touch "$out/ready"
echo "$name session ready in $out/$name.session"
