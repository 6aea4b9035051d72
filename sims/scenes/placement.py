"""Shared placement logic: turn a scene's YAML data and a seed into a :class:`SceneSpec`.

Every scene is data (``sims/scenes/data/<name>.yaml``); this module is the only code that reads it.
The data names object *kinds* (label, category, shape, half extents, colour, parts) and *placements*
that say where instances of a kind go:

- ``pose: [x, y, yaw_deg]``: a fixed pose, optionally jittered by ``jitter_m`` / ``yaw_jitter_deg``;
- ``slot: GROUP``: the next slot of a named slot group; each layout permutes the group's slots, so
  objects that share a group (say the goal and its distractor) trade places with the seed;
- ``near: NAME`` with ``distance_m: [lo, hi]``: a random bearing and distance from an earlier object;
- ``line: {from: [x, y], to: [x, y], gap_m: w, gap_at: [lo, hi]}``: a wall, hedge or shelf row along a
  segment, split by a gap of width ``w`` whose centre lies at a random fraction in ``[lo, hi]``.

``count: n`` repeats a slot or near placement as ``name_0 .. name_{n-1}``. A yaw of ``any`` draws a
uniform heading. Perimeter walls (role ``wall``) are added just outside the bounds.

Seed rule: layout attempt ``k`` of scene ``name`` with seed ``s`` draws from
``numpy.random.default_rng(SeedSequence([crc32(name), s, k]))``. An attempt is rejected when an obstacle
would overlap another or leave the bounds (after :data:`PLACEMENT_DRAWS` draws), or when the goal is not
reachable: the free cells within the success radius of the goal's footprint must touch the largest
8-connected free region of the inflated occupancy grid, some of them at least :data:`GOAL_APPROACH_MARGIN_M`
inside it, and that region must hold a cell at least the scene's ``min_geodesic_m`` (Euclidean, hence also
geodesic) from them. After :data:`MAX_LAYOUT_ATTEMPTS` rejected attempts the build raises
:class:`SceneLayoutError`.

Why a margin inside the success radius (docs/scenes.md, "A goal the robot can stand beside"): a goal in a
nook, behind a table or across a wall may have free cells within r_s only on its rim, a few centimetres
deep; a robot stands there only by luck, and the confirmation, which declares from 0.05 m inside r_s, never
can. Such a layout is not a search problem.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from semexp_bt.core.language import COLOURS
from semexp_bt.core.scene import SceneObject, SceneSpec
from semexp_bt.core.types import InvalidInputError
from sims.occupancy import (
    DEFAULT_RESOLUTION_M,
    GridGeometry,
    OccupancyGrid,
    distance_to_mask_m,
    footprint_geoms,
    rasterise_object,
)
from sims.robot_footprint import ROBOT_RADIUS_M

#: Folder of the scenes' YAML data.
DATA_DIR = Path(__file__).resolve().parent / "data"
#: Whole-layout attempts before a build gives up.
MAX_LAYOUT_ATTEMPTS = 50
#: Draws per object (jitter, bearing) before the attempt is rejected.
PLACEMENT_DRAWS = 25
#: Success radius (m) around the goal's footprint used by the reachability check; the same value is
#: the episode sampler's default (``sims.episodes.GOAL_SUCCESS_RADIUS_M``).
GOAL_SUCCESS_RADIUS_M = 1.0
#: How far inside the success radius (m) the disc robot must be able to stand beside the goal: the
#: controller stops up to 0.15 m off a plan's end (FollowPath's ``path_end_tolerance_m``) and the
#: confirmation declares only 0.05 m inside r_s (ConfirmTarget's ``declare_margin_m``).
GOAL_APPROACH_MARGIN_M = 0.2
#: Minimum start-to-goal geodesic (m) when a scene's data does not name one.
DEFAULT_MIN_GEODESIC_M = 3.0

_ROLES = ("goal", "distractor", "occluder", "obstacle", "wall", "clutter")
_PART_FIELDS = 11
#: Slack (m) for objects flush with the bounds (positions are rounded to 0.1 mm).
_BOUNDS_TOLERANCE_M = 1e-3


class SceneDataError(InvalidInputError):
    """A scene's YAML data is malformed; the message names the file and the key."""


class SceneLayoutError(RuntimeError):
    """No valid layout was found for a scene and seed within the attempt budget."""


