#!/usr/bin/env bash
# Saves the view of the README's mission while its world process (the saved view's Rerun logger, a
# child of the mission) is stopped for a while, then prints the manifest's frame counts: what a child
# that stops reading costs the recording (docs/viewer.md, session 27).
# Usage: scripts/pause_world_process.sh DIR [PAUSE_AFTER_S] [PAUSE_S]
set -euo pipefail
dir=${1:?usage: scripts/pause_world_process.sh DIR [PAUSE_AFTER_S] [PAUSE_S]}
pause_after_s=${2:-4}
pause_s=${3:-15}
root=$(cd "$(dirname "$0")/.." && pwd)
rm -rf "$dir"
MUJOCO_GL=${MUJOCO_GL:-egl} "$root/.venv/bin/semexp-bt" run "$root/trees/object_search.yaml" \
  --scene road --seed 0 --view-record "$dir" &
mission=$!
sleep "$pause_after_s"
child=$(pgrep -P "$mission" -f serve_world_on || true)
if [ -z "$child" ]; then
  echo "no world process under the mission (pid $mission)" >&2
  kill "$mission"
  exit 1
fi
kill -STOP "$child"
echo "world process $child stopped for $pause_s s"
sleep "$pause_s"
kill -CONT "$child"
wait "$mission"
"$root/.venv/bin/python" -c 'import json, sys; m = json.load(open(sys.argv[1])); print("frames", m["frames"], "worker errors", m["worker_errors"])' "$dir/manifest.json"
