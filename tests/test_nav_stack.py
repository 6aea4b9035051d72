"""The navigation stack's units: footprint, costmap, global planner, controllers (semexp_bt/nav).

Depth comes from :class:`robots.null_robot.NullRobot` (a flat floor and vertical posts, ray-cast), so
every expectation is geometry that can be worked out by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from robots.go1 import go1_footprint, leg_envelope, load_go1_spec, trunk_boxes
from robots.null_robot import NullRobot
from semexp_bt.core.types import InvalidInputError, Pose2D, Twist
from semexp_bt.nav.controller import MotionLimits, SafetyRules, admissible, footprint_clearance, rollout
from semexp_bt.nav.costmap import INSCRIBED_COST, LETHAL_COST, NO_INFORMATION_COST, Costmap, CostmapConfig
from semexp_bt.nav.dwb import DwbConfig, DwbController, OscillationGuard
from semexp_bt.nav.footprint import Footprint
from semexp_bt.nav.frontiers import costmap_frontiers
from semexp_bt.nav.global_planner import GlobalPlanner
from semexp_bt.nav.pure_pursuit import RegulatedPurePursuit

FOOTPRINT = go1_footprint()


def costmap_at(
    pose: Pose2D, *, posts=(), turns: int = 8, config: CostmapConfig | None = None
) -> tuple[Costmap, NullRobot]:  # type: ignore[no-untyped-def]
    """A costmap built from a full turn in place at ``pose`` among ``posts`` ((id, x, y, r, h), ...)."""
    robot = NullRobot(start_pose=pose, posts=tuple(posts))
    costmap = Costmap(config or CostmapConfig(), footprint=FOOTPRINT, origin_xy=(pose.x_m, pose.y_m))
    for k in range(turns):
        robot._pose = Pose2D(pose.x_m, pose.y_m, pose.yaw_rad + k * math.tau / turns)
        costmap.integrate(robot.observe_depth(pixel_grids=[costmap.sampled_pixels]))
    robot._pose = pose
    return costmap, robot


# ------------------------------------------------------------------ footprint
def test_go1_footprint_is_the_plan_view_of_the_kinematic_geoms() -> None:
    spec = load_go1_spec()
    boxes = [*trunk_boxes().values(), leg_envelope(spec, spec.standing_trunk_height_m)]
    assert FOOTPRINT.x_max_m == pytest.approx(max(c[0] + h[0] for c, h in boxes))
    assert FOOTPRINT.x_min_m == pytest.approx(
        -0.378, abs=1e-3
    )  # the rear feet, 8 cm behind the trunk's own end
    assert FOOTPRINT.x_max_m == pytest.approx(0.29)  # the head's glass
    assert FOOTPRINT.half_width_m == pytest.approx(0.14975)
    assert FOOTPRINT.inscribed_radius_m == pytest.approx(0.14975)
    assert FOOTPRINT.circumscribed_radius_m == pytest.approx(math.hypot(0.378, 0.15), abs=2e-3)


def test_covering_discs_hold_the_rectangle_and_overshoot_little() -> None:
    centres, radius = FOOTPRINT.covering_discs
    xs, ys = np.meshgrid(
        np.linspace(FOOTPRINT.x_min_m, FOOTPRINT.x_max_m, 80),
        np.linspace(-FOOTPRINT.half_width_m, FOOTPRINT.half_width_m, 30),
    )
    points = np.stack([xs.ravel(), ys.ravel()], axis=1)
    nearest = np.min(np.hypot(points[:, None, 0] - centres[:, 0], points[:, None, 1] - centres[:, 1]), axis=1)
    assert (nearest <= radius + 1e-9).all()  # every point of the rectangle is covered
    sides = np.abs(centres[:, 1]).max() + radius - FOOTPRINT.half_width_m
    ends = FOOTPRINT.x_max_m - (centres[:, 0].max() + radius)
    assert 0.0 <= sides <= 0.03 and -0.04 <= ends <= 0.0


def test_footprint_refuses_a_rectangle_without_the_origin() -> None:
    with pytest.raises(InvalidInputError, match="origin"):
        Footprint(0.1, 0.5, 0.2)


# ------------------------------------------------------------------ costmap
def test_a_post_is_marked_lethal_and_the_floor_around_it_free() -> None:
    costmap, _ = costmap_at(Pose2D(0.0, 0.0, 0.0), posts=((1, 2.0, 0.0, 0.2, 0.6),))
    assert costmap.state_at((1.82, 0.0)) == "lethal"  # the face toward the robot
    assert costmap.state_at((1.0, 0.0)) == "free"
    assert costmap.state_at((2.0, 0.0)) != "free"  # behind the face: never seen through
    assert costmap.state_at((0.0, 0.0)) == "free"  # under the robot: footprint clearing
    assert costmap.state_at((30.0, 0.0)) == "unknown"  # beyond the range
    distance = costmap.distance_at(np.array([1.0, 0.0]))
    assert distance == pytest.approx(0.8, abs=0.06)
    cost = costmap.cost()
    r, c = costmap.cell_of(np.array([1.82, 0.0]))
    assert cost[r, c] == LETHAL_COST
    r, c = costmap.cell_of(np.array([1.6, 0.0]))
    assert cost[r, c] == INSCRIBED_COST  # 0.2 m from the face: inside the padded inscribed radius
    r, c = costmap.cell_of(np.array([30.0, 0.0])) if costmap.state_at((30.0, 0.0)) != "unknown" else (0, 0)
    assert cost[0, 0] == NO_INFORMATION_COST


def test_a_ray_that_passes_over_a_low_obstacle_does_not_clear_it() -> None:
    """A 0.15 m post 1.5 m ahead: the camera sees the floor behind it over its top, yet it stays lethal."""
    costmap, _ = costmap_at(Pose2D(0.0, 0.0, 0.0), posts=((1, 1.5, 0.0, 0.15, 0.15),))
    assert costmap.state_at((1.37, 0.0)) == "lethal"
    assert costmap.state_at((2.5, 0.0)) == "free"  # the floor seen beyond it


def test_the_distance_field_is_the_exact_transform_of_the_obstacles() -> None:
    """Lethal cells, and the never-observed cells next to them (what the camera did not see of a post)."""
    posts = ((1, 2.0, 0.5, 0.2, 0.6), (2, -1.0, 2.0, 0.3, 0.6))
    costmap, _ = costmap_at(Pose2D(0.0, 0.0, 0.3), posts=posts, config=CostmapConfig(unseen_extension_m=0.3))
    res, ext = costmap.resolution_m, costmap.config.unseen_extension_m
    lethal = costmap.lethal()
    near = ndimage.distance_transform_edt(~lethal, sampling=res) <= ext
    obstacles = lethal | (near & ~costmap.observed)
    exact = ndimage.distance_transform_edt(~obstacles, sampling=res)
    exact = np.minimum(exact, costmap.config.inflation_radius_m)
    assert (obstacles & ~lethal).any()  # the posts' far sides
    np.testing.assert_allclose(costmap.distance_m, exact, atol=1e-5)


def test_the_grid_grows_with_what_is_seen_and_stops_at_its_bound() -> None:
    costmap = Costmap(CostmapConfig(max_extent_m=8.0), footprint=FOOTPRINT, origin_xy=(0.0, 0.0))
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    first = costmap.shape
    for x in np.arange(0.0, 20.0, 2.0):
        robot._pose = Pose2D(float(x), 0.0, 0.0)
        costmap.integrate(robot.observe_depth(pixel_grids=[costmap.sampled_pixels]))
    rows, cols = costmap.shape
    assert cols > first[1] and cols * costmap.resolution_m <= 8.0 + 1e-9
    assert costmap.dropped_points > 0  # what lay beyond the bound was dropped and counted
    assert costmap.memory_bytes() <= (8.0 / 0.05) ** 2 * 10


def test_clear_around_forgets_a_ring_and_keeps_the_inside() -> None:
    costmap, _ = costmap_at(Pose2D(0.0, 0.0, 0.0), posts=((1, 2.0, 0.0, 0.2, 0.6),))
    revision = costmap.revision
    costmap.clear_around((0.0, 0.0), radius_m=3.0, keep_radius_m=0.8)
    assert costmap.state_at((1.82, 0.0)) == "unknown" and costmap.state_at((0.0, 0.0)) == "free"
    assert costmap.revision == revision + 1
    assert costmap.distance_at(np.array([1.0, 0.0])) == pytest.approx(costmap.config.inflation_radius_m)


def test_frontiers_lie_on_the_seen_unseen_boundary_away_from_the_robot() -> None:
    costmap, _ = costmap_at(Pose2D(0.0, 0.0, 0.0), turns=1)  # one 55-degree view of an empty floor
    found = costmap_frontiers(costmap, around_xy=(0.0, 0.0), radius_m=8.0)
    assert found
    for f in found:
        assert math.hypot(f.x_m, f.y_m) >= 1.0
        assert costmap.state_at((f.x_m, f.y_m)) == "free"


# ------------------------------------------------------------------ global planner
def walled_costmap(*, door: bool) -> Costmap:
    """A known 8 m x 8 m room split by a wall at x = 0 with (or without) a 1.2 m door at y = 0."""
    res = 0.05
    occupied = np.zeros((160, 160), dtype=bool)
    occupied[[0, -1], :] = True
    occupied[:, [0, -1]] = True
    occupied[:, 79:81] = True
    if door:
        occupied[68:92, 79:81] = False
    costmap = Costmap(CostmapConfig(), footprint=FOOTPRINT, origin_xy=(0.0, 0.0))
    costmap.set_known(occupied, lower_left_xy=(-4.0, -4.0), resolution_m=res)
    return costmap


def test_the_plan_goes_through_the_door_and_keeps_off_the_walls() -> None:
    costmap = walled_costmap(door=True)
    plan = GlobalPlanner().plan(costmap, start_xy=(-2.0, 2.5), goal_xy=(2.0, 2.5))
    assert plan.ok
    crossing = plan.path_xy[np.argmin(np.abs(plan.path_xy[:, 0]))]
    assert abs(crossing[1]) < 0.3  # through the door, near its middle
    assert costmap.distance_at(plan.path_xy).min() >= costmap.inscribed_radius_m - 0.03
    assert plan.length_m >= math.hypot(2.0, 2.5) * 2
    assert math.dist(plan.path_xy[-1], (2.0, 2.5)) <= 0.9
    assert plan.cost_to_go_at(np.array([[-2.0, 2.5]]))[0] > plan.cost_to_go_at(np.array([[1.0, 0.0]]))[0]


def test_no_path_is_an_explicit_answer() -> None:
    plan = GlobalPlanner().plan(walled_costmap(door=False), start_xy=(-2.0, 2.5), goal_xy=(2.0, 2.5))
    assert plan.status == "no_path" and len(plan.path_xy) == 0 and plan.length_m == math.inf


def test_travel_distances_go_round_what_the_costmap_knows() -> None:
    """Eq. 9's ``travel_cost: costmap``: through the door, never through the wall; unknown space at its length."""
    planner = GlobalPlanner()
    through_door = planner.travel_distances(
        walled_costmap(door=True), start_xy=(-1.0, 2.5), targets_xy=[(1.0, 2.5), (-1.0, 0.5)]
    )
    assert through_door is not None
    behind_wall, same_side = through_door
    assert behind_wall >= 2 * math.hypot(1.0, 2.5) - 0.8  # down to the door and back up, less the tolerance
    assert 1.2 - 0.1 <= same_side <= 2.0 + 0.1  # straight, reached within goal_tolerance_m
    walled_off = planner.travel_distances(
        walled_costmap(door=False), start_xy=(-1.0, 2.5), targets_xy=[(1.0, 2.5)]
    )
    assert walled_off is not None and walled_off[0] == math.inf
    unknown = Costmap(CostmapConfig(), footprint=FOOTPRINT, origin_xy=(0.0, 0.0))
    (open_ground,) = planner.travel_distances(unknown, start_xy=(0.0, 0.0), targets_xy=[(5.0, 0.0)])
    assert 4.1 <= open_ground <= 5.1


