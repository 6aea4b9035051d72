"""Compare the path-following controllers in closed loop on the true map (no tree, no perception).

For each scene and seed, the kinematic Go1 starts at the episode's start with the scene's true occupancy
map in its costmap (as ``oracle_nav``) and drives to the goal object (within 0.8 m of its main shape) with
the global planner and the controller named; 12.5 Hz control, replanning every 3 s. One line per run:
outcome, simulated time, path length against L*, contacts and clearance breaches the simulator recorded,
and the controller's CPU time per cycle. This is the measurement behind docs/planner.md's choice.

    MUJOCO_GL=egl .venv/bin/python scripts/compare_controllers.py --controllers rpp,dwb --seeds 1000
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from robots.go1 import go1_footprint
from robots.mujoco_backend import MujocoRobot
from semexp_bt.app.components import PLANNERS
from semexp_bt.app.episode import privileged_navigation
from semexp_bt.nav.costmap import Costmap, CostmapConfig
from semexp_bt.nav.global_planner import GlobalPlanner
from sims.catalogue import build_scene, list_scenes
from sims.episodes import sample_episode
from sims.geodesic import GeodesicOracle


def run(scene_name: str, seed: int, controller_name: str, limit_s: float) -> str:
    scene = build_scene(scene_name, seed=seed)
    oracle = GeodesicOracle(scene)
    episode = sample_episode(scene, seed=seed, oracle=oracle)
    known = privileged_navigation(scene, oracle, start=episode.start, success_radius_m=1.0)
    assert known.occupancy is not None and known.goal_point_xy is not None
    costmap = Costmap(
        CostmapConfig(), footprint=go1_footprint(), origin_xy=(episode.start.x_m, episode.start.y_m)
    )
    occupied, lower_left, resolution = known.occupancy
    costmap.set_known(occupied, lower_left_xy=lower_left, resolution_m=resolution)
    robot = MujocoRobot(scene=scene, fidelity="kinematic", start_pose=episode.start, seed=seed)
    planner, controller = GlobalPlanner(), PLANNERS[controller_name]()
    plan, status, cpu, travelled, last, blocked_since = None, "timeout", [], 0.0, robot.base_pose(), None
    try:
        for tick in range(int(limit_s / 0.02)):
            if tick % 4 == 0:
                now, pose = robot.now_s(), robot.base_pose()
                if plan is None or now - plan.stamp_s >= 3.0:
                    plan = planner.plan(
                        costmap, start_xy=(pose.x_m, pose.y_m), goal_xy=known.goal_point_xy, stamp_s=now
                    )
                    controller.reset()
                if not plan.ok:
                    status = plan.status
                    break
                if math.dist(plan.path_xy[-1], (pose.x_m, pose.y_m)) < 0.15:
                    status = "arrived"
                    break
                c0 = time.thread_time()
                result = controller.compute(
                    plan=plan, costmap=costmap, pose=pose, velocity=robot.base_twist(), stamp_s=now
                )
                cpu.append(time.thread_time() - c0)
                robot.command_twist(result.twist)
                blocked_since = (blocked_since or now) if result.status == "blocked" else None
                if blocked_since is not None and now - blocked_since > 5.0:
                    status = "blocked"
                    break
            robot.advance(0.02)
            pose = robot.base_pose()
            travelled += math.hypot(pose.x_m - last.x_m, pose.y_m - last.y_m)
            last = pose
        events = robot.safety().events
    finally:
        robot.close()
    contacts = sum(e.kind == "collision" for e in events)
    breaches = sum(e.kind == "clearance" for e in events)
    final = (last.x_m, last.y_m)
    return (
        f"{scene_name}/{seed} {controller_name}: {status} in {robot.now_s():.1f} s, path {travelled:.1f} m "
        f"(L* {episode.geodesic_length_m:.1f}), {scene.goal.boundary_distance_m(final):.2f} m from the goal, "
        f"contacts {contacts}, breaches {breaches}, controller CPU median "
        f"{np.median(cpu) * 1e3 if cpu else 0.0:.2f} ms"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default=",".join(list_scenes()))
    parser.add_argument("--seeds", default="1000")
    parser.add_argument("--controllers", default="rpp,dwb")
    parser.add_argument("--limit-s", type=float, default=120.0)
    args = parser.parse_args()
    for controller in args.controllers.split(","):
        for seed in (int(s) for s in args.seeds.split(",")):
            for scene in args.scenes.split(","):
                print(run(scene, seed, controller, args.limit_s), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
