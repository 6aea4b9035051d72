"""Sidewalk (simulation): a 16 x 12 m street-block section. A building facade and a kerb-side row
of parked cars bound the pavement; the traffic sign shares its spots with an advertising board and a
second board stands near it; a kiosk-sized news stand, lamp posts, bollards and bins are obstacles.

Everything the scene holds (labels, categories, sizes, colours, roles, placement slots) is data in
``sims/scenes/data/sidewalk.yaml``; the placement rules are shared (:mod:`sims.scenes._placement`).
"""

from __future__ import annotations

from semexp_bt.core.scene import SceneSpec
from sims.scenes._placement import build_scene_from_data

SCENE_NAME = "sidewalk"


def build(*, seed: int) -> SceneSpec:
    """Build the Sidewalk scene with layout seed ``seed`` (same seed, same scene)."""
    return build_scene_from_data(SCENE_NAME, seed=seed)
