# Shared by the browser tests (browser_test.sh, scout_app_test.sh); source
# it after setting $repo and $chromium.
#
# need_browser: exits 77 (skipped) without Node, Chromium or the npm
# packages, except under CI=true, where that is a failure.
# start_server LOG ARGS...: runs `$bin serve ARGS...` in the background with
# its output in LOG, sets $server (the pid) and $url (its address), or
# fails with the log.

skip() {
  if [ "${CI:-}" = true ]; then echo "FAIL: $1 (required under CI=true)"; exit 1; fi
  echo "SKIP: $1"; exit 77
}

need_browser() {
  command -v node > /dev/null || skip "node is not installed (deploy/install-deps.sh)"
  [ -x "$chromium" ] || skip "$chromium is not installed (deploy/install-deps.sh)"
  [ -d "$repo/viewer/web/node_modules/playwright-core" ] ||
    skip "viewer/web/node_modules is missing (npm ci --prefix viewer/web)"
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