def test_travel_distances_need_a_passable_cell_near_the_robot() -> None:
    occupied = np.zeros((80, 80), dtype=bool)
    occupied[20:60, 20:60] = True  # a 2 m block: its middle is more than start_escape_m from free floor
    costmap = Costmap(CostmapConfig(), footprint=FOOTPRINT, origin_xy=(0.0, 0.0))
    costmap.set_known(occupied, lower_left_xy=(-2.0, -2.0), resolution_m=0.05)
    planner = GlobalPlanner()
    assert planner.travel_distances(costmap, start_xy=(0.0, 0.0), targets_xy=[(1.8, 1.8)]) is None
    assert planner.travel_distances(costmap, start_xy=(-1.8, -1.8), targets_xy=[(1.8, 1.8)]) is not None


def test_unknown_space_is_traversable_at_a_price() -> None:
    costmap = Costmap(CostmapConfig(), footprint=FOOTPRINT, origin_xy=(0.0, 0.0))
    plan = GlobalPlanner().plan(costmap, start_xy=(0.0, 0.0), goal_xy=(5.0, 0.0))
    assert plan.ok and 4.1 <= plan.length_m <= 5.3
    assert math.dist(plan.path_xy[-1], (5.0, 0.0)) <= 0.9


# ------------------------------------------------------------------ controllers
def drive(controller, costmap: Costmap, start: Pose2D, goal: tuple[float, float], seconds: float = 40.0):  # type: ignore[no-untyped-def]
    """Closed loop at 12.5 Hz on a perfect unicycle (acceleration-limited): the poses and the least clearance."""
    plan = GlobalPlanner().plan(costmap, start_xy=(start.x_m, start.y_m), goal_xy=goal)
    assert plan.ok
    pose, velocity, dt = start, Twist(), 0.08
    least = math.inf
    for _ in range(int(seconds / dt)):
        if math.dist((pose.x_m, pose.y_m), plan.path_xy[-1]) < 0.15:
            break
        result = controller.compute(plan=plan, costmap=costmap, pose=pose, velocity=velocity, stamp_s=0.0)
        states, _ = rollout(pose, velocity, np.array([[result.twist.linear_x_mps, result.twist.angular_z_radps]]),
                            limits=MotionLimits(), horizon_s=dt, dt_s=dt)  # fmt: skip
        x, y, yaw = states[0, -1]
        velocity = Twist(result.twist.linear_x_mps, 0.0, result.twist.angular_z_radps)
        pose = Pose2D(float(x), float(y), float(yaw))
        least = min(
            least, float(footprint_clearance(costmap, np.array([x]), np.array([y]), np.array([yaw]))[0])
        )
    return pose, plan, least


