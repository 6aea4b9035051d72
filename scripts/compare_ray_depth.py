"""Compare the ray-cast planner depth with the rendered depth frame over the scene catalogue.

Usage (the agreement figures in docs/simulation.md come from this command):

    MUJOCO_GL=egl .venv/bin/python scripts/compare_ray_depth.py

For every catalogue scene (seed 0, episode seed 0's start pose) it takes, at four headings in kinematic
fidelity and one in dynamic fidelity, ``observe_depth(pixel_grids=...)`` with LocalPlan's grids (the
planner's and the occupancy map's) and the rendered ``observe_depth()``, and counts the sampled pixels
whose validity differs and those whose depths differ by more than ``--tolerance-m``.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

from robots.mujoco_backend import MujocoRobot
from semexp_bt.core.types import PixelGrid, Pose2D
from semexp_bt.nav.costmap import CostmapConfig
from sims.catalogue import build_scene, list_scenes
from sims.episodes import sample_episode

#: Headings (rad, added to the start's) per fidelity.
HEADINGS_RAD = {"kinematic": (0.0, 1.5, 3.0, 4.5), "dynamic": (0.0,)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tolerance-m", type=float, default=0.01)
    args = parser.parse_args()
    grids = [PixelGrid.centred(CostmapConfig().pixel_stride)]  # the costmap's pixels (UpdateCostmap's)
    sampled_total = validity_total = far_total = 0
    for fidelity, headings in HEADINGS_RAD.items():
        for name in list_scenes():
            scene = build_scene(name, seed=0)
            start = sample_episode(scene, seed=0).start
            robot = MujocoRobot(scene=scene, fidelity=fidelity, start_pose=start, seed=0)  # type: ignore[arg-type]
            try:
                for turn in headings:
                    robot.teleport(Pose2D(start.x_m, start.y_m, start.yaw_rad + turn))
                    rays = robot.observe_depth(pixel_grids=grids).depth_m
                    rendered = robot.observe_depth().depth_m
                    measured = np.isfinite(rays)
                    ray_depth, reference = rays[measured], rendered[measured]
                    validity = int(np.count_nonzero((ray_depth > 0) != (reference > 0)))
                    both = (ray_depth > 0) & (reference > 0)
                    far = int(np.count_nonzero(np.abs(ray_depth[both] - reference[both]) > args.tolerance_m))
                    sampled_total += int(measured.sum())
                    validity_total += validity
                    far_total += far
                    print(
                        f"{fidelity:9s} {name:12s} +{turn:.1f} rad: {validity} validity, {far} beyond tolerance"
                    )
            finally:
                robot.close()
    print(
        f"all: {sampled_total} sampled pixels, {validity_total} differ in validity, "
        f"{far_total} differ by more than {args.tolerance_m} m"
    )


if __name__ == "__main__":
    main()
