#!/usr/bin/env bash
# Build the catkin workspace (catkin_ws) with the project venv's Python, then the gtest binaries.
#
#   scripts/catkin_build.sh [extra catkin_make / CMake arguments]
#
# Afterwards:  source catkin_ws/devel/setup.bash
#              cmake --build catkin_ws/build --target run_tests && catkin_test_results catkin_ws/build/test_results
#              (or `catkin_make -C catkin_ws run_tests`, which re-runs CMake once; or
#               `cd catkin_ws/build && ctest --output-on-failure`)
# Environment: PG_BUILD_JOBS (default 2), PG_BUILD_TYPE (default Release), PG_PYTHON (default $REPO/.venv/bin/python),
#   PG_BUILD_DIR / PG_DEVEL_DIR (default catkin_ws/build, catkin_ws/devel: a separate pair lets two developers build
#   the same source tree side by side).
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WS="$REPO/catkin_ws"
PYTHON="${PG_PYTHON:-$REPO/.venv/bin/python}"
JOBS="${PG_BUILD_JOBS:-2}"
BUILD_TYPE="${PG_BUILD_TYPE:-Release}"
BUILD_DIR="${PG_BUILD_DIR:-$WS/build}"
DEVEL_DIR="${PG_DEVEL_DIR:-$WS/devel}"

die() { echo "catkin_build.sh: $*" >&2; exit 1; }

command -v catkin_make >/dev/null || die "catkin_make not found (apt-get install catkin ros-core-dev)"
[ -x "$PYTHON" ] || die "no Python interpreter at $PYTHON (make setup creates it)"
[ -d "$WS/src" ] || die "no workspace sources at $WS/src"

# Debian's ROS lives in /usr and needs no /opt/ros/*/setup.bash; catkin_make sets up its own environment.
# Keep a previously sourced workspace from leaking into this build (it would be chained as an underlay).
unset CMAKE_PREFIX_PATH ROS_PACKAGE_PATH
export ROS_PYTHON_VERSION=3

start=$(date +%s)
catkin_make -C "$WS" --build "$BUILD_DIR" -j"$JOBS" \
  -DCATKIN_DEVEL_PREFIX="$DEVEL_DIR" \
  -DPYTHON_EXECUTABLE="$PYTHON" \
  -DPython3_EXECUTABLE="$PYTHON" \
  -DCMAKE_BUILD_TYPE="$BUILD_TYPE" \
  -DCATKIN_ENABLE_TESTING=ON \
  "$@"
# Test binaries are not part of `all`; build them now so run_tests/ctest only run. (Not a second catkin_make: with
# other arguments it would re-run CMake, and again on the next full build.)
cmake --build "$BUILD_DIR" --target tests -- -j"$JOBS"
echo "catkin_build.sh: built $WS in $(( $(date +%s) - start )) s"
