"""Garden (real-world analogue, 50 m^2): a 10 x 5 m garden with grass, trees and bushes. The carton
box shares its spots with plastic crates (one stands near it); bushes and a hedge occlude.

Everything the scene holds (labels, categories, sizes, colours, roles, placement slots) is data in
``sims/scenes/data/garden_real.yaml``; the placement rules are shared (:mod:`sims.scenes._placement`).
"""

from __future__ import annotations

from semexp_bt.core.scene import SceneSpec
from sims.scenes._placement import build_scene_from_data

SCENE_NAME = "garden_real"


def build(*, seed: int) -> SceneSpec:
    """Build the Garden (real) scene with layout seed ``seed`` (same seed, same scene)."""
    return build_scene_from_data(SCENE_NAME, seed=seed)