# ---------------------------------------------------------------------- data loading and validation
@cache
def load_scene_data(name: str) -> dict[str, Any]:
    """Read and validate ``data/<name>.yaml`` (cached; treat the result as read-only)."""
    path = DATA_DIR / f"{name}.yaml"
    if not path.is_file():
        raise SceneDataError(f"scene data file not found: {path}")
    with path.open() as stream:
        data = yaml.safe_load(stream)
    _validate(data, source=str(path))
    return data


def _require(mapping: dict[str, Any], key: str, kind: type | tuple[type, ...], *, where: str) -> Any:
    if not isinstance(mapping, dict) or key not in mapping:
        raise SceneDataError(f"{where}: missing key '{key}'")
    value = mapping[key]
    if not isinstance(value, kind):
        raise SceneDataError(f"{where}.{key}: expected {kind}, got {type(value).__name__} ({value!r})")
    return value


def _numbers(value: Any, count: int, *, where: str) -> list[float]:
    if not isinstance(value, list) or len(value) != count:
        raise SceneDataError(f"{where}: expected a list of {count} numbers, got {value!r}")
    out = []
    for item in value:
        if isinstance(item, bool) or not isinstance(item, int | float) or not math.isfinite(item):
            raise SceneDataError(f"{where}: expected finite numbers, got {value!r}")
        out.append(float(item))
    return out


def _check_naming(kind: dict[str, Any], *, where: str) -> None:
    """A kind's other names (``aliases``), ``colour`` and ``size`` (see docs/scenes.md, "Names")."""
    aliases = kind.get("aliases", [])
    if not isinstance(aliases, list) or not all(isinstance(a, str) and a.strip() for a in aliases):
        raise SceneDataError(f"{where}.aliases: expected a list of non-empty names, got {aliases!r}")
    colour = kind.get("colour", "")
    if colour and colour not in COLOURS:
        raise SceneDataError(f"{where}.colour: expected one of {sorted(COLOURS)}, got {colour!r}")
    size = kind.get("size", "")
    if size and size not in ("small", "large"):
        raise SceneDataError(f"{where}.size: expected 'small' or 'large', got {size!r}")


def _validate(data: Any, *, source: str) -> None:
    if not isinstance(data, dict):
        raise SceneDataError(f"{source}: expected a mapping at the top level")
    for key in ("name", "title", "instruction"):
        _require(data, key, str, where=source)
    width, depth = _numbers(_require(data, "size_m", list, where=source), 2, where=f"{source}: size_m")
    if width <= 0 or depth <= 0:
        raise SceneDataError(f"{source}: size_m must be positive, got {data['size_m']}")
    _numbers(data.get("floor_rgba", [0.45, 0.45, 0.45, 1.0]), 4, where=f"{source}: floor_rgba")
    perimeter = _require(data, "perimeter", dict, where=source)
    for key in ("label", "category"):
        _require(perimeter, key, str, where=f"{source}: perimeter")
    for key in ("height_m", "thickness_m"):
        _require(perimeter, key, (int, float), where=f"{source}: perimeter")
    _numbers(
        _require(perimeter, "rgba", list, where=f"{source}: perimeter"), 4, where=f"{source}: perimeter.rgba"
    )
    kinds = _require(data, "kinds", dict, where=source)
    for kind_name, kind in kinds.items():
        where = f"{source}: kinds.{kind_name}"
        for key in ("label", "category"):
            _require(kind, key, str, where=where)
        if _require(kind, "shape", str, where=where) not in ("box", "cylinder"):
            raise SceneDataError(f"{where}.shape: expected 'box' or 'cylinder', got {kind['shape']!r}")
        size = _numbers(_require(kind, "size_m", list, where=where), 3, where=f"{where}.size_m")
        if min(size) <= 0:
            raise SceneDataError(f"{where}.size_m: half extents must be positive, got {size}")
        _numbers(_require(kind, "rgba", list, where=where), 4, where=f"{where}.rgba")
        _check_naming(kind, where=where)
        for index, part in enumerate(kind.get("parts", [])):
            if not isinstance(part, list) or len(part) != _PART_FIELDS or part[0] not in ("box", "cylinder"):
                raise SceneDataError(
                    f"{where}.parts[{index}]: expected [shape, dx, dy, dz, sx, sy, sz, r, g, b, a], got {part!r}"
                )
            _numbers(part[1:], _PART_FIELDS - 1, where=f"{where}.parts[{index}]")
    groups = data.get("slot_groups", {})
    if not isinstance(groups, dict):
        raise SceneDataError(f"{source}: slot_groups must be a mapping")
    for group_name, group in groups.items():
        for index, slot in enumerate(
            _require(group, "slots", list, where=f"{source}: slot_groups.{group_name}")
        ):
            if not isinstance(slot, list) or len(slot) != 3:
                raise SceneDataError(
                    f"{source}: slot_groups.{group_name}.slots[{index}]: expected [x, y, yaw_deg|any]"
                )
    names: set[str] = set()
    goals = 0
    for index, entry in enumerate(_require(data, "objects", list, where=source)):
        where = f"{source}: objects[{index}]"
        name = _require(entry, "name", str, where=where)
        if name in names:
            raise SceneDataError(f"{where}: duplicate object name '{name}'")
        names.add(name)
        if _require(entry, "kind", str, where=where) not in kinds:
            raise SceneDataError(f"{where}.kind: unknown kind '{entry['kind']}'")
        if _require(entry, "role", str, where=where) not in _ROLES:
            raise SceneDataError(f"{where}.role: expected one of {_ROLES}, got {entry['role']!r}")
        goals += entry["role"] == "goal"
        modes = [key for key in ("pose", "slot", "near", "line") if key in entry]
        if len(modes) != 1:
            raise SceneDataError(
                f"{where} ('{name}'): give exactly one of pose, slot, near, line; got {modes}"
            )
        if "slot" in entry and entry["slot"] not in groups:
            raise SceneDataError(f"{where}.slot: unknown slot group '{entry['slot']}'")
        if "near" in entry and entry["near"] not in names:
            raise SceneDataError(f"{where}.near: '{entry['near']}' must name an earlier object")
        count = entry.get("count", 1)
        if (
            isinstance(count, bool)
            or not isinstance(count, int)
            or count < 1
            or ("line" in entry and count != 1)
        ):
            raise SceneDataError(f"{where}.count: expected a positive integer (1 for a line), got {count!r}")
        names.update(f"{name}_{i}" for i in range(count if count > 1 else 0))
    if goals != 1:
        raise SceneDataError(f"{source}: expected exactly one object with role 'goal', found {goals}")
    for group_name, group in groups.items():
        needed = sum(int(e.get("count", 1)) for e in data["objects"] if e.get("slot") == group_name)
        if needed > len(group["slots"]):
            raise SceneDataError(
                f"{source}: slot_groups.{group_name} has {len(group['slots'])} slots but {needed} objects use it"
            )


