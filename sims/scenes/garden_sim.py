"""Garden (simulation, paper Table III): a 14 x 14 m park corner. Hedge rows with seeded gaps cut it
into beds; the green bin shares its spots with a blue bin (and a second blue bin stands beside it),
trees, benches and bushes are obstacles.

Everything the scene holds (labels, categories, sizes, colours, roles, placement slots) is data in
``sims/scenes/data/garden_sim.yaml``; the placement rules are shared (:mod:`sims.scenes._placement`).
"""

from __future__ import annotations

from semexp_bt.core.scene import SceneSpec
from sims.scenes._placement import build_scene_from_data

SCENE_NAME = "garden_sim"


def build(*, seed: int) -> SceneSpec:
    """Build the Garden scene with layout seed ``seed`` (same seed, same scene)."""
    return build_scene_from_data(SCENE_NAME, seed=seed)
