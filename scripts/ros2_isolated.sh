#!/usr/bin/env bash
# Runs a command with ROS 2 traffic kept on loopback: inside a network namespace that has only `lo`
# (`unshare -n`, when this user may create one), always with the loopback-only Fast DDS profile,
# ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, UDP as the only transport and a random ROS_DOMAIN_ID (1-101)
# unless one is set.
# Usage: scripts/ros2_isolated.sh COMMAND [ARGS...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
export FASTRTPS_DEFAULT_PROFILES_FILE="$here/fastdds_loopback.xml"
export FASTDDS_DEFAULT_PROFILES_FILE="$here/fastdds_loopback.xml"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
# rmw_fastrtps adds Fast DDS's shared-memory transport to a LOCALHOST participant, whatever the profile says;
# a process SIGKILLed while holding its shared-memory port's lock then blocks its peers' publishes for about
# 2 s (a tick thread stuck in SharedMemManager::Port::try_push; docs/ros2.md, session 28). UDP only:
export FASTDDS_BUILTIN_TRANSPORTS=UDPv4
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-$((RANDOM % 101 + 1))}
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
if [ -z "${SEMEXP_ROS2_NETNS:-}" ] && unshare -n true 2>/dev/null; then
  export SEMEXP_ROS2_NETNS=1
  exec unshare -n bash -c 'ip link set lo up && exec "$@"' bash "$@"
fi
exec "$@"
