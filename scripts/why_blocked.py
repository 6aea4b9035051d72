"""Why the controller stands still: which safety rule refused how many of its samples, when it reports blocked.

Runs one episode in process and, at the first ``--reports`` controller cycles whose result is ``blocked``
(at most one per simulated second), re-runs the DWB sampler's rollouts (``semexp_bt.nav.dwb``: the
fallback search of regulated pure pursuit, and the DWB controller itself) against the costmap of that
moment and prints, per rule of ``semexp_bt.nav.controller.admissible``, how many of the sampled
trajectories it lets through, alone and cumulatively, then what is known around the robot. A blocked
robot whose samples pass every rule but score worse than standing still is in a local minimum of the
critics; one whose samples all fail a rule is held by that rule.

Usage::

    MUJOCO_GL=egl .venv/bin/python scripts/why_blocked.py --scene office --seed 1001 --max-sim-s 60
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: Directions and distances of the ring printed around the robot.
RING_DIRECTIONS = 16
RING_DISTANCES_M = (0.4, 0.8)


def rule_counts(controller: Any, costmap: Any, pose: Any, velocity: Any, plan: Any) -> dict[str, int]:
    """How many of the DWB sampler's trajectories each rule admits, alone and together (in the order
    ``admissible`` applies them)."""
    from semexp_bt.nav import dwb
    from semexp_bt.nav.controller import path_progress_index, rollout, rule_masks

    cfg = controller.config
    here = np.array([pose.x_m, pose.y_m])
    remaining = dwb._remaining_length(plan.path_xy, path_progress_index(plan.path_xy, here, 0), here)
    max_forward = min(
        cfg.limits.max_speed_mps, max(cfg.min_approach_speed_mps, cfg.approach_gain * remaining)
    )
    targets = controller._targets(max_forward)
    states, commands = rollout(
        pose, velocity, targets, limits=cfg.limits, horizon_s=cfg.horizon_s, dt_s=cfg.dt_s
    )
    masks, now = rule_masks(costmap, pose, states, commands, rules=cfg.rules)
    not_oscillating = ~controller.oscillation.forbidden(pose, targets)
    together = np.ones(len(states), dtype=bool)
    counts = {"sampled": len(states), "clearance_now_mm": round(now * 1e3)}
    masks["not oscillating"] = not_oscillating
    for name, passed in masks.items():
        together &= passed
        counts[f"{name}: alone"] = int(passed.sum())
        counts[f"{name}: with the rules before"] = int(together.sum())
    moving = together & ((np.abs(targets[:, 0]) > 1e-6) | (np.abs(targets[:, 1]) > 1e-6))
    counts["admissible and moving"] = int(moving.sum())
    return counts


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", required=True)
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--max-sim-s", type=float, default=120.0)
    parser.add_argument("--reports", type=int, default=3)
    args = parser.parse_args()

    import py_trees
    import torch

    torch.set_num_threads(1)
    from semexp_bt.app.episode import EpisodeOptions, run_episode
    from semexp_bt.nav.dwb import DwbController

    reported: list[float] = []

    class BlockedReporter:
        wants_activity_stream = False

        def start(self, run: Any) -> None:
            del run

        def finish(self, run: Any, outcome: str) -> None:
            del run, outcome

        def after_tick(self, run: Any) -> None:
            storage = py_trees.blackboard.Blackboard.storage
            result, plan, costmap = (
                storage.get("/plan"),
                storage.get("/global_plan"),
                storage.get("/local_map"),
            )
            robot = run.services.robot
            now = robot.now_s()
            if getattr(result, "status", None) != "blocked" or plan is None or not plan.ok or costmap is None:
                return
            if len(reported) >= args.reports or (reported and now - reported[-1] < 1.0):
                return
            reported.append(now)
            planner = run.services.planner
            controller = planner if isinstance(planner, DwbController) else planner._fallback
            pose = robot.base_pose()
            print(
                f"t={now:.2f} s, pose ({pose.x_m:.2f}, {pose.y_m:.2f}) m, heading {math.degrees(pose.yaw_rad):.0f} deg"
            )
            for name, count in rule_counts(controller, costmap, pose, robot.base_twist(), plan).items():
                print(f"  {name}: {count}")
            angles = np.linspace(0.0, math.tau, RING_DIRECTIONS, endpoint=False) + pose.yaw_rad
            for distance in RING_DISTANCES_M:
                ring = np.stack(
                    [pose.x_m + distance * np.cos(angles), pose.y_m + distance * np.sin(angles)], axis=1
                )
                known = "".join("k" if k else "." for k in costmap.known_at(ring))
                print(f"  observed at {distance} m, from straight ahead counter-clockwise: {known}")

    record = run_episode(
        EpisodeOptions(
            mission_path=ROOT / "trees" / "object_search.yaml",
            scene=args.scene,
            seed=args.seed,
            max_sim_s=args.max_sim_s,
            observers=[BlockedReporter()],
        )
    )
    print(f"{args.scene} seed {args.seed}: {record['outcome']} after {record['sim_time_s']:.1f} s, "
          f"path {record['path_length_m']:.1f} m, blocked cycles reported: {len(reported)}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
