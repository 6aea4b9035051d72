"""The mission runner: one mission tree on any ``Robot``, ticking in lockstep with the robot's clock.

:func:`run_mission` takes what a mission needs and nothing of where it runs: a robot backend, a
perception source, a relevance scorer, a planner, the parsed mission and its resolved configuration. It
prepares the blackboard (the topological memory lives there), builds the tree, ticks it once per
:data:`TICK_PERIOD_S` of robot time until the root succeeds or fails or the time runs out, stops the robot
and returns the executive's record (:class:`MissionResult`). It never asks where the goal is: a simulated
episode (``semexp_bt.app.episode``) scores the result against its scene afterwards, and a privileged
reference strategy is handed its knowledge explicitly (:class:`PrivilegedKnowledge`).

Observers (:class:`TickObserver`: the tick recorder, the terminal display, a viewer) see the tree after
every tick; they cannot change the mission.

Example:
    >>> from semexp_bt.app.runner import MissionComponents, run_mission  # doctest: +SKIP
    >>> result = run_mission(mission=parse_mission("trees/object_search.yaml"), components=components,
    ...                      config=SemExpConfig(), instructions=["find the chair"], seed=0)  # doctest: +SKIP
    >>> result.outcome  # doctest: +SKIP
    'success'
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import py_trees

from behaviours.services import MissionServices
from robots.interface import Robot
from semexp_bt.app.executive import MissionTree, build_tree, prepare_board
from semexp_bt.core.clock import is_due
from semexp_bt.core.config import SemExpConfig
from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.relevance import RelevanceScorer
from semexp_bt.core.types import Pose2D, Twist
from semexp_bt.nav.controller import PathController
from semexp_bt.perception.interface import PerceptionSource
from trees.loader import MissionDocument
from trees.registry import NodeRegistry

#: One tree tick per 20 ms of robot time: the gait's 50 Hz.
TICK_PERIOD_S = 0.02
#: The runner stops a mission this long after its budget (``budget_s``) if the tree's own budget guard
#: has not ended it (a safety net, never the mission's rule).
BUDGET_GRACE_S = 30.0


@dataclass
class MissionComponents:
    """What a mission runs on.

    Attributes:
        robot: the backend (MuJoCo, ROS 2, or a test robot).
        perception: the evidence source (emulator, model adapters, or a fake).
        relevance: the relevance scorer S in [0, 1] (cached).
        planner: the path-following controller.
        gait: ``(robot, twist) -> None`` realising twists with joint targets; None when the robot walks
            by itself.
    """

    robot: Robot
    perception: PerceptionSource
    relevance: RelevanceScorer
    planner: PathController
    gait: Callable[[Robot, Twist], None] | None = None


@dataclass(frozen=True)
class PrivilegedKnowledge:
    """PRIVILEGED: what a reference strategy (``oracle``) is told about the goal; never the method.

    Attributes:
        goal_xy: the true goal position ``(x, y)`` in ``map``.
        goal_distance: ``(x, y) -> true geodesic distance (m)`` to the goal's success region.
        goal_point_xy: for ``oracle_nav``: the point of the goal object's footprint nearest
            ``standpoint_xy`` (the subgoal it drives to and faces).
        standpoint_xy: for ``oracle_nav``: the free point within the success radius of the goal object at
            the end of the true shortest path from the start.
        occupancy: for ``oracle_nav``: the true occupancy of the scene, ``(occupied (rows along y, cols
            along x), lower-left corner (x, y), cell side)``; the mission's costmap starts as this map
            and is not changed by depth frames.
    """

    goal_xy: tuple[float, float]
    goal_distance: Callable[[tuple[float, float]], float] | None = None
    goal_point_xy: tuple[float, float] | None = None
    standpoint_xy: tuple[float, float] | None = None
    occupancy: tuple[np.ndarray, tuple[float, float], float] | None = None


@dataclass
class MissionRun:
    """A mission in progress, as observers see it.

    Attributes:
        tree: the py_trees tree.
        board: the runner's blackboard client (the memory, the subgoal, the outcome).
        services: what the behaviours call (robot, perception, timings, decision log, events).
        tick: ticks run so far.
    """

    tree: MissionTree
    board: py_trees.blackboard.Client
    services: MissionServices
    tick: int = 0

    @property
    def robot(self) -> Robot:
        return self.services.robot

    def now_s(self) -> float:
        """The robot's clock."""
        return self.services.clock()


class TickObserver(Protocol):
    """Sees the mission tree after every tick (recorder, display, viewer).

    Attributes:
        wants_activity_stream: whether it reads the blackboard's activity stream (the runner enables it).
    """

    wants_activity_stream: bool

    def start(self, run: MissionRun) -> None:
        """The tree is built and set up; no tick has run."""
        ...

    def after_tick(self, run: MissionRun) -> None:
        """Tick ``run.tick`` has just run."""
        ...

    def finish(self, run: MissionRun, outcome: str) -> None:
        """The mission has ended with ``outcome`` and the robot has been stopped."""
        ...


