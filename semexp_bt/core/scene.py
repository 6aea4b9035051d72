"""The scene description shared by scene builders (``sims/``) and robot backends (``robots/``).

A scene is a flat floor with walls and objects made of boxes and cylinders. Builders in ``sims/scenes``
produce a :class:`SceneSpec` from a seed; the MuJoCo backend turns it into MJCF, the geodesic oracle into
an occupancy grid, the perception emulator reads its labels. World frame ``map``: x forward, y left,
z up, the floor at z = 0.

This is a core module: standard library only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

Shape = Literal["box", "cylinder"]


@dataclass(frozen=True)
class SceneObject:
    """One object in a scene.

    Attributes:
        object_id: unique non-negative id; the segmentation render writes it per pixel.
        name: unique name within the scene (e.g. ``"extinguisher_0"``).
        label: the semantic label a detector would say (e.g. ``"fire extinguisher"``).
        category: the category SA compares with the instruction (e.g. ``"extinguisher"``).
        shape: ``"box"`` or ``"cylinder"``.
        position_m: ``(x, y, z)`` of the object's centre.
        yaw_rad: rotation about +z.
        size_m: box: half extents ``(hx, hy, hz)``; cylinder: ``(radius, radius, half_height)``.
        rgba: colour in [0, 1].
        is_obstacle: it blocks the robot (collides and is inflated in the occupancy grid). Flat
            decorations (rugs, road markings) are not obstacles.
        role: ``"goal"``, ``"distractor"`` (semantically close to the goal), ``"occluder"``,
            ``"obstacle"``, ``"wall"`` or ``"clutter"``.
        parts: extra ``(shape, dx, dy, dz, sx, sy, sz, r, g, b, a)`` geoms in the object's frame that
            make it look like itself (a bin's lid, a sign's post); same id, same label.
        aliases: other names people and models use for the object ("green wheelie bin"); with the label
            and the category, the names that name it.
        colour: its colour word ("green"), or "" when it has none worth saying.
        size: ``"small"`` or ``"large"`` for its kind, or "".
    """

    object_id: int
    name: str
    label: str
    category: str
    shape: Shape
    position_m: tuple[float, float, float]
    size_m: tuple[float, float, float]
    yaw_rad: float = 0.0
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.6, 1.0)
    is_obstacle: bool = True
    role: Literal["goal", "distractor", "occluder", "obstacle", "wall", "clutter"] = "obstacle"
    parts: tuple[tuple[object, ...], ...] = ()
    aliases: tuple[str, ...] = ()
    colour: str = ""
    size: str = ""

    @property
    def names(self) -> tuple[str, ...]:
        """Every name that names the object: its label, its category and its aliases."""
        return tuple(dict.fromkeys((self.label, self.category, *self.aliases)))

    def boundary_distance_m(self, xy: tuple[float, float]) -> float:
        """2D distance from ``xy`` to the object's footprint (0 inside it).

        Example:
            >>> SceneObject(0, "b", "box", "box", "box", (0.0, 0.0, 0.5), (1.0, 0.5, 0.5)).boundary_distance_m((3.0, 0.0))
            2.0
        """
        dx, dy = xy[0] - self.position_m[0], xy[1] - self.position_m[1]
        if self.shape == "cylinder":
            return max(0.0, math.hypot(dx, dy) - self.size_m[0])
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        ex, ey = max(abs(lx) - self.size_m[0], 0.0), max(abs(ly) - self.size_m[1], 0.0)
        return math.hypot(ex, ey)


@dataclass(frozen=True)
class SceneSpec:
    """A whole scene.

    Attributes:
        name: the scene's key (e.g. ``"office"``).
        title: human title (e.g. ``"Office"``).
        seed: the seed the layout was built from.
        bounds_m: ``(x_min, y_min, x_max, y_max)`` of the walkable area (inside the walls).
        objects: every object, walls included.
        goal_object_id: the id of the goal object.
        instruction: the default instruction (e.g. ``"find the fire extinguisher"``).
        floor_rgba: floor colour.
        outdoor: outdoor scenes get a sky-coloured background instead of a ceiling.
    """

    name: str
    title: str
    seed: int
    bounds_m: tuple[float, float, float, float]
    objects: tuple[SceneObject, ...]
    goal_object_id: int
    instruction: str
    floor_rgba: tuple[float, float, float, float] = (0.45, 0.45, 0.45, 1.0)
    outdoor: bool = False
    extra: dict[str, object] = field(default_factory=dict)

    def object_by_id(self, object_id: int) -> SceneObject:
        for obj in self.objects:
            if obj.object_id == object_id:
                return obj
        raise KeyError(f"scene '{self.name}' has no object with id {object_id}")

    @property
    def goal(self) -> SceneObject:
        return self.object_by_id(self.goal_object_id)

    @property
    def goal_category(self) -> str:
        """The goal object's category (the class its instruction asks for)."""
        return self.goal.category
