"""Where a lockstep tick's wall time goes: a ROS 2 mission with every robot call and bridge handler timed.

Run it in the ROS 2 environment, on loopback only::

    scripts/ros2_isolated.sh .venv-ros2/bin/python scripts/profile_ros2_lockstep.py --budget-s 60

It runs the bench's episode (showroom seed 9, kinematic, lexical relevance; the mission's budget cut to
``--budget-s``) over ROS 2 in lockstep, with the bridge and the executive each started through a wrapper
that times, with ``time.perf_counter``, every call of what :data:`EXECUTIVE_CALLS` and :data:`BRIDGE_CALLS`
name, and reads each thread's CPU time from
``/proc`` at the end (the tick thread, rclpy's executor thread, Fast DDS's own threads). It prints, per
process, each call's count, total and mean, and the per-tick share (total / ticks), as JSON.

The timers wrap methods, so the figures include the wrappers' own cost (about 1 us a call). The bridge's
``step`` counts its speculative steps too (``_speculate``; ``--no-speculation`` turns them off).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.ros2_support import mission_with_budget, run_bridge_and_executive  # noqa: E402

#: What is timed on the executive's side, ``module:attribute`` (a class's method or a module's function):
#: the robot calls of the tree, the backend's callbacks, rclpy's publish.
EXECUTIVE_CALLS = (
    *(
        f"robots.ros2_backend:Ros2Robot.{name}"
        for name in (
            "advance",
            "observe",
            "observe_depth",
            "base_pose",
            "base_twist",
            "imu",
            "joint_state",
            "safety",
            "now_s",
            "command_twist",
            "_on_odom",
            "_on_sim_time",
            "_on_heartbeat",
            "_record",
            "_send_command",
            "_request_frame",
            "_observation",
            "_on_state",
            "_step_to",
        )
    ),
    *(
        f"robots.ros2_backend:{name}"
        for name in ("image_to_depth_m", "image_to_rgb", "image_to_segmentation", "camera_info_to_intrinsics")
    ),
    "rclpy.publisher:Publisher.publish",
    # The navigation stack's hot calls: the same work as in process, so a per-call cost above the
    # in-process one is the process's, not the hand-over's (docs/ros2.md, "The C heap").
    "behaviours.follow_path:FollowPath.update",
    "semexp_bt.nav.dwb:DwbController.compute",
    "semexp_bt.nav.costmap:Costmap.distance_at",
)
#: What is timed on the bridge's side.
BRIDGE_CALLS = (
    *(
        f"sims.ros2_bridge:SimBridge.{name}"
        for name in (
            "_on_step",
            "_speculate",
            "_send_state",
            "_catch_up",
            "_take_back_speculation",
            "step",
            "publish_state",
            "publish_frame",
            "_on_camera_request",
            "_on_cmd_vel",
        )
    ),
    *(
        f"robots.mujoco_backend:MujocoRobot.{name}"
        for name in ("base_odometry", "base_twist", "imu", "joint_state", "observe", "observe_depth", "now_s")
    ),
    "sims.ros2_bridge:fill_odometry",
    *(
        f"sims.ros2_bridge:{name}"
        for name in ("fill_camera_info", "fill_depth_image", "fill_rgb_image", "fill_segmentation_image")
    ),
    "rclpy.publisher:Publisher.publish",
)
#: Calls whose every duration is kept (their distribution, not only the mean).
DISTRIBUTIONS = ("Ros2Robot.observe", "Ros2Robot.observe_depth", "Ros2Robot.advance")

#: The wrapper each process starts with: it patches the callables, runs the CLI, and dumps the counters
#: (the executive's before ``Ros2Robot.close``, while its threads live; the bridge's after its run).
WRAPPER = r"""
import json, os, sys, threading, time, collections
sys.path.insert(0, os.getcwd())
targets, dump, kept = sys.argv[1].split(","), sys.argv[2], sys.argv[3].split(",")
totals = collections.defaultdict(float)
counts = collections.defaultdict(int)
durations = collections.defaultdict(list)
def timed(name, fn):
    keep = durations[name].append if name in kept else None
    def wrapper(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            dt = time.perf_counter() - t0
            totals[name] += dt
            counts[name] += 1
            if keep is not None:
                keep(dt)
    return wrapper
for target in targets:
    module_name, path = target.split(":")
    owner = __import__(module_name, fromlist=["_"])
    *outer, attribute = path.split(".")
    for part in outer:
        owner = getattr(owner, part)
    setattr(owner, attribute, timed(path, getattr(owner, attribute)))
def thread_cpu():
    tick = os.sysconf("SC_CLK_TCK")
    names = {t.native_id: t.name for t in threading.enumerate()}
    out = collections.defaultdict(float)
    for tid in os.listdir("/proc/self/task"):
        try:
            comm = open(f"/proc/self/task/{tid}/comm").read().strip()
            fields = open(f"/proc/self/task/{tid}/stat").read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        out[names.get(int(tid), comm)] += (int(fields[11]) + int(fields[12])) / tick
    return dict(out)
def write():
    json.dump({"totals_s": dict(totals), "counts": dict(counts), "durations_s": dict(durations),
               "thread_cpu_s": thread_cpu(), "process_cpu_s": sum(os.times()[:2])}, open(dump, "w"))
from robots.ros2_backend import Ros2Robot
from sims.ros2_bridge import SimBridge
if sys.argv[4] == "run":
    close = Ros2Robot.close
    def close_and_dump(self):
        write()
        return close(self)
    Ros2Robot.close = close_and_dump
else:
    run = SimBridge.run
    def run_and_dump(self):
        try:
            return run(self)
        finally:
            write()
    SimBridge.run = run_and_dump
from semexp_bt.cli import main
sys.argv = ["semexp-bt", *sys.argv[4:]]
raise SystemExit(main())
"""


def _wrapped(targets: tuple[str, ...], dump: Path, *args: str) -> list[str]:
    return [sys.executable, "-c", WRAPPER, ",".join(targets), str(dump), ",".join(DISTRIBUTIONS), *args]


def summarise(data: dict[str, Any], ticks: int) -> dict[str, Any]:
    """Per call: count, total (s), mean (us), per tick (ms)."""
    calls = {
        name: {
            "count": data["counts"][name],
            "total_s": round(total, 3),
            "mean_us": round(total / data["counts"][name] * 1e6, 1),
            "per_tick_ms": round(total / ticks * 1e3, 3),
        }
        for name, total in sorted(data["totals_s"].items(), key=lambda kv: -kv[1])
    }
    for name, values in data["durations_s"].items():
        ms = np.sort(np.array(values)) * 1e3
        calls[name]["ms_median_p90_p99_max"] = [
            round(float(v), 2) for v in (*np.percentile(ms, [50, 90, 99]), ms.max())
        ]
    threads = {k: round(v, 2) for k, v in sorted(data["thread_cpu_s"].items(), key=lambda kv: -kv[1]) if v}
    return {"calls": calls, "thread_cpu_s": threads, "process_cpu_s": round(data["process_cpu_s"], 2)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="showroom")
    parser.add_argument("--seed", type=int, default=9)
    parser.add_argument("--budget-s", type=float, default=60.0)
    parser.add_argument(
        "--no-speculation",
        action="store_true",
        help="the bridge steps only when asked (sim-bridge --no-speculation)",
    )
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        mission = mission_with_budget(out / "mission", args.budget_s)
        bridge_dump, exec_dump, exec_json = out / "bridge.json", out / "exec.json", out / "record.json"
        run_bridge_and_executive(
            _wrapped(BRIDGE_CALLS, bridge_dump, "sim-bridge", "--scene", args.scene, "--seed", str(args.seed),
                     "--max-wall-s", "900", *(("--no-speculation",) if args.no_speculation else ())),
            _wrapped(EXECUTIVE_CALLS, exec_dump, "run", str(mission), "--backend", "ros2", "--seed",
                     str(args.seed), "--relevance", "lexical", "--json", str(exec_json)),
        )  # fmt: skip
        record = json.loads(exec_json.read_text())
        ticks = record["ticks"]
        report = {
            "episode": {"scene": args.scene, "seed": args.seed, "budget_s": args.budget_s},
            "speculation": not args.no_speculation,
            "outcome": record["outcome"],
            "ticks": ticks,
            "mission_wall_s": record["mission_wall_s"],
            "wall_per_tick_ms": round(record["mission_wall_s"] / ticks * 1e3, 3),
            "load_average_at_end": os.getloadavg(),
            "executive": summarise(json.loads(exec_dump.read_text()), ticks),
            "bridge": summarise(json.loads(bridge_dump.read_text()), ticks),
        }
    text = json.dumps(report, indent=1)
    if args.json is not None:
        args.json.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
