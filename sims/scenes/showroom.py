"""Showroom (real-world analogue, 40 m^2): an 8 x 5 m showroom. Display boards hide the quadruped
robot, which shares its plinth spots with a toy robot dog and a robot arm; machines are obstacles.

Everything the scene holds (labels, categories, sizes, colours, roles, placement slots) is data in
``sims/scenes/data/showroom.yaml``; the placement rules are shared (:mod:`sims.scenes._placement`).
"""

from __future__ import annotations

from semexp_bt.core.scene import SceneSpec
from sims.scenes._placement import build_scene_from_data

SCENE_NAME = "showroom"


def build(*, seed: int) -> SceneSpec:
    """Build the Showroom scene with layout seed ``seed`` (same seed, same scene)."""
    return build_scene_from_data(SCENE_NAME, seed=seed)
