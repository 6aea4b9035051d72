"""Warehouse (b) (simulation): a 14 x 12 m storage hall with a different shelving plan. The fire
extinguisher shares its spots with a red trash can (and a red gas cylinder stands near it); shelving
and crate stacks occlude, pallets and a forklift are obstacles.

Everything the scene holds (labels, categories, sizes, colours, roles, placement slots) is data in
``sims/scenes/data/warehouse_b.yaml``; the placement rules are shared (:mod:`sims.scenes._placement`).
"""

from __future__ import annotations

from semexp_bt.core.scene import SceneSpec
from sims.scenes._placement import build_scene_from_data

SCENE_NAME = "warehouse_b"


def build(*, seed: int) -> SceneSpec:
    """Build the Warehouse (b) scene with layout seed ``seed`` (same seed, same scene)."""
    return build_scene_from_data(SCENE_NAME, seed=seed)
