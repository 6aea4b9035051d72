#!/usr/bin/env bash
# Runs a command with ROS 2 traffic kept on loopback: inside a network namespace that has only `lo`
# (`unshare -n`, when this user may create one), always with the loopback-only Fast DDS profile,
# ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a random ROS_DOMAIN_ID (1-101) unless one is set.
# (rmw_fastrtps gives a LOCALHOST participant Fast DDS's shared-memory transport in code, whatever the
# profile or FASTDDS_BUILTIN_TRANSPORTS say: docs/ros2.md, "What the watchdogs do".)
# Usage: scripts/ros2_isolated.sh COMMAND [ARGS...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
export FASTRTPS_DEFAULT_PROFILES_FILE="$here/fastdds_loopback.xml"
export FASTDDS_DEFAULT_PROFILES_FILE="$here/fastdds_loopback.xml"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-$((RANDOM % 101 + 1))}
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
if [ -z "${SEMEXP_ROS2_NETNS:-}" ] && unshare -n true 2>/dev/null; then
  export SEMEXP_ROS2_NETNS=1
  exec unshare -n bash -c 'ip link set lo up && exec "$@"' bash "$@"
fi
exec "$@"
