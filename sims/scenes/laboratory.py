"""Laboratory (real-world analogue, 30 m^2): a 6 x 5 m lab with a hand-built obstacle course. Lab
benches and boards occlude; the black chair shares its spots with grey chairs (one stands near it).

Everything the scene holds (labels, categories, sizes, colours, roles, placement slots) is data in
``sims/scenes/data/laboratory.yaml``; the placement rules are shared (:mod:`sims.scenes._placement`).
"""

from __future__ import annotations

from semexp_bt.core.scene import SceneSpec
from sims.scenes._placement import build_scene_from_data

SCENE_NAME = "laboratory"


def build(*, seed: int) -> SceneSpec:
    """Build the Laboratory scene with layout seed ``seed`` (same seed, same scene)."""
    return build_scene_from_data(SCENE_NAME, seed=seed)
