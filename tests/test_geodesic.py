"""Geodesic oracle: hand-worked distances in hand-built scenes, and metric properties in real ones."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.scene import SceneObject, SceneSpec
from semexp_bt.core.types import InvalidInputError
from sims.catalogue import build_scene, list_scenes
from sims.geodesic import GeodesicOracle
from sims.occupancy import OccupancyGrid
from sims.robot_footprint import ROBOT_RADIUS_M

RES = 0.05
ROOM = (0.0, 0.0, 10.0, 8.0)


def box(
    object_id: int, name: str, x: float, y: float, hx: float, hy: float, *, role: str = "obstacle"
) -> SceneObject:
    return SceneObject(object_id, name, name, name, "box", (x, y, 0.5), (hx, hy, 0.5), role=role)  # type: ignore[arg-type]


def room(*objects: SceneObject) -> SceneSpec:
    goal = objects[0] if objects else box(0, "marker", 9.0, 7.0, 0.1, 0.1)
    return SceneSpec("test", "Test", 0, ROOM, objects or (goal,), goal.object_id, "find it", goal.category)


#: A wall across x = 5 from the floor up to y = 5.5; the only way round is the 2.5 m gap at the top.
WALL_TOP_Y, WALL_HALF_T = 5.5, 0.05
WALLED = room(box(0, "wall", 5.0, WALL_TOP_Y / 2, WALL_HALF_T, WALL_TOP_Y / 2, role="wall"))
EMPTY = room(box(0, "marker", 9.5, 7.5, 0.05, 0.05))


@pytest.fixture(scope="module")
def walled() -> GeodesicOracle:
    return GeodesicOracle(WALLED, resolution_m=RES)


@pytest.fixture(scope="module")
def empty() -> GeodesicOracle:
    return GeodesicOracle(EMPTY, resolution_m=RES)


@pytest.fixture(scope="module")
def warehouse() -> GeodesicOracle:
    return GeodesicOracle(build_scene("warehouse_b", seed=4))


def around_wall_end(a: tuple[float, float], b: tuple[float, float], inflation_m: float) -> float:
    """Shortest path from a (left, below the top) to b (right) around the wall's top end inflated by R.

    The inflated end is two quarter circles of radius R about the wall's top corners joined by the
    wall's thickness: tangent segment + arc on each side, plus the straight top.
    """

    def leg(p: tuple[float, float], corner: tuple[float, float], clockwise: bool) -> float:
        d = math.dist(p, corner)
        bearing = math.atan2(p[1] - corner[1], p[0] - corner[0])
        tangent = bearing - math.acos(inflation_m / d) if clockwise else bearing + math.acos(inflation_m / d)
        arc = abs(wrap_angle(math.pi / 2 - tangent))
        return math.sqrt(d * d - inflation_m**2) + inflation_m * arc

    left, right = (5.0 - WALL_HALF_T, WALL_TOP_Y), (5.0 + WALL_HALF_T, WALL_TOP_Y)
    return leg(a, left, True) + 2 * WALL_HALF_T + leg(b, right, False)


def test_detour_around_a_wall_matches_the_hand_worked_length(walled: GeodesicOracle) -> None:
    a, b = (2.0, 1.0), (8.0, 1.0)
    exact = around_wall_end(a, b, ROBOT_RADIUS_M)
    # Rasterising keeps cells within half a cell of the wall and inflating works on cell centres, so
    # the oracle's wall is up to about two cells fatter than the exact one.
    fatter = around_wall_end(a, b, ROBOT_RADIUS_M + 2 * RES)
    d = walled.distance(a, b)
    assert exact - 1e-6 <= d <= fatter + RES
    assert d > math.dist(a, b) + 5.0  # it really goes round, it does not leak through the wall
    path = walled.path(a, b)
    assert np.allclose(path[0], a) and np.allclose(path[-1], b)
    assert path[:, 1].max() > WALL_TOP_Y + ROBOT_RADIUS_M / 2  # the path wraps over the inflated end


def test_empty_room_distance_is_euclidean(empty: GeodesicOracle) -> None:
    for a, b in [((1.0, 1.0), (9.0, 7.0)), ((1.0, 1.0), (8.7, 2.3)), ((4.321, 3.0), (4.0, 6.5))]:
        assert empty.distance(a, b) == pytest.approx(math.dist(a, b), abs=1e-9)
        assert len(empty.path(a, b)) == 2


@settings(max_examples=60, deadline=None)
@given(ax=st.floats(0.8, 9.2), ay=st.floats(0.8, 7.2), bx=st.floats(0.8, 9.2), by=st.floats(0.8, 7.2))
def test_empty_room_property(empty: GeodesicOracle, ax: float, ay: float, bx: float, by: float) -> None:
    assert empty.distance((ax, ay), (bx, by)) == pytest.approx(math.hypot(bx - ax, by - ay), abs=1e-9)


@settings(max_examples=40, deadline=None)
@given(ax=st.floats(0.0, 14.0), ay=st.floats(0.0, 12.0), bx=st.floats(0.0, 14.0), by=st.floats(0.0, 12.0))
def test_geodesic_is_never_shorter_than_euclidean(
    warehouse: GeodesicOracle, ax: float, ay: float, bx: float, by: float
) -> None:
    d = warehouse.distance((ax, ay), (bx, by))
    both_free = warehouse.is_free((ax, ay)) and warehouse.is_free((bx, by))
    if not both_free:
        assert d == math.inf
    elif math.isfinite(d):
        assert d >= math.hypot(bx - ax, by - ay) - 1e-9
        path = warehouse.path((ax, ay), (bx, by))
        for p, q in zip(path[:-1], path[1:], strict=True):  # every leg is collision-free
            for t in np.linspace(0.0, 1.0, 50):
                assert warehouse.is_free(p + t * (q - p))
        # The field over-estimates by at most ~2.8 % (16-connected lattice) plus a cell or two.
        field_value = warehouse.field_value(warehouse.distance_field((bx, by)), (ax, ay))
        assert d <= field_value + 2 * 0.05 + 1e-9
        assert field_value <= 1.03 * d + 0.2


def test_distance_field_values(empty: GeodesicOracle, walled: GeodesicOracle) -> None:
    field = empty.distance_field((5.0, 4.0))
    assert empty.field_value(field, (5.0, 4.0)) == 0.0
    assert empty.field_value(field, (8.0, 4.0)) == pytest.approx(3.0, abs=0.06)  # axis-aligned: exact
    diagonal = empty.field_value(field, (8.0, 7.0))
    assert math.hypot(3, 3) - 0.08 <= diagonal <= math.hypot(3, 3) * 1.03
    assert np.isinf(field[empty.occupancy.blocked]).all()
    # goal radius: every free cell within the radius is a source
    disc = empty.distance_field((5.0, 4.0), goal_radius_m=1.0)
    assert empty.field_value(disc, (5.9, 4.0)) == 0.0
    assert empty.field_value(disc, (8.0, 4.0)) == pytest.approx(2.0, abs=0.08)
    assert empty.distance_field((5.0, 4.0)) is field  # cached
    walled_field = walled.distance_field((8.0, 1.0))
    assert walled.field_value(walled_field, (2.0, 1.0)) >= walled.distance((2.0, 1.0), (8.0, 1.0)) > 11.0


def test_distance_to_object_is_measured_to_the_success_region() -> None:
    # A 1 x 1 m box centred at (5, 4); from (1, 4) its boundary is 3.5 m away, the 1 m region 2.5 m.
    target = box(0, "crate", 5.0, 4.0, 0.5, 0.5)
    oracle = GeodesicOracle(room(target))
    assert oracle.distance_to_object((1.0, 4.0), 0, success_radius_m=1.0) == pytest.approx(2.5, abs=2 * RES)
    assert oracle.distance_to_object((1.0, 4.0), 0, success_radius_m=2.0) == pytest.approx(1.5, abs=2 * RES)
    assert oracle.distance_to_object((5.0, 2.8), 0, success_radius_m=1.0) == 0.0  # already inside it
    nearest = oracle.nearest_point_on_object((1.0, 4.0), 0)
    assert nearest[0] == pytest.approx(4.5, abs=RES) and nearest[1] == pytest.approx(4.0, abs=RES)
    path = oracle.path_to_object((1.0, 4.0), 0, success_radius_m=1.0)
    assert np.allclose(path[0], (1.0, 4.0)) and path[-1][0] == pytest.approx(3.5, abs=2 * RES)


def test_an_overhead_part_counts_for_the_success_region_and_not_for_the_obstacles() -> None:
    # A 0.2 m post at (5, 4) under a 2 x 0.4 m sign board 1.5 m up, reaching 0.9 m towards +x: the board
    # blocks nothing, but a robot 1 m from its tip is 1 m from the object (SR and L* alike).
    sign = SceneObject(
        0,
        "sign",
        "sign",
        "sign",
        "box",
        (5.0, 4.0, 0.8),
        (0.1, 0.1, 0.8),
        parts=(("box", 0.9, 0.0, 0.8, 1.0, 0.2, 0.05),),
    )
    oracle = GeodesicOracle(room(sign), resolution_m=RES)
    assert oracle.is_free((6.5, 4.0))  # under the board
    assert sign.boundary_distance_m((7.9, 4.0)) == pytest.approx(1.0)
    mask = oracle.object_goal_mask(0, success_radius_m=1.0)
    geometry = oracle.occupancy.geometry
    assert mask[geometry.cell_of((7.85, 4.0))] and not mask[geometry.cell_of((8.05, 4.0))]


@pytest.mark.parametrize("name", list_scenes())
def test_sr_and_l_star_measure_to_the_same_success_region(name: str) -> None:
    # The scorer's test (boundary_distance_m <= r_s) and the oracle's goal cells agree on every free cell
    # but those within a cell of the region's edge (the grid's own rounding).
    scene = build_scene(name, seed=0)
    oracle = GeodesicOracle(scene)
    mask = oracle.object_goal_mask(scene.goal_object_id, success_radius_m=1.0)
    geometry = oracle.occupancy.geometry
    rows, cols = np.nonzero(oracle.occupancy.free)
    centres = geometry.centre_of(rows, cols)
    distance = np.array([scene.goal.boundary_distance_m((float(x), float(y))) for x, y in centres])
    clear = np.abs(distance - 1.0) > 1.5 * geometry.resolution_m
    print(name, "goal cells", int(mask.sum()), "cells compared", int(clear.sum()))
    assert np.array_equal(mask[rows, cols][clear], distance[clear] <= 1.0)


def test_unreachable_and_blocked_queries_are_infinite() -> None:
    # A closed pen of four walls around (8, 6): the inside is free but cut off.
    pen = (
        box(0, "goal", 8.0, 6.0, 0.1, 0.1),
        box(1, "pen_s", 8.0, 4.5, 1.6, 0.05),
        box(2, "pen_n", 8.0, 7.5, 1.6, 0.05),
        box(3, "pen_w", 6.5, 6.0, 0.05, 1.6),
        box(4, "pen_e", 9.5, 6.0, 0.05, 1.6),
    )
    oracle = GeodesicOracle(room(*pen))
    assert oracle.is_free((7.0, 5.2))
    assert oracle.distance((1.0, 1.0), (7.0, 5.2)) == math.inf
    assert oracle.path((1.0, 1.0), (7.0, 5.2)).shape == (0, 2)
    assert oracle.distance_to_object((1.0, 1.0), 0, success_radius_m=1.0) == math.inf
    assert oracle.distance_to_object((7.0, 5.2), 0, success_radius_m=1.0) < 1.0
    assert oracle.distance((8.0, 4.5), (1.0, 1.0)) == math.inf  # starts inside a wall
    assert oracle.distance((1.0, 1.0), (30.0, 1.0)) == math.inf  # ends outside the scene


def test_is_free_respects_the_robot_radius(walled: GeodesicOracle) -> None:
    assert walled.is_free((2.0, 1.0))
    assert not walled.is_free((5.0 - WALL_HALF_T - ROBOT_RADIUS_M + 0.1, 1.0))
    assert walled.is_free((5.0 - WALL_HALF_T - ROBOT_RADIUS_M - 0.1, 1.0))
    assert not walled.is_free((0.1, 4.0))  # within the radius of the room's boundary
    grid = OccupancyGrid.from_scene(WALLED, robot_radius_m=0.0)
    assert grid.is_free((0.1, 4.0))


def test_bad_input_is_rejected(empty: GeodesicOracle) -> None:
    with pytest.raises(InvalidInputError, match="goal_xy"):
        empty.distance_field((math.nan, 1.0))
    with pytest.raises(InvalidInputError, match="goal_radius_m"):
        empty.distance_field((1.0, 1.0), goal_radius_m=-1.0)
    with pytest.raises(InvalidInputError, match="a_xy"):
        empty.distance((1.0, math.inf), (2.0, 2.0))
    with pytest.raises(KeyError, match="no object with id 99"):
        empty.distance_to_object((1.0, 1.0), 99, success_radius_m=1.0)
    with pytest.raises(InvalidInputError, match="resolution_m"):
        GeodesicOracle(EMPTY, resolution_m=0.0)
