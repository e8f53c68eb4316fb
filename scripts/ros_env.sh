# Source me: `source scripts/ros_env.sh` puts the project's ROS environment in the current shell:
# the catkin devel space (pg_msgs, package paths) and the project venv first on PATH, so that rospy nodes
# (`#!/usr/bin/env python3`) run with the venv's Python (torch, pybullet). Debian's ROS needs no /opt/ros setup.
# Environment: PG_DEVEL_DIR (default catkin_ws/devel).
_pg_repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
_pg_devel="${PG_DEVEL_DIR:-$_pg_repo/catkin_ws/devel}"
if [ ! -f "$_pg_devel/setup.bash" ]; then
  echo "ros_env.sh: $_pg_devel/setup.bash not found: run 'make setup' (or 'make build') first" >&2
  return 1 2>/dev/null || exit 1
fi
export ROS_PYTHON_VERSION=3
# catkin's setup scripts read unset variables: allow that while sourcing them, even under `set -u`.
_pg_nounset=$([[ $- == *u* ]] && echo 1 || true)
set +u
# Sourced from a function with no arguments: catkin's setup.sh hands "$@" to _setup_util.py, so a caller's own
# arguments (scripts/demo.sh --help) would otherwise reach it.
_pg_source_devel() { local f="$1"; set --; source "$f"; }  # shellcheck disable=SC1090
_pg_source_devel "$_pg_devel/setup.bash"
unset -f _pg_source_devel
[ -n "$_pg_nounset" ] && set -u
# tests/ros is the pg_tests package of integration test nodes (not built, found through ROS_PACKAGE_PATH).
export ROS_PACKAGE_PATH="$_pg_repo/tests/ros:${ROS_PACKAGE_PATH:-}"
case ":$PATH:" in
  *":$_pg_repo/.venv/bin:"*) ;;
  *) export PATH="$_pg_repo/.venv/bin:$PATH" ;;
esac
export PG_REPO="$_pg_repo"
unset _pg_repo _pg_devel _pg_nounset
