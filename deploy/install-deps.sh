#!/usr/bin/env bash
# Installs every Debian 12 package arscout needs to build, test and run.
# Idempotent: re-running it only refreshes the package lists and confirms
# that everything is present.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config git clang-format
  # clang-tidy (and run-clang-tidy): the lint step of tests/run_all.sh
  clang-tidy
  # clang and its libFuzzer runtime, for the fuzz build (tests/fuzz)
  clang libclang-rt-14-dev
  # libraries
  libopencv-dev libeigen3-dev libceres-dev libmeshoptimizer-dev
  libsqlite3-dev sqlite3 libpqxx-dev libpq-dev
  libgeographiclib-dev libboost-dev nlohmann-json3-dev libexiv2-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev libspdlog-dev
  libssl-dev openssl
  # expat: the XML parser of the GPX reader (metadata/src/gps_gpx.cpp)
  libexpat1-dev
  # PROJ and its grids (EGM96): the output CRSs of the LAS export
  # (viewer/src/output_crs.cpp); cs2cs (proj-bin) and gdalsrsinfo (gdal-bin)
  # check them independently in the tests
  libproj-dev proj-data proj-bin gdal-bin
  # the scout app's pairing QR code (token create --qr), and zbarimg to
  # read it back in the test
  libqrencode-dev zbar-tools
  # zlib: the decode-budget tests build their PNGs with it
  zlib1g-dev
  # PostgreSQL server for the PostgreSQL backend tests and deployments
  postgresql-15 postgresql-client-15
  # runuser (util-linux) starts the throwaway test server as 'postgres';
  # losetup (mount) and mkfs.ext4/e2fsck (e2fsprogs) give the fault tests
  # a disk of their own to fail (tests/reliability/scratch_disks.h)
  util-linux procps mount e2fsprogs
  # PCL's pcl_ply2pcd: the test that our PLY files open in standard tools
  pcl-tools
  # the web viewer: Node.js for npm (three.js, playwright-core) and
  # Chromium for the browser test
  nodejs chromium
)

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  sudo_cmd=(sudo)
fi

export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update
"${sudo_cmd[@]}" apt-get install -y --no-install-recommends "${packages[@]}"
# Debian's npm, unless the installed Node.js brings its own (NodeSource's
# package does, and conflicts with Debian's npm).
if ! command -v npm > /dev/null; then
  "${sudo_cmd[@]}" apt-get install -y --no-install-recommends npm
fi

# The web viewer's packages, exactly as locked (viewer/web/package-lock.json).
npm ci --prefix "$(dirname "$0")/../viewer/web" --no-audit --no-fund
