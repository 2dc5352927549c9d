#!/usr/bin/env bash
# The main job: the whole system on the embedded SQLite default. An API
# server with an engine worker in the same process (`arscout serve
# --with-engine`), and two scouts uploading at the same time over HTTP:
# ../shared/data/strecha/fountain-P11 (with its gps.csv and K.txt) and
# ../shared/data/opensfm/lund (GPS from EXIF). Without ../shared/data one
# scout uploads a rendered synthetic street instead. It ends with a summary
# of the sites, their model versions and registered counts, and writes the
# models as PLY files.
#
#   deploy/main-job.sh            (after cmake --build build --target arscout)
#
# Environment: ARSCOUT_BIN (default build/cli/arscout), ARSCOUT_MAIN_JOB_DIR
# (default arscout-main-job: the database, logs and models),
# ARSCOUT_DATA (default ../shared/data), ARSCOUT_MAIN_JOB_SERVE=1 (keep
# serving the API and the web viewer after the summary, until Ctrl-C).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${ARSCOUT_BIN:-build/cli/arscout}
work=${ARSCOUT_MAIN_JOB_DIR:-arscout-main-job}
data=${ARSCOUT_DATA:-../shared/data}
[ -x "$bin" ] || { echo "main job: $bin not built (cmake --build build --target arscout)" >&2; exit 1; }

rm -rf "$work"
mkdir -p "$work"
db="sqlite:$work/arscout.db"
server_pid=""
cleanup() { [ -n "$server_pid" ] && kill "$server_pid" 2>/dev/null || true; }
trap cleanup EXIT

echo "== arscout main job: server + engine on $db"
alice=$("$bin" token create --db "$db" --role scout --name alice)
bob=$("$bin" token create --db "$db" --role scout --name bob)

# Created before the server starts: the loop below reads it at once.
: > "$work/server.log"
# At info the log holds the engine's progress (event=engine) and one line
# per request (event=request); only the engine's are shown below.
"$bin" --log-level info serve --db "$db" --listen 127.0.0.1:0 --with-engine \
  > "$work/server.log" 2>&1 &
server_pid=$!
for _ in $(seq 100); do
  url=$(sed -n 's/^arscout serving .* at \(http[^ ]*\)$/\1/p' "$work/server.log")
  [ -n "$url" ] && break
  kill -0 "$server_pid" 2>/dev/null || { cat "$work/server.log"; exit 1; }
  sleep 0.1
done
[ -n "$url" ] || { echo "main job: the server did not start" >&2; exit 1; }
planner=$("$bin" token create --db "$db" --role planner --name planner)
echo "== server at $url (log: $work/server.log); engine lines follow"
echo "== planners: open $url/ in a browser while it runs, token $planner"
tail -f "$work/server.log" --pid "$server_pid" |
  sed -un 's/.* level=info event=engine msg="\(.*\)"$/   engine  \1/p' &

fountain="$data/strecha/fountain-P11"
lund="$data/opensfm/lund"
if [ -d "$fountain/images" ] && [ -d "$lund/images" ]; then
  echo "== two scouts: alice walks fountain-P11, bob walks lund"
  "$bin" scout --server "$url" --token "$alice" --scout-name alice \
    --dir "$fountain/images" --gps-csv "$fountain/gps.csv" \
    --camera fountain-p11 --camera-k "$fountain/images/K.txt" \
    --interval 2 | sed -u 's/^/   alice   /' &
  scout_a=$!
  "$bin" scout --server "$url" --token "$bob" --scout-name bob \
    --dir "$lund/images" --interval 1 | sed -u 's/^/   bob     /' &
  scout_b=$!
  wait "$scout_a"
  wait "$scout_b"
else
  echo "== $data not found: alice walks a rendered synthetic street"
  "$bin" render-site --out "$work/synthetic" > /dev/null
  "$bin" scout --server "$url" --token "$alice" --scout-name alice \
    --dir "$work/synthetic/images" --gps-csv "$work/synthetic/gps.csv" \
    --camera synthetic --camera-k "$work/synthetic/images/K.txt" \
    --interval 1 | sed -u 's/^/   alice   /'
fi

echo "== uploads done; waiting for the engine to finish"
"$bin" summary --db "$db" --wait 900 --models "$work/models"
echo
echo "models: $work/models/SITE/{sparse,dense}.ply; the same files are served"
echo "at $url/v1/blobs/SHA256 (GET /v1/docs/sites/SITE/model names them)"
if [ "${ARSCOUT_MAIN_JOB_SERVE:-0}" = 1 ]; then
  echo "== still serving at $url/ (planner token $planner); Ctrl-C stops"
  wait "$server_pid"
fi