@pytest.mark.parametrize("controller", [RegulatedPurePursuit(), DwbController()], ids=["rpp", "dwb"])
def test_controllers_take_the_body_through_the_door_with_clearance(controller) -> None:  # type: ignore[no-untyped-def]
    costmap = walled_costmap(door=True)
    pose, plan, least = drive(controller, costmap, Pose2D(-2.0, 2.5, -1.0), (2.0, 2.5))
    assert math.dist((pose.x_m, pose.y_m), plan.path_xy[-1]) < 0.15
    assert least >= SafetyRules().min_clearance_m - 1e-6


def test_backing_up_only_onto_known_free_cells() -> None:
    costmap, _ = costmap_at(Pose2D(0.0, 0.0, 0.0), turns=1)  # nothing behind the robot was ever seen
    pose = Pose2D(0.0, 0.0, 0.0)
    states, commands = rollout(
        pose, Twist(), np.array([[-0.3, 0.0], [0.3, 0.0]]), limits=MotionLimits(), horizon_s=1.5, dt_s=0.1
    )
    ok, _ = admissible(costmap, pose, states, commands, rules=SafetyRules())
    assert not ok[0] and ok[1]


@settings(max_examples=25, deadline=None)
@given(x=st.floats(-1.5, 1.5), y=st.floats(-1.5, 1.5), yaw=st.floats(-math.pi, math.pi))
def test_the_commanded_motion_is_always_admissible(x: float, y: float, yaw: float) -> None:
    """Wherever the robot stands clear among posts, the twist commanded keeps the rules over the horizon."""
    costmap = _POSTS_MAP
    pose = Pose2D(x, y, yaw)
    if (
        footprint_clearance(costmap, np.array([x]), np.array([y]), np.array([yaw]))[0]
        < SafetyRules().min_clearance_m
    ):
        return  # inside the margin: the rule is "never closer", checked by the controllers' own tests
    plan = GlobalPlanner().plan(costmap, start_xy=(x, y), goal_xy=(3.0, 0.0))
    if not plan.ok:
        return
    controller = RegulatedPurePursuit()
    result = controller.compute(plan=plan, costmap=costmap, pose=pose, velocity=Twist(), stamp_s=0.0)
    if result.status == "blocked":
        assert result.twist == Twist()
        return
    target = np.array([[result.twist.linear_x_mps, result.twist.angular_z_radps]])
    states, commands = rollout(pose, Twist(), target, limits=MotionLimits(), horizon_s=1.0, dt_s=0.1)
    ok, _ = admissible(costmap, pose, states, commands, rules=SafetyRules())
    assert ok[0]


