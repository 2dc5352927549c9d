#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run, the README's test command),
# from the repository root, after deploy/install-deps.sh. Every test runs
# once, in one of two trees:
#
#  1. the default build (build/, RelWithDebInfo without debug information,
#     the system compiler), the lint step (tests/lint.sh: clang-format and
#     clang-tidy, any finding fails), and the tests that reconstruct whole
#     photo sets (labels engine-data, engine-synthetic, browser: the real
#     photos, the rendered block walks, the 20-million-point street in
#     Chromium), which need an optimized build;
#  2. an AddressSanitizer + UndefinedBehaviorSanitizer build (build-san/,
#     clang, -O1, with the libFuzzer targets of tests/fuzz) and every other
#     test: the unit and integration tests of every library, the servers,
#     the CLI, the reliability tests, and a short run of each fuzz target
#     (label `fuzz`). The whole-reconstruction tests are left out there:
#     under ASan they take about 40 minutes more on 2 cores, past CI's
#     limit, and they run the code the unit tests run under the sanitizers
#     (docs/RELIABILITY.md says when they last ran under ASan).
#
# The default half's tree is configured without the unit tests
# (-DARSCOUT_UNIT_TESTS=OFF): a build/ made by this script runs only the
# whole reconstructions; configure it with -DARSCOUT_UNIT_TESTS=ON for all.
# Either half alone: `tests/run_all.sh default` or `tests/run_all.sh san`.
# The long runs (`ctest -L long`, docs/RELIABILITY.md) are left to people.
set -euo pipefail
cd "$(dirname "$0")/.."
which=${1:-all}
case "$which" in all | default | san) ;; *)
  echo "usage: tests/run_all.sh [all|default|san]" >&2
  exit 2
  ;;
esac

# Each half prints its minutes: CI stops at 90, the target is 60 in all.
minutes_since() { echo "$(((SECONDS - $1 + 30) / 60))"; }

if [ "$which" != san ]; then
  started=$SECONDS
  echo "== default build: build/"
  # RelWithDebInfo named, not defaulted: the README's main job may have
  # configured build/ for Release first. The CLI file by file, not as a
  # unity build: clang-tidy (tests/lint.sh) checks each file's own command.
  # No debug information (ARSCOUT_DEBUG_INFO=none): CI steps through nothing,
  # and it is a quarter of the build's time on 2 cores.
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DARSCOUT_CLI_UNITY=OFF -DARSCOUT_DEBUG_INFO=none \
    -DARSCOUT_UNIT_TESTS=OFF -DARSCOUT_WHOLE_RUN_TESTS=ON
  cmake --build build
  echo "== default build: $(minutes_since "$started") minutes"
  # Formatting and clang-tidy on the production code (tests/lint.sh).
  tests/lint.sh build
  echo "== default build and lint: $(minutes_since "$started") minutes"
  ctest --test-dir build --output-on-failure -j2 -LE long
  echo "== default half: $(minutes_since "$started") minutes"
fi

if [ "$which" != default ]; then
  started=$SECONDS
  echo "== AddressSanitizer + UndefinedBehaviorSanitizer build: build-san/"
  # Line tables only, for file:line in the reports; without the programs of
  # the whole-reconstruction tests, which this half does not run.
  cmake -S . -B build-san -G Ninja -DCMAKE_CXX_COMPILER=clang++ \
    -DARSCOUT_SANITIZE=ON -DARSCOUT_FUZZ=ON -DARSCOUT_DEBUG_INFO=lines \
    -DARSCOUT_WHOLE_RUN_TESTS=OFF -DARSCOUT_UNIT_TESTS=ON
  cmake --build build-san
  echo "== sanitizer build: $(minutes_since "$started") minutes"
  # Any report (leaks included) fails the test that triggered it: the
  # build stops at the first UBSan finding, and ASan exits non-zero. The
  # browser-scale test (20 million points through the server) runs in the
  # default half only; its server code is unit-tested here.
  UBSAN_OPTIONS=print_stacktrace=1 \
    ctest --test-dir build-san --output-on-failure -j2 \
    -LE 'long|engine-data|engine-synthetic|browser'
  echo "== sanitizer half: $(minutes_since "$started") minutes"
fi
