"""Per-frame costmap update and per-cycle planner + controller cost, replayed on MuJoCo walks.

For each scene, the Go1 (kinematic) drives from the seed's start to its goal with the real stack
(costmap from ray-cast depth at 6 Hz, global planner replanning as the mission does, the controller at
12 Hz); the costmap update of every frame and the planner + controller work of every control cycle
(the global plan when one is due, plus the controller) are timed with the thread's CPU clock and the
wall clock. Prints one JSON object (medians and p99 in ms).

    MUJOCO_GL=egl .venv/bin/python scripts/measure_nav.py --scenes office,road,warehouse_a --seed 1000

With the flank depth cameras (the default robot) each costmap update integrates their frames with the
head camera's; ``--no-side-depth`` times the head camera alone.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from robots.go1 import go1_footprint
from robots.mujoco_backend import MujocoRobot
from robots.side_depth import GO1_SIDE_DEPTH
from semexp_bt.app.components import PLANNERS
from semexp_bt.nav.costmap import Costmap, CostmapConfig
from semexp_bt.nav.global_planner import GlobalPlanner
from sims.catalogue import build_scene
from sims.episodes import sample_episode
from sims.geodesic import GeodesicOracle


def walk(
    scene_name: str, seed: int, controller_name: str, seconds: float, *, side_depth: bool
) -> dict[str, list[float]]:
    scene = build_scene(scene_name, seed=seed)
    oracle = GeodesicOracle(scene)
    episode = sample_episode(scene, seed=seed, oracle=oracle)
    goal = oracle.nearest_point_on_object((episode.start.x_m, episode.start.y_m), scene.goal.object_id)
    robot = MujocoRobot(
        scene=scene,
        fidelity="kinematic",
        start_pose=episode.start,
        seed=seed,
        side_depth=GO1_SIDE_DEPTH if side_depth else None,
    )
    costmap = Costmap(
        CostmapConfig(), footprint=go1_footprint(), origin_xy=(episode.start.x_m, episode.start.y_m)
    )
    planner, controller = GlobalPlanner(), PLANNERS[controller_name]()
    out: dict[str, list[float]] = {"costmap_cpu": [], "costmap_wall": [], "cycle_cpu": [], "cycle_wall": []}
    plan = None
    try:
        for tick in range(int(seconds / 0.02)):
            now = robot.now_s()
            if tick % 8 == 0:  # 6.25 Hz
                pixels = [costmap.sampled_pixels]
                frames = [
                    robot.observe_depth(pixel_grids=pixels),
                    *robot.observe_side_depth(pixel_grids=pixels),
                ]
                c0, w0 = time.thread_time(), time.perf_counter()
                costmap.integrate(*frames)
                out["costmap_cpu"].append(time.thread_time() - c0)
                out["costmap_wall"].append(time.perf_counter() - w0)
            if tick % 4 == 0:  # 12.5 Hz
                pose = robot.base_pose()
                c0, w0 = time.thread_time(), time.perf_counter()
                if (
                    plan is None
                    or (costmap.revision != plan.revision and now - plan.stamp_s >= 1.0)
                    or now - plan.stamp_s >= 4.0
                ):
                    plan = planner.plan(costmap, start_xy=(pose.x_m, pose.y_m), goal_xy=goal, stamp_s=now)
                if plan.ok:
                    result = controller.compute(
                        plan=plan, costmap=costmap, pose=pose, velocity=robot.base_twist(), stamp_s=now
                    )
                    robot.command_twist(result.twist)
                out["cycle_cpu"].append(time.thread_time() - c0)
                out["cycle_wall"].append(time.perf_counter() - w0)
                if not plan.ok or math.dist((pose.x_m, pose.y_m), plan.path_xy[-1]) < 0.15:
                    break
            robot.advance(0.02)
    finally:
        robot.close()
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="office,road,warehouse_a,laboratory,garden_sim")
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--controller", default="rpp", choices=sorted(PLANNERS))
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument(
        "--no-side-depth", action="store_true", help="the head camera only (no flank depth cameras)"
    )
    args = parser.parse_args()
    samples: dict[str, list[float]] = {}
    for name in args.scenes.split(","):
        for key, values in walk(
            name, args.seed, args.controller, args.seconds, side_depth=not args.no_side_depth
        ).items():
            samples.setdefault(key, []).extend(values)
    report = {
        key: {
            "n": len(v),
            "median_ms": round(float(np.median(v)) * 1e3, 3),
            "p99_ms": round(float(np.percentile(v, 99)) * 1e3, 3),
        }
        for key, v in samples.items()
    }
    print(
        json.dumps(
            {"scenes": args.scenes, "seed": args.seed, "controller": args.controller, **report}, indent=1
        )
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