@dataclass
class MissionResult:
    """The executive's record of one mission: what it did, not how well (that needs ground truth).

    Attributes:
        outcome: ``success``, ``budget_exceeded``, ``fallen``, ``stuck``, ``failed``, ...
        instructions: the instructions, in search order.
        found_objects: the confirmed targets (label, position, stamp, where the robot stood).
        positions: the base position after every tick, the start first.
        ticks: ticks run.
        tick_wall_s: the wall time of each tick.
        tick_cpu_s: the CPU time of each tick on the executive's own thread (the models' worker threads
            and other processes excluded), the figure a shared machine's load does not inflate; empty
            unless the mission was run with ``measure_tick_cpu``.
        sim_time_s: the robot clock when the mission ended.
        services: the mission's services (decision log, events, stage timings).
        memory: the topological memory at the end.
    """

    outcome: str
    instructions: list[str]
    found_objects: list[dict[str, Any]]
    positions: list[np.ndarray]
    ticks: int
    tick_wall_s: list[float]
    tick_cpu_s: list[float]
    sim_time_s: float
    services: MissionServices
    memory: TopologicalMemory

    def tick_wall_ms(self) -> dict[str, float]:
        """Median and p99 of the tick wall time, in ms."""
        return median_and_p99_ms(self.tick_wall_s)

    def tick_cpu_ms(self) -> dict[str, float] | None:
        """Median and p99 of the tick's thread CPU time, in ms (None when it was not measured)."""
        return median_and_p99_ms(self.tick_cpu_s) if self.tick_cpu_s else None


def median_and_p99_ms(durations_s: Sequence[float]) -> dict[str, float]:
    """``{"median": ..., "p99": ...}`` of durations in seconds, in ms."""
    return {
        "median": float(np.median(durations_s) * 1e3),
        "p99": float(np.percentile(durations_s, 99) * 1e3),
    }


def run_mission(
    *,
    mission: MissionDocument,
    components: MissionComponents,
    config: SemExpConfig,
    instructions: Sequence[str],
    seed: int,
    strategy_switches: Mapping[str, str] | None = None,
    start_pose: Pose2D | None = None,
    max_time_s: float = 900.0,
    observers: Sequence[TickObserver] = (),
    privileged: PrivilegedKnowledge | None = None,
    registry: NodeRegistry | None = None,
    measure_tick_cpu: bool = False,
) -> MissionResult:
    """Run one mission to its end and return the executive's record.

    Args:
        mission: the parsed mission file (``trees.loader.parse_mission``).
        components: robot, perception, relevance, planner and gait.
        config: the resolved configuration (``semexp_bt.app.configuration.resolve_config``).
        instructions: the instructions in search order (at least one).
        seed: seeds the mission's random generator (``services.rng``).
        strategy_switches: named switches the behaviours read (``services.strategy``).
        start_pose: where the mission starts (the master node, the map's origin); None reads the robot.
        max_time_s: a hard cap on robot time, whatever the mission's budget.
        observers: see every tick (recorder, display, viewer).
        privileged: PRIVILEGED goal knowledge (and for ``oracle_nav`` the true map) for the reference
            strategies only.
        registry: the node registry (default: the product's).
        measure_tick_cpu: also time each tick's thread CPU (``MissionResult.tick_cpu_s``). Off by default:
            a thread-CPU clock read is a system call, not the vDSO read of ``perf_counter``, and only the
            soak reads the figure.
    """
    robot = components.robot
    settings = mission.settings
    services = MissionServices(
        robot=robot,
        perception=components.perception,
        relevance=components.relevance,
        config=config,
        planner=components.planner,
        gait=components.gait,
        rng=np.random.default_rng(seed),
        strategy=dict(strategy_switches or {}),
        budget_s=float(settings.budget_s),
    )
    if privileged is not None:
        services.privileged_goal_xy = privileged.goal_point_xy or privileged.goal_xy
        services.privileged_goal_distance = privileged.goal_distance
        services.privileged_standpoint_xy = privileged.standpoint_xy
    board = prepare_board(
        instructions=list(instructions),
        start_pose=start_pose if start_pose is not None else robot.base_pose(),
        memory=TopologicalMemory(config.memory),
        activity_stream=any(observer.wants_activity_stream for observer in observers),
    )
    if privileged is not None and privileged.occupancy is not None:
        occupied, lower_left_xy, resolution_m = privileged.occupancy
        board.local_map.set_known(occupied, lower_left_xy=lower_left_xy, resolution_m=resolution_m)
    tree = build_tree(mission=mission, services=services, registry=registry)
    run = MissionRun(tree=tree, board=board, services=services)
    for observer in observers:
        observer.start(run)
    tree.setup()

    stop_after_s = min(max_time_s, float(settings.budget_s) + BUDGET_GRACE_S)
    positions = [robot.base_pose().position()]
    tick_wall: list[float] = []
    tick_cpu: list[float] = []
    status = py_trees.common.Status.RUNNING
    while True:
        t0 = time.perf_counter()
        cpu0 = time.thread_time() if measure_tick_cpu else 0.0
        tree.tick()
        tick_wall.append(time.perf_counter() - t0)
        if measure_tick_cpu:
            tick_cpu.append(time.thread_time() - cpu0)
        run.tick += 1
        for observer in observers:
            observer.after_tick(run)
        status = tree.root.status
        if status != py_trees.common.Status.RUNNING:
            break
        if is_due(now_s=robot.now_s(), due_s=stop_after_s):
            board.mission_outcome = "budget_exceeded"
            break
        robot.advance(TICK_PERIOD_S)
        positions.append(robot.base_pose().position())
    tree.interrupt()
    robot.stop()

    outcome = board.mission_outcome
    if outcome == "running":
        outcome = "success" if status == py_trees.common.Status.SUCCESS else "failed"
    for observer in observers:
        observer.finish(run, outcome)
    return MissionResult(
        outcome=outcome,
        instructions=list(instructions),
        found_objects=list(board.found_objects),
        positions=positions,
        ticks=run.tick,
        tick_wall_s=tick_wall,
        tick_cpu_s=tick_cpu,
        sim_time_s=robot.now_s(),
        services=services,
        memory=board.memory,
    )
