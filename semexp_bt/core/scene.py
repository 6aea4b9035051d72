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
#: One geom of an object seen from above: ``(shape, cx, cy, yaw, half_x, half_y)`` in ``map``; a
#: cylinder's radius is ``half_x``.
PlanarGeom = tuple[str, float, float, float, float, float]


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

    def planar_geoms(self, *, below_height_m: float | None = None) -> list[PlanarGeom]:
        """The object's main geom and parts projected on the floor, in ``map``.

        Args:
            below_height_m: keep only the geoms whose bottom is below this height (what blocks a body
                that tall); None keeps every geom: the object's whole footprint, the region its success
                radius is measured from (SR, L*, the drawn goal zone).

        Example:
            >>> table = SceneObject(0, "t", "table", "table", "box", (0.0, 0.0, 0.7), (0.6, 0.4, 0.02),
            ...                     parts=(("box", 0.5, 0.3, -0.35, 0.03, 0.03, 0.35),))
            >>> [g[1:3] for g in table.planar_geoms()], [g[1:3] for g in table.planar_geoms(below_height_m=0.5)]
            ([(0.0, 0.0), (0.5, 0.3)], [(0.5, 0.3)])
        """
        x, y, z = self.position_m
        cos_y, sin_y = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        geoms: list[PlanarGeom] = []
        if below_height_m is None or z - self.size_m[2] < below_height_m:
            geoms.append((self.shape, x, y, self.yaw_rad, self.size_m[0], self.size_m[1]))
        for part in self.parts:
            shape, dx, dy, dz, sx, sy, sz = (str(part[0]), *(float(v) for v in part[1:7]))  # type: ignore[arg-type]
            if below_height_m is not None and z + dz - sz >= below_height_m:
                continue
            px = x + cos_y * dx - sin_y * dy
            py = y + sin_y * dx + cos_y * dy
            geoms.append((shape, px, py, self.yaw_rad, sx, sy))
        return geoms

    def boundary_distance_m(self, xy: tuple[float, float]) -> float:
        """2D distance from ``xy`` to the object's whole footprint (:meth:`planar_geoms`; 0 inside it).

        Example:
            >>> SceneObject(0, "b", "box", "box", "box", (0.0, 0.0, 0.5), (1.0, 0.5, 0.5)).boundary_distance_m((3.0, 0.0))
            2.0
        """
        near = self.nearest_point_m(xy)
        return math.hypot(xy[0] - near[0], xy[1] - near[1])

    def nearest_point_m(self, xy: tuple[float, float]) -> tuple[float, float]:
        """The point of the object's whole footprint nearest ``xy`` (``xy`` itself inside it).

        Example:
            >>> SceneObject(0, "b", "box", "box", "box", (0.0, 0.0, 0.5), (1.0, 0.5, 0.5)).nearest_point_m((3.0, 2.0))
            (1.0, 0.5)
        """
        points = [_nearest_point_of_geom(geom, xy) for geom in self.planar_geoms()]
        return min(points, key=lambda p: math.hypot(xy[0] - p[0], xy[1] - p[1]))


def _nearest_point_of_geom(geom: PlanarGeom, xy: tuple[float, float]) -> tuple[float, float]:
    shape, cx, cy, yaw, hx, hy = geom
    dx, dy = xy[0] - cx, xy[1] - cy
    if shape == "cylinder":
        norm = math.hypot(dx, dy)
        scale = min(1.0, hx / norm) if norm > 0 else 0.0
        return (cx + dx * scale, cy + dy * scale)
    c, s = math.cos(yaw), math.sin(yaw)
    lx = max(-hx, min(hx, c * dx + s * dy))
    ly = max(-hy, min(hy, -s * dx + c * dy))
    return (cx + c * lx - s * ly, cy + s * lx + c * ly)


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