# ---------------------------------------------------------------------- layout
@dataclass
class _Layout:
    """One layout attempt in progress."""

    data: dict[str, Any]
    rng: np.random.Generator
    grid: GridGeometry
    bounds_m: tuple[float, float, float, float]
    objects: list[SceneObject] = field(default_factory=list)
    occupied: np.ndarray = field(init=False)
    slot_orders: dict[str, list[list[Any]]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.occupied = np.zeros(self.grid.shape, dtype=bool)

    def next_slot(self, group_name: str) -> tuple[list[Any], dict[str, Any]]:
        group = self.data["slot_groups"][group_name]
        if group_name not in self.slot_orders:
            slots = group["slots"]
            self.slot_orders[group_name] = [slots[i] for i in self.rng.permutation(len(slots))]
        return self.slot_orders[group_name].pop(0), group

    def draw_yaw(self, yaw_deg: Any, jitter_deg: float) -> float:
        if yaw_deg == "any":
            return float(self.rng.uniform(-math.pi, math.pi))
        return math.radians(float(yaw_deg) + self.rng.uniform(-jitter_deg, jitter_deg))

    def jitter(self, radius_m: float) -> tuple[float, float]:
        radius = radius_m * math.sqrt(self.rng.uniform())
        bearing = self.rng.uniform(-math.pi, math.pi)
        return radius * math.cos(bearing), radius * math.sin(bearing)

    def make(
        self, name: str, kind_name: str, role: str, xy: tuple[float, float], yaw_rad: float, **overrides: Any
    ) -> SceneObject:
        kind = self.data["kinds"][kind_name]
        size = tuple(float(v) for v in overrides.get("size_m", kind["size_m"]))
        z = float(kind.get("z_m", size[2]))
        return SceneObject(
            object_id=len(self.objects),
            name=name,
            label=kind["label"],
            category=kind["category"],
            shape=kind["shape"],
            position_m=(round(xy[0], 4), round(xy[1], 4), z),
            size_m=size,  # type: ignore[arg-type]
            yaw_rad=round(yaw_rad, 5),
            rgba=tuple(float(v) for v in kind["rgba"]),  # type: ignore[arg-type]
            is_obstacle=bool(kind.get("is_obstacle", True)),
            role=role,  # type: ignore[arg-type]
            parts=tuple(tuple(part) for part in kind.get("parts", [])),
            aliases=tuple(kind.get("aliases", ())),
            colour=str(kind.get("colour", "")),
            size=str(kind.get("size", "")),
        )

    def fits(self, obj: SceneObject) -> tuple[bool, np.ndarray | None]:
        """Inside the bounds and (for obstacles) not overlapping an earlier obstacle."""
        x_min, y_min, x_max, y_max = self.bounds_m
        for shape, cx, cy, yaw, hx, hy in footprint_geoms(obj):
            if shape == "cylinder":
                ex = ey = hx
            else:
                ex = abs(hx * math.cos(yaw)) + abs(hy * math.sin(yaw))
                ey = abs(hx * math.sin(yaw)) + abs(hy * math.cos(yaw))
            if (
                cx - ex < x_min - _BOUNDS_TOLERANCE_M
                or cx + ex > x_max + _BOUNDS_TOLERANCE_M
                or cy - ey < y_min - _BOUNDS_TOLERANCE_M
                or cy + ey > y_max + _BOUNDS_TOLERANCE_M
            ):
                return False, None
        if not obj.is_obstacle:
            return True, None
        mask = rasterise_object(obj, self.grid)
        return not bool((mask & self.occupied).any()), mask

    def add(self, obj: SceneObject, mask: np.ndarray | None) -> None:
        self.objects.append(obj)
        if mask is not None:
            self.occupied |= mask

    def by_name(self, name: str) -> SceneObject:
        for obj in self.objects:
            if obj.name == name:
                return obj
        raise KeyError(name)


def _perimeter(layout: _Layout) -> None:
    spec = layout.data["perimeter"]
    x_min, y_min, x_max, y_max = layout.bounds_m
    half_t, half_h = float(spec["thickness_m"]) / 2.0, float(spec["height_m"]) / 2.0
    half_w, half_d = (x_max - x_min) / 2.0 + 2 * half_t, (y_max - y_min) / 2.0
    cx, cy = (x_min + x_max) / 2.0, (y_min + y_max) / 2.0
    walls = {
        "south": ((cx, y_min - half_t), (half_w, half_t)),
        "north": ((cx, y_max + half_t), (half_w, half_t)),
        "west": ((x_min - half_t, cy), (half_t, half_d)),
        "east": ((x_max + half_t, cy), (half_t, half_d)),
    }
    for side, ((x, y), (hx, hy)) in walls.items():
        layout.objects.append(
            SceneObject(
                object_id=len(layout.objects),
                name=f"{spec.get('name', 'wall')}_{side}",
                label=spec["label"],
                category=spec["category"],
                shape="box",
                position_m=(x, y, half_h),
                size_m=(hx, hy, half_h),
                rgba=tuple(float(v) for v in spec["rgba"]),  # type: ignore[arg-type]
                role="wall",
            )
        )


def _place_line(layout: _Layout, entry: dict[str, Any]) -> bool:
    line = entry["line"]
    start = np.array(line["from"], dtype=float)
    end = np.array(line["to"], dtype=float)
    length = float(np.linalg.norm(end - start))
    direction = (end - start) / length
    yaw = math.atan2(direction[1], direction[0])
    gap = float(line.get("gap_m", 0.0))
    pieces: list[tuple[float, float]] = [(0.0, length)]
    if gap > 0.0:
        lo, hi = line.get("gap_at", [0.5, 0.5])
        centre = float(layout.rng.uniform(lo, hi)) * length
        pieces = [(0.0, centre - gap / 2.0), (centre + gap / 2.0, length)]
    kind = layout.data["kinds"][entry["kind"]]
    index = 0
    for a, b in pieces:
        if b - a < 0.05:  # a gap at the very end leaves no piece there
            continue
        mid = start + direction * (a + b) / 2.0
        size = [(b - a) / 2.0, kind["size_m"][1], kind["size_m"][2]]
        obj = layout.make(
            f"{entry['name']}_{index}", entry["kind"], entry["role"], (mid[0], mid[1]), yaw, size_m=size
        )
        ok, mask = layout.fits(obj)
        if not ok:
            return False
        layout.add(obj, mask)
        index += 1
    return True


def _place_one(layout: _Layout, entry: dict[str, Any], name: str) -> bool:
    slot, group = layout.next_slot(entry["slot"]) if "slot" in entry else (None, {})
    jitter_m = float(entry.get("jitter_m", group.get("jitter_m", 0.0)))
    yaw_jitter = float(entry.get("yaw_jitter_deg", group.get("yaw_jitter_deg", 0.0)))
    for _ in range(PLACEMENT_DRAWS):
        if "near" in entry:
            anchor = layout.by_name(entry["near"]).position_m
            lo, hi = entry.get("distance_m", [0.8, 1.5])
            radius = float(layout.rng.uniform(lo, hi))
            bearing = float(layout.rng.uniform(-math.pi, math.pi))
            xy = (anchor[0] + radius * math.cos(bearing), anchor[1] + radius * math.sin(bearing))
            yaw = layout.draw_yaw(entry.get("yaw_deg", "any"), yaw_jitter)
        else:
            x, y, yaw_deg = slot if slot is not None else entry["pose"]
            dx, dy = layout.jitter(jitter_m)
            xy = (float(x) + dx, float(y) + dy)
            yaw = layout.draw_yaw(entry.get("yaw_deg", yaw_deg), yaw_jitter)
        obj = layout.make(name, entry["kind"], entry["role"], xy, yaw)
        ok, mask = layout.fits(obj)
        if ok:
            layout.add(obj, mask)
            return True
    return False


def goal_approach(scene: SceneSpec) -> tuple[np.ndarray, np.ndarray, GridGeometry]:
    """What the layout rule reads of a scene: every cell's distance to the goal's footprint (m), the mask of
    the largest 8-connected free region of the inflated occupancy grid, and the grid's geometry."""
    occupancy = OccupancyGrid.from_scene(
        scene, resolution_m=DEFAULT_RESOLUTION_M, robot_radius_m=ROBOT_RADIUS_M
    )
    to_goal_m = distance_to_mask_m(rasterise_object(scene.goal, occupancy.geometry), occupancy.geometry)
    return to_goal_m, occupancy.largest_free_component(), occupancy.geometry


def _goal_reachable(scene: SceneSpec, *, min_geodesic_m: float) -> bool:
    to_goal_m, region, geometry = goal_approach(scene)
    if not ((to_goal_m <= GOAL_SUCCESS_RADIUS_M - GOAL_APPROACH_MARGIN_M) & region).any():
        return False
    goal_zone = (to_goal_m <= GOAL_SUCCESS_RADIUS_M) & region
    return bool((distance_to_mask_m(goal_zone, geometry)[region] >= min_geodesic_m).any())


def build_scene_from_data(name: str, *, seed: int, max_attempts: int = MAX_LAYOUT_ATTEMPTS) -> SceneSpec:
    """Build scene ``name`` from its YAML data with layout seed ``seed`` (see the module doc for the rule)."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InvalidInputError(f"seed must be a non-negative integer, got {seed!r}")
    data = load_scene_data(name)
    width, depth = (float(v) for v in data["size_m"])
    bounds = (0.0, 0.0, width, depth)
    grid = GridGeometry.over_bounds(bounds, resolution_m=DEFAULT_RESOLUTION_M)
    min_geodesic = float(data.get("min_geodesic_m", DEFAULT_MIN_GEODESIC_M))
    failure = "no attempt made"
    for attempt in range(max_attempts):
        rng = np.random.default_rng(np.random.SeedSequence([zlib.crc32(name.encode()), int(seed), attempt]))
        layout = _Layout(data, rng, grid, bounds)
        _perimeter(layout)
        placed = True
        for entry in data["objects"]:
            count = int(entry.get("count", 1))
            names = [entry["name"]] if count == 1 else [f"{entry['name']}_{i}" for i in range(count)]
            for object_name in names:
                placed = (
                    _place_line(layout, entry) if "line" in entry else _place_one(layout, entry, object_name)
                )
                if not placed:
                    failure = f"could not place '{object_name}'"
                    break
            if not placed:
                break
        if not placed:
            continue
        goal = next(obj for obj in layout.objects if obj.role == "goal")
        scene = SceneSpec(
            name=data["name"],
            title=data["title"],
            seed=int(seed),
            bounds_m=bounds,
            objects=tuple(layout.objects),
            goal_object_id=goal.object_id,
            instruction=data["instruction"],
            floor_rgba=tuple(float(v) for v in data.get("floor_rgba", [0.45, 0.45, 0.45, 1.0])),  # type: ignore[arg-type]
            outdoor=bool(data.get("outdoor", False)),
            extra={"min_geodesic_m": min_geodesic, "layout_attempt": attempt, "area_m2": width * depth},
        )
        if _goal_reachable(scene, min_geodesic_m=min_geodesic):
            return scene
        failure = "goal not approachable from the largest free region"
    raise SceneLayoutError(
        f"scene '{name}' seed {seed}: no valid layout in {max_attempts} attempts (last: {failure})"
    )
