# For test scripts that run `arscout serve`; source it after setting $bin
# (the arscout executable).
#
# skip WHY: exits 77 (skipped), except under CI=true, where it fails.
# use_work_dir: sets $work to a fresh folder; on exit the server started
# by start_server is stopped and the folder removed.
# copy_fixture_store FIXTURE: use_work_dir, then a copy of the SQLite store
# of the viewer_fountain fixture in FIXTURE (make_fountain_site.sh) in
# $work, its URL in $db; fails when the fixture is not ready.
# start_server LOG ARGS...: runs `$bin serve ARGS...` in the background with
# its output in LOG, sets $server (the pid) and $url (its address, http or
# https), or fails with the log.

skip() {
  if [ "${CI:-}" = true ]; then echo "FAIL: $1 (required under CI=true)"; exit 1; fi
  echo "SKIP: $1"; exit 77
}

start_server() {
  local log=$1; shift
  : > "$log"
  "$bin" serve "$@" >> "$log" 2>&1 &
  server=$!
  url=""
  for _ in $(seq 100); do
    url=$(sed -n 's/^arscout serving .* at \(http[^ ]*\)$/\1/p' "$log")
    [ -n "$url" ] && return 0
    sleep 0.1
  done
  cat "$log"; echo "FAIL: no server"; exit 1
}

use_work_dir() {
  work=$(mktemp -d)
  server=""
  trap 'if [ -n "$server" ]; then kill "$server" 2>/dev/null; wait "$server" 2>/dev/null; fi; rm -rf "$work"' EXIT
}

copy_fixture_store() {
  [ -f "$1/ready" ] || { echo "FAIL: no fountain site in $1"; exit 1; }
  use_work_dir
  cp "$1"/arscout.db* "$work/"
  db="sqlite:$work/arscout.db"
}
