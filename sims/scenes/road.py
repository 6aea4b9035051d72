"""Road (simulation): a 16 x 14 m stretch of road with pavements. Parked cars and a van hide the
bus station, which shares its spots with a kiosk (a second kiosk stands near it); lamp posts, cones
and barriers are obstacles.

Everything the scene holds (labels, categories, sizes, colours, roles, placement slots) is data in
``sims/scenes/data/road.yaml``; the placement rules are shared (:mod:`sims.scenes._placement`).
"""

from __future__ import annotations

from semexp_bt.core.scene import SceneSpec
from sims.scenes._placement import build_scene_from_data

SCENE_NAME = "road"


def build(*, seed: int) -> SceneSpec:
    """Build the Road scene with layout seed ``seed`` (same seed, same scene)."""
    return build_scene_from_data(SCENE_NAME, seed=seed)
