"""Office (real-world analogue, 30 m^2): a 6 x 5 m office. A partition with a seeded doorway splits the
room; the extinguisher shares its wall spots with a red trash can (a second one stands near it);
filing cabinets occlude, desks and chairs are obstacles.

Everything the scene holds (labels, categories, sizes, colours, roles, placement slots) is data in
``sims/scenes/data/office.yaml``; the placement rules are shared (:mod:`sims.scenes._placement`).
"""

from __future__ import annotations

from semexp_bt.core.scene import SceneSpec
from sims.scenes._placement import build_scene_from_data

SCENE_NAME = "office"


def build(*, seed: int) -> SceneSpec:
    """Build the Office scene with layout seed ``seed`` (same seed, same scene)."""
    return build_scene_from_data(SCENE_NAME, seed=seed)
