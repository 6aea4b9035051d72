"""The scene catalogue: every scene's name, its builder, and a one-line summary for ``semexp-bt scene list``.

Scenes are listed once, in :data:`SCENE_BUILDERS` (the paper's five simulation scenes first, then the
simulated analogues of its five real-world scenes). ``build_scene(name, seed=s)`` is deterministic:
the same name and seed give an equal :class:`~semexp_bt.core.scene.SceneSpec`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from semexp_bt.core.scene import SceneSpec
from semexp_bt.core.types import InvalidInputError
from sims.scenes import (
    garden_real,
    garden_sim,
    laboratory,
    living_room,
    office,
    road,
    showroom,
    sidewalk,
    warehouse_a,
    warehouse_b,
)
from sims.scenes._placement import load_scene_data

SceneBuilder = Callable[..., SceneSpec]

#: name -> builder(seed=...). The only list of scenes.
SCENE_BUILDERS: dict[str, SceneBuilder] = {
    module.SCENE_NAME: module.build
    for module in (
        garden_sim,
        sidewalk,
        road,
        warehouse_a,
        warehouse_b,
        office,
        showroom,
        laboratory,
        living_room,
        garden_real,
    )
}


class UnknownSceneError(InvalidInputError):
    """A scene name that the catalogue does not hold."""


@dataclass(frozen=True)
class SceneSummary:
    """What ``semexp-bt scene list`` prints about a scene (read from its data, no layout built)."""

    name: str
    title: str
    area_m2: float
    goal_label: str
    instruction: str
    object_count: int


def list_scenes() -> list[str]:
    """Every scene name, in catalogue order."""
    return list(SCENE_BUILDERS)


def _check_name(name: str) -> None:
    if name not in SCENE_BUILDERS:
        raise UnknownSceneError(f"unknown scene '{name}'; known scenes: {', '.join(SCENE_BUILDERS)}")


def build_scene(name: str, *, seed: int) -> SceneSpec:
    """Build scene ``name`` with layout seed ``seed``."""
    _check_name(name)
    return SCENE_BUILDERS[name](seed=seed)


def scene_summary(name: str) -> SceneSummary:
    """The scene's title, area, goal and instruction, and its object count for seed 0 (walls included)."""
    _check_name(name)
    data = load_scene_data(name)
    goal_entry = next(entry for entry in data["objects"] if entry["role"] == "goal")
    width, depth = data["size_m"]
    return SceneSummary(
        name=name,
        title=data["title"],
        area_m2=float(width) * float(depth),
        goal_label=data["kinds"][goal_entry["kind"]]["label"],
        instruction=data["instruction"],
        object_count=len(build_scene(name, seed=0).objects),
    )
