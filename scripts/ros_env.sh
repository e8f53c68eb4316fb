# Source me: `source scripts/ros_env.sh` puts the project's ROS environment in the current shell:
# the catkin devel space (pg_msgs, package paths) and the project venv first on PATH, so that rospy nodes
# (`#!/usr/bin/env python3`) run with the venv's Python (torch, pybullet). Debian's ROS needs no /opt/ros setup.
# Environment: PG_DEVEL_DIR (default catkin_ws/devel); PG_ROS_NETWORK (network, below).
#
# Network: loopback unless asked otherwise. When neither ROS_HOSTNAME nor ROS_IP is set, ROS_HOSTNAME=localhost:
# rosmaster, roslaunch and every rospy node listen on 127.0.0.1 only, and roscpp nodes' topic and service ports too.
# A roscpp node's XML-RPC port ignores the setting (xmlrpcpp binds INADDR_ANY), so this mode also preloads
# devel/lib/libpg_loopback_bind.so (pg_control, src/loopback_bind.c) with PG_LOOPBACK_BIND=1: in every process
# started from this shell, a TCP/UDP bind that libxmlrpcpp makes to 0.0.0.0 or :: binds 127.0.0.1 or ::1
# instead (every other bind is left as asked). The shim's path goes
# first in LD_PRELOAD, before any entries already there; without a built shim nothing is preloaded.
# ROS_MASTER_URI defaults to http://localhost:11311.
# To reach a robot network deliberately: PG_ROS_NETWORK=<this machine's address on it> (an IP sets ROS_IP, a name
# ROS_HOSTNAME; ROS_MASTER_URI defaults to http://<address>:11311): the master, the rospy nodes and roscpp's ports
# then listen on all interfaces (ROS 1 cannot bind one interface), reachable by the drivers and by anyone on that
# network; the shim is not preloaded (an earlier sourcing's entry is taken out of LD_PRELOAD, PG_LOOPBACK_BIND
# unset). ROS_HOSTNAME, ROS_IP or ROS_MASTER_URI set before sourcing are kept as they are (no shim either).
_pg_repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
_pg_devel="${PG_DEVEL_DIR:-$_pg_repo/catkin_ws/devel}"
if [ ! -f "$_pg_devel/setup.bash" ]; then
  echo "ros_env.sh: $_pg_devel/setup.bash not found: run 'make setup' (or 'make build') first" >&2
  return 1 2>/dev/null || exit 1
fi
export ROS_PYTHON_VERSION=3
if [ "${PG_ROS_NET_SET:-}" = "${ROS_HOSTNAME:-}|${ROS_IP:-}|${ROS_MASTER_URI:-}" ]; then
  unset ROS_HOSTNAME ROS_IP ROS_MASTER_URI  # as an earlier sourcing left them: choose again (PG_ROS_NETWORK)
fi
_pg_master="${ROS_MASTER_URI:-}"  # the user's own, before catkin's env hooks default it
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
# Network (header). A master elsewhere without an address of this machine: ROS's own default (all interfaces).
_pg_host="${PG_ROS_NETWORK:-localhost}"
[[ "$_pg_host" == *:* ]] && _pg_host="[$_pg_host]"
export ROS_MASTER_URI="${_pg_master:-http://$_pg_host:11311}"
_pg_loopback=""  # 1: the loopback branch below chose ROS_HOSTNAME=localhost
if [ -z "${ROS_HOSTNAME:-}" ] && [ -z "${ROS_IP:-}" ]; then
  if [[ "${PG_ROS_NETWORK:-}" =~ ^[0-9.]+$ || "${PG_ROS_NETWORK:-}" == *:* ]]; then
    export ROS_IP="$PG_ROS_NETWORK"
  elif [ -n "${PG_ROS_NETWORK:-}" ]; then
    export ROS_HOSTNAME="$PG_ROS_NETWORK"
  elif [[ "$ROS_MASTER_URI" =~ ^http://(localhost|127\.[0-9.]+)(:[0-9]+)?/?$ ]]; then
    export ROS_HOSTNAME=localhost
    _pg_loopback=1
  else
    echo "ros_env.sh: ROS_MASTER_URI=$ROS_MASTER_URI is not this machine: ROS ports listen on all interfaces;" \
         "set PG_ROS_NETWORK (or ROS_IP) to this machine's address on that network" >&2
  fi
fi
export PG_ROS_NET_SET="${ROS_HOSTNAME:-}|${ROS_IP:-}|${ROS_MASTER_URI}"
# Network (header): the loopback bind shim. First take any earlier sourcing's shim out of LD_PRELOAD (whatever devel
# space it came from), keeping the user's own entries in their order; then, in loopback mode with the shim built,
# put it first. ld.so splits LD_PRELOAD at colons and spaces, so a shim path holding either cannot be preloaded.
_pg_shim="$_pg_devel/lib/libpg_loopback_bind.so"
_pg_preload=""
if [[ "${LD_PRELOAD:-}" == *libpg_loopback_bind.so* ]]; then
  IFS=': ' read -r -a _pg_entries <<< "$LD_PRELOAD"
  for _pg_entry in "${_pg_entries[@]}"; do
    [[ -z "$_pg_entry" || "$_pg_entry" == */libpg_loopback_bind.so || "$_pg_entry" == libpg_loopback_bind.so ]] \
      || _pg_preload="${_pg_preload:+$_pg_preload:}$_pg_entry"
  done
  if [ -n "$_pg_preload" ]; then export LD_PRELOAD="$_pg_preload"; else unset LD_PRELOAD; fi
  unset _pg_entries _pg_entry
else
  _pg_preload="${LD_PRELOAD:-}"
fi
unset PG_LOOPBACK_BIND
if [ -n "${_pg_loopback:-}" ] && [ -f "$_pg_shim" ]; then
  if [[ "$_pg_shim" == *[:\ ]* ]]; then
    echo "ros_env.sh: $_pg_shim cannot be preloaded (its path holds a colon or a space): roscpp nodes' XML-RPC" \
         "ports listen on all interfaces" >&2
  else
    export LD_PRELOAD="$_pg_shim${_pg_preload:+:$_pg_preload}" PG_LOOPBACK_BIND=1
  fi
fi
export PG_REPO="$_pg_repo"
unset _pg_repo _pg_devel _pg_nounset _pg_master _pg_host _pg_loopback _pg_shim _pg_preload
