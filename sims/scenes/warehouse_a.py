"""Warehouse (a) (simulation): a 14 x 12 m warehouse hall. Shelving rows with seeded cross-aisles
hide the loading cart, which shares its spots with a parked hand truck (a second hand truck stands
near it); pallets and box stacks are obstacles.

Everything the scene holds (labels, categories, sizes, colours, roles, placement slots) is data in
``sims/scenes/data/warehouse_a.yaml``; the placement rules are shared (:mod:`sims.scenes._placement`).
"""

from __future__ import annotations

from semexp_bt.core.scene import SceneSpec
from sims.scenes._placement import build_scene_from_data

SCENE_NAME = "warehouse_a"


def build(*, seed: int) -> SceneSpec:
    """Build the Warehouse (a) scene with layout seed ``seed`` (same seed, same scene)."""
    return build_scene_from_data(SCENE_NAME, seed=seed)
