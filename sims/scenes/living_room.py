"""Living room (real-world analogue, 30 m^2): a 6 x 5 m living room. A sofa and a room divider
occlude; the bucket shelf shares its wall spots with a plain shelf; a table, armchair and TV stand
are obstacles.

Everything the scene holds (labels, categories, sizes, colours, roles, placement slots) is data in
``sims/scenes/data/living_room.yaml``; the placement rules are shared (:mod:`sims.scenes._placement`).
"""

from __future__ import annotations

from semexp_bt.core.scene import SceneSpec
from sims.scenes._placement import build_scene_from_data

SCENE_NAME = "living_room"


def build(*, seed: int) -> SceneSpec:
    """Build the Living Room scene with layout seed ``seed`` (same seed, same scene)."""
    return build_scene_from_data(SCENE_NAME, seed=seed)