_POSTS_MAP = costmap_at(Pose2D(0.0, 0.0, 0.0), posts=((1, 1.2, 0.6, 0.2, 0.6), (2, 1.0, -0.9, 0.25, 0.6)))[0]


# ------------------------------------------------------------------ issue #17, second round
def corridor_costmap(*, free_cells: int) -> Costmap:
    """A known 8 m x 8 m floor with a corridor along x whose free width is ``free_cells`` cells (from
    y = -0.30 m up), walled on both sides."""
    occupied = np.zeros((160, 160), dtype=bool)
    occupied[:74, :] = True
    occupied[74 + free_cells :, :] = True
    costmap = Costmap(CostmapConfig(), footprint=FOOTPRINT, origin_xy=(0.0, 0.0))
    costmap.set_known(occupied, lower_left_xy=(-4.0, -4.0), resolution_m=0.05)
    return costmap


def test_the_clearance_is_the_rectangles_own_not_a_disc_covers() -> None:
    """In a 0.55 m corridor (wall cell centres 0.60 m apart) the centred 0.30 m body has 0.15 m each side:
    a straight walk is admissible. The first round's disc cover said 0.12 m there and refused it."""
    costmap = corridor_costmap(free_cells=11)
    pose = Pose2D(-2.0, -0.025, 0.0)
    clearance = float(footprint_clearance(costmap, np.array([-2.0]), np.array([-0.025]), np.array([0.0]))[0])
    assert clearance == pytest.approx(0.15, abs=0.005)
    centres, radius = FOOTPRINT.covering_discs
    disc_clearance = float(costmap.distance_at(centres + np.array([-2.0, -0.025])).min()) - radius
    assert disc_clearance < SafetyRules().min_clearance_m <= clearance
    states, commands = rollout(
        pose, Twist(), np.array([[0.5, 0.0]]), limits=MotionLimits(), horizon_s=1.5, dt_s=0.1
    )
    ok, least = admissible(costmap, pose, states, commands, rules=SafetyRules())
    assert ok[0] and least[0] == pytest.approx(0.15, abs=0.005)


