"""The scene catalogue: every scene's name, in report order, and a one-line summary for ``semexp-bt scene list``.

Scenes are listed once, in ``sims/scenes/catalogue.yaml`` (the paper's five simulation scenes first, then
the simulated analogues of its five real-world scenes); each scene's layout is data in
``sims/scenes/data/<name>.yaml``. ``build_scene(name, seed=s)`` is deterministic: the same name and seed
give an equal :class:`~semexp_bt.core.scene.SceneSpec`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import yaml

from semexp_bt.core.scene import SceneSpec
from semexp_bt.core.types import InvalidInputError
from sims.scenes.placement import build_scene_from_data, load_scene_data

#: The catalogue's data: scene names by group, in report order.
CATALOGUE_FILE = Path(__file__).resolve().parent / "scenes" / "catalogue.yaml"
#: The catalogue's groups, in report order.
SCENE_GROUPS = ("simulation", "real_analogue")


@functools.cache
def _catalogue() -> dict[str, tuple[str, ...]]:
    data = yaml.safe_load(CATALOGUE_FILE.read_text(encoding="utf-8"))
    if not isinstance(data, dict) or set(data) != set(SCENE_GROUPS):
        raise ValueError(f"{CATALOGUE_FILE}: expected exactly the groups {list(SCENE_GROUPS)}")
    groups = {group: tuple(str(name) for name in data[group]) for group in SCENE_GROUPS}
    names = [name for group in SCENE_GROUPS for name in groups[group]]
    if len(set(names)) != len(names):
        raise ValueError(f"{CATALOGUE_FILE}: a scene is listed twice: {names}")
    return groups


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
    return [name for group in SCENE_GROUPS for name in _catalogue()[group]]


def scenes_in_group(group: str) -> tuple[str, ...]:
    """The scenes of one catalogue group (``simulation`` or ``real_analogue``), in report order."""
    if group not in SCENE_GROUPS:
        raise InvalidInputError(f"unknown scene group {group!r}; known: {list(SCENE_GROUPS)}")
    return _catalogue()[group]


def _check_name(name: str) -> None:
    if name not in list_scenes():
        raise UnknownSceneError(f"unknown scene '{name}'; known scenes: {', '.join(list_scenes())}")


def build_scene(name: str, *, seed: int) -> SceneSpec:
    """Build scene ``name`` with layout seed ``seed``."""
    _check_name(name)
    return build_scene_from_data(name, seed=seed)


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
