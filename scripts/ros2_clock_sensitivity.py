"""How the in-process mission reacts to what a ROS 2 link changes: the clock's last bits, the depth's
millimetres, the camera pose from the profile (docs/ros2.md, "Lockstep and realtime").

Runs one in-process episode (default living_room seed 0, kinematic, lexical relevance) as shipped and
then with each perturbation applied to the MuJoCo robot, and prints outcome, simulated time, ticks and path:

- ``ns_clock``: ``now_s()`` rounded to whole nanoseconds (what ``/clock`` carries);
- ``mm_depth``: depth through 16UC1 millimetres (what realsense-ros publishes);
- ``profile_pose``: the camera pose as odometry times the profile's mount (not MuJoCo's compiled camera).

Usage: ``MUJOCO_GL=egl .venv/bin/python scripts/ros2_clock_sensitivity.py [--scene S --seed N]``
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

import semexp_bt.app.components as components
from robots.go1 import TRUNK_BODY_NAME
from robots.mujoco_backend import MujocoRobot
from robots.ros2_messages import depth_to_millimetres
from robots.ros2_profile import load_ros2_profile
from semexp_bt.app.episode import EpisodeOptions, run_episode
from semexp_bt.core.types import Observation

MISSION = Path(__file__).resolve().parents[1] / "trees" / "object_search.yaml"
PERTURBATIONS: dict[str, tuple[str, ...]] = {
    "as shipped": (),
    "ns_clock": ("ns_clock",),
    "mm_depth": ("mm_depth",),
    "profile_pose": ("profile_pose",),
    "mm_depth + profile_pose": ("mm_depth", "profile_pose"),
}


def perturbed_robot(changes: tuple[str, ...]) -> type[MujocoRobot]:
    optical_to_base = load_ros2_profile().optical_to_base()

    class Perturbed(MujocoRobot):
        def now_s(self) -> float:
            t = super().now_s()
            return int(round(t * 1e9)) * 1e-9 if "ns_clock" in changes else t

        def _perturb(self, observation: Observation) -> Observation:
            if "mm_depth" in changes:
                observation.depth_m = depth_to_millimetres(observation.depth_m).astype(
                    np.float32
                ) * np.float32(1e-3)
            if "profile_pose" in changes:
                trunk = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, TRUNK_BODY_NAME)
                base_to_world = np.eye(4)
                base_to_world[:3, :3] = self.data.xmat[trunk].reshape(3, 3)
                base_to_world[:3, 3] = self.data.xpos[trunk]
                observation.camera_to_world = base_to_world @ optical_to_base
            observation.stamp_s = self.now_s()
            return observation

        def observe(self) -> Observation:
            return self._perturb(super().observe())

        def observe_depth(self, **kwargs: Any) -> Observation:
            return self._perturb(super().observe_depth(**kwargs))

    return Perturbed


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="living_room")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rows = {}
    for name, changes in PERTURBATIONS.items():
        robot_class = perturbed_robot(changes)

        def build(
            request: components.ComponentRequest, robot_class: type[MujocoRobot] = robot_class
        ) -> MujocoRobot:
            assert request.scene is not None and request.start_pose is not None
            return robot_class(
                scene=request.scene,
                fidelity=request.fidelity,
                start_pose=request.start_pose,
                seed=request.seed,
            )

        components.ROBOT_BACKENDS["mujoco"] = build
        record = run_episode(
            EpisodeOptions(mission_path=MISSION, scene=args.scene, seed=args.seed, relevance="lexical")
        )
        rows[name] = {
            "outcome": record["outcome"],
            "success": record["success"],
            "sim_time_s": round(record["sim_time_s"], 2),
            "ticks": record["ticks"],
            "path_length_m": record["path_length_m"],
            "decisions": len(record["decisions"]),
        }
        print(name, json.dumps(rows[name]), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