def test_a_passage_as_narrow_as_the_body_allows_is_planned_and_driven() -> None:
    """A 0.55 m corridor: no planning cell's centre has the padded inscribed radius (0.28 m), yet the plan
    goes through it (a cell is passable where one of its costmap cells is) and RPP drives it with the
    controller's clearance."""
    costmap = corridor_costmap(free_cells=11)
    plan = GlobalPlanner().plan(costmap, start_xy=(-1.0, -0.025), goal_xy=(1.5, -0.025))
    assert plan.ok and plan.length_m == pytest.approx(2.5, abs=0.9)
    pose, plan, least = drive(
        RegulatedPurePursuit(), costmap, Pose2D(-1.0, -0.025, 0.0), (1.5, -0.025), seconds=10.0
    )
    # 1.8 m along the corridor in 10 s (slowed by the clearance and the approach to the end), on its centre line.
    assert pose.x_m >= 0.8 and abs(pose.y_m + 0.025) < 0.03
    assert least >= SafetyRules().min_clearance_m - 1e-6


def test_a_turn_in_place_sweeping_never_observed_floor_is_refused() -> None:
    """One view ahead: the floor beside the robot was never seen, so a turn in place (its rear corners swing
    out sideways) is refused, while walking straight on is not. Once the turning circle is known free
    (the start pose's, assumed at the start of a mission), the turn is admissible."""
    costmap, _ = costmap_at(Pose2D(0.0, 0.0, 0.0), turns=1)
    pose = Pose2D(0.0, 0.0, 0.0)
    targets = np.array([[0.0, 0.8], [0.5, 0.0]])
    states, commands = rollout(pose, Twist(), targets, limits=MotionLimits(), horizon_s=1.0, dt_s=0.1)
    ok, _ = admissible(costmap, pose, states, commands, rules=SafetyRules())
    assert not ok[0] and ok[1]
    ok, _ = admissible(costmap, pose, states, commands, rules=SafetyRules(sweep_observed_only=False))
    assert ok[0]  # the first round's rule: lethal cells only
    changed = costmap.assume_free_around((0.0, 0.0), radius_m=FOOTPRINT.circumscribed_radius_m + 0.05)
    assert changed > 0 and costmap.state_at((0.0, -0.35)) == "free"
    ok, _ = admissible(costmap, pose, states, commands, rules=SafetyRules())
    assert ok[0] and ok[1]


