#!/usr/bin/env bash
# Every test tier of `make test`: lint, C++ gtests (catkin), then Python core and integration tests (pytest, last
# so its summary line closes the run). Fails when any tier fails.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
cd "$repo"
py="$repo/.venv/bin/python"

echo "== ruff"
"$py" -m ruff check .

echo "== gtest (catkin, via ctest)"
ctest --test-dir catkin_ws/build --output-on-failure

echo "== pytest (core, message and bag tests; rostests via tests/test_rostests.py)"
# The devel space puts pg_msgs on the Python path for the message tests; rostests source it themselves.
# shellcheck disable=SC1091
source "$repo/scripts/ros_env.sh"
"$py" -m pytest -q -p no:cacheprovider "$@"
