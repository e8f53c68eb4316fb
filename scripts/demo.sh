#!/usr/bin/env bash
# `make demo`: the ROS stack headless in simulation (sim.launch on a packed scene, /pg/grasp_target for the green
# target); see catkin_ws/src/pg_policy/src/pg_policy/ros/demo.py. Options: scripts/demo.sh --help.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
cd "$repo"
# shellcheck disable=SC1091
source "$repo/scripts/ros_env.sh"
exec python -m pg_policy.ros.demo "$@"