def test_assuming_the_start_free_keeps_what_was_seen() -> None:
    costmap, _ = costmap_at(Pose2D(0.0, 0.0, 0.0), posts=((1, 0.0, 0.55, 0.1, 0.6),), turns=16)
    lethal_before = costmap.lethal().copy()
    costmap.assume_free_around((0.0, 0.0), radius_m=0.5)
    np.testing.assert_array_equal(costmap.lethal(), lethal_before)
    assert lethal_before.any()


# ------------------------------------------------------------------ issue #17, oscillation critic
def test_a_turn_that_flipped_may_not_flip_back_until_the_base_has_turned_or_moved() -> None:
    """Nav2's OscillationCritic: left, then right, then left again is refused until 0.2 rad or 0.05 m."""
    guard = OscillationGuard(reset_dist_m=0.05, reset_angle_rad=0.2)
    start = Pose2D(0.0, 0.0, 0.0)
    left, right, ahead = [0.0, 0.5], [0.0, -0.5], [0.4, 0.0]
    targets = np.array([left, right, ahead])
    guard.commanded(start, Twist(angular_z_radps=0.5))
    assert not guard.forbidden(start, targets).any()  # one direction so far
    guard.commanded(start, Twist(angular_z_radps=-0.5))  # the flip
    assert guard.forbidden(Pose2D(0.0, 0.0, -0.1), targets).tolist() == [True, False, False]
    assert not guard.forbidden(Pose2D(0.0, 0.0, -0.21), targets).any()  # turned far enough
    guard.commanded(Pose2D(0.0, 0.0, -0.21), Twist(angular_z_radps=0.5))  # flips again
    assert guard.forbidden(Pose2D(0.03, 0.0, -0.2), targets).tolist() == [False, True, False]
    assert not guard.forbidden(Pose2D(0.06, 0.0, -0.2), targets).any()  # moved far enough
    guard.reset()
    guard.commanded(start, Twist(linear_x_mps=0.4))
    guard.commanded(start, Twist(linear_x_mps=-0.2))  # forward, then backing up
    assert guard.forbidden(start, targets).tolist() == [False, False, True]


@pytest.mark.parametrize(
    "guarded, unguarded",
    [
        (
            DwbController(),
            DwbController(DwbConfig(oscillation_reset_dist_m=0.0, oscillation_reset_angle_rad=0.0)),
        ),
    ],
    ids=["dwb"],
)
def test_the_controller_keeps_turning_the_way_it_flipped_to_when_the_path_swings_back(
    guarded, unguarded
) -> None:  # type: ignore[no-untyped-def]
    """In a known empty room: the path to the left asks a left turn, then a path to the right a right turn;
    the path to the left again does not get a left turn at the same pose (the sampler without its critic
    turns left again; pursuit's own rotation to the left would)."""
    room = np.zeros((160, 160), dtype=bool)
    room[[0, -1], :] = True
    room[:, [0, -1]] = True
    costmap = Costmap(CostmapConfig(), footprint=FOOTPRINT, origin_xy=(0.0, 0.0))
    costmap.set_known(room, lower_left_xy=(-4.0, -4.0), resolution_m=0.05)
    pose = Pose2D(0.0, 0.0, 0.0)
    planner = GlobalPlanner()
    to_the_left = planner.plan(costmap, start_xy=(0.0, 0.0), goal_xy=(0.0, 2.5))
    to_the_right = planner.plan(costmap, start_xy=(0.0, 0.0), goal_xy=(0.0, -2.5))

    def turn(controller, plan) -> float:  # type: ignore[no-untyped-def]
        return controller.compute(
            plan=plan, costmap=costmap, pose=pose, velocity=Twist(), stamp_s=0.0
        ).twist.angular_z_radps

    for controller in (guarded, unguarded):
        if controller is not None:
            assert turn(controller, to_the_left) > 0 and turn(controller, to_the_right) < 0
    if unguarded is not None:
        assert turn(unguarded, to_the_left) > 0
    assert turn(guarded, to_the_left) <= 0
