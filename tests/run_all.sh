#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run, the README's test command),
# from the repository root, after deploy/install-deps.sh:
#
#  1. the default build (build/, RelWithDebInfo, the system compiler), the
#     lint step (tests/lint.sh: clang-format and clang-tidy, any finding
#     fails; about 7 minutes), and every test but the `long` ones;
#  2. an AddressSanitizer + UndefinedBehaviorSanitizer build (build-san/,
#     clang, with the libFuzzer targets of tests/fuzz) and the same tests
#     but the `engine-data` and `engine-synthetic` ones (whole
#     reconstructions of real photos and of the rendered block walk), plus
#     a short run of each fuzz target
#     (label `fuzz`). The engine-data tests reconstruct real photo sets end
#     to end; under ASan they take about 40 minutes more on 2 cores, past
#     CI's limit, and they exercise the code the synthetic engine tests do
#     (docs/RELIABILITY.md says when they last ran under ASan).
#
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
    -DARSCOUT_CLI_UNITY=OFF -DARSCOUT_DEBUG_INFO=none
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
    -DARSCOUT_WHOLE_RUN_TESTS=OFF
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
