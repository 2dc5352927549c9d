# Shared by the browser tests (browser_test.sh, scout_app_test.sh); source
# it after setting $repo and $chromium.
#
# need_browser: exits 77 (skipped) without Node, Chromium or the npm
# packages, except under CI=true, where that is a failure.
# start_server and skip come from tests/support/serve_script.sh.

# shellcheck source=../support/serve_script.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/serve_script.sh"

need_browser() {
  command -v node > /dev/null || skip "node is not installed (deploy/install-deps.sh)"
  [ -x "$chromium" ] || skip "$chromium is not installed (deploy/install-deps.sh)"
  [ -d "$repo/viewer/web/node_modules/playwright-core" ] ||
    skip "viewer/web/node_modules is missing (npm ci --prefix viewer/web)"
}
