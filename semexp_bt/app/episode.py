"""A simulated episode: a scene, a start pose, the MuJoCo robot and the perception emulator around one
mission, scored against the ground truth the executive never sees.

:func:`run_episode` builds the scene and the episode from the seed, the geodesic oracle (once), the
components by name (``semexp_bt.app.components``), resolves the configuration
(``semexp_bt.app.configuration``), runs the mission with :func:`semexp_bt.app.runner.run_mission` and
returns the episode record: outcome, path length, L*, collisions, the reached object and its category,
every decision with its candidates, utilities and GNSA's oracle node, and per-stage timings. The same seed
and options give the same record (timings aside).

Strategies (evidence and decision baselines of the paper's Tables I, II and IV) are configurations of
the same tree, selected with ``strategy``; see ``semexp_bt/app/strategies.yaml``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO, cast

import numpy as np

from robots.interface import Robot
from semexp_bt.app.components import (
    DEFAULT_PLANNER,
    DEFAULT_RELEVANCE,
    ComponentRequest,
    build_gait,
    build_perception,
    build_planner,
    build_relevance,
    build_robot,
    with_faults,
)
from semexp_bt.app.configuration import resolve_config
from semexp_bt.app.recorder import TickRecorder
from semexp_bt.app.runner import (
    MissionComponents,
    MissionResult,
    PrivilegedKnowledge,
    TickObserver,
    run_mission,
)
from semexp_bt.app.strategies import Strategy, resolve_strategy
from semexp_bt.core.metrics import DEFAULT_CLEARANCE_M, DEFAULT_SUCCESS_RADIUS_M
from semexp_bt.core.scene import SceneSpec
from sims.catalogue import build_scene
from sims.episode_scoring import score_episode, snap_to_free
from sims.episodes import Episode, sample_episode
from sims.faults import FaultSpec, parse_faults
from sims.geodesic import GeodesicOracle
from trees.loader import parse_mission

if TYPE_CHECKING:
    from semexp_bt.app.viewer.observer import ViewOptions
    from semexp_bt.perception.model_config import ModelsProfile

#: ``trajectory_xy`` keeps a base position each time the robot has moved this far (m) since the last kept one.
TRAJECTORY_STEP_M = 0.1
#: A memory node lies on the object it describes (a blocked cell); the oracle measures from the nearest
#: free cell within this radius (m), as the robot would stand next to the object.
PRIVILEGED_SNAP_RADIUS_M = 1.0
#: How far (m) from a memory node GNSA's oracle looks for the free cell the robot would stand on.
ORACLE_NODE_SNAP_RADIUS_M = 1.5


@dataclass
class EpisodeOptions:
    """How to run one simulated episode.

    Attributes:
        mission_path: the mission tree (YAML).
        scene: scene name (``semexp-bt scene list``).
        seed: seeds the scene layout, the start pose, the perception noise and everything else.
        instruction: overrides the mission's/scene's instruction.
        fidelity: ``kinematic`` or ``dynamic``; None takes the mission's setting.
        strategy: a named strategy (``ours`` by default) from ``semexp_bt/app/strategies.yaml``.
        relevance: a name of ``semexp_bt.app.components.RELEVANCE_SCORERS``: ``hybrid`` (the default:
            offline MiniLM or the object lexicon, the larger), ``embedding``, ``lexical`` (no torch) or
            ``llm`` (needs ``models``).
        perception: ``emulator`` (default) or ``models`` (the real models of ``models``; the simulation
            then runs at wall-clock pace unless the profile says otherwise).
        models: the models profile for ``perception="models"`` and ``relevance="llm"``.
        planner: the path-following controller's name (``semexp_bt.app.components.PLANNERS``).
        config_overrides: SemExpConfig overrides from the command line (the last layer).
        display: print the tick-level display to ``display_stream``.
        display_stream: where the display prints (stdout by default).
        record_path: write the per-tick record (JSONL) here.
        success_radius_m: r_s for SR.
        clearance_m: the clearance threshold for OASR.
        max_sim_s: hard cap on simulated time, whatever the tree says (a safety net).
        measure_tick_cpu: record each tick's thread CPU time too (``tick_cpu_ms``; the soak's floor).
        keep_trajectory: add ``trajectory_xy`` (the base path, subsampled every
            :data:`TRAJECTORY_STEP_M`) and ``memory_snapshot`` (``TopologicalMemory.snapshot()`` at the
            end) to the record, for the harness's trajectory plots.
        faults: faults to inject (``sims.faults``); None takes the mission file's ``faults:`` section.
            The record then names them under ``faults`` and is scored on the true robot state.
        observers: more tick observers (a benchmark's probe), after the recorder.
        view: serve and/or save the browser view (``semexp_bt.app.viewer``), or None.
    """

    mission_path: Path
    scene: str
    seed: int
    instruction: str | None = None
    fidelity: str | None = None
    strategy: str = "ours"
    relevance: str = DEFAULT_RELEVANCE
    perception: str = "emulator"
    models: ModelsProfile | None = None
    planner: str = DEFAULT_PLANNER
    config_overrides: Mapping[str, Any] | None = None
    display: bool = False
    display_stream: TextIO | None = None
    record_path: Path | None = None
    success_radius_m: float = DEFAULT_SUCCESS_RADIUS_M
    clearance_m: float = DEFAULT_CLEARANCE_M
    max_sim_s: float = 900.0
    measure_tick_cpu: bool = False
    keep_trajectory: bool = False
    faults: Sequence[FaultSpec] | None = None
    observers: Sequence[TickObserver] = ()
    view: ViewOptions | None = None


def run_episode(options: EpisodeOptions) -> dict[str, Any]:
    """Run one simulated episode and return its record (JSON-serialisable)."""
    wall_start = time.perf_counter()
    recorder = TickRecorder(path=options.record_path, display=options.display, stream=options.display_stream)
    view_observers: list[TickObserver] = []
    if options.view is not None:
        from semexp_bt.app.viewer.observer import ViewObserver

        # First: the view imports Rerun on a thread of its own, which then overlaps the scene's set-up.
        view_observers.append(ViewObserver(options.view, recorder=recorder))
    mission = parse_mission(options.mission_path)
    settings = mission.settings
    faults = (
        tuple(options.faults)
        if options.faults is not None
        else parse_faults(settings.faults, where=settings.faults_where or str(options.mission_path))
    )
    strategy = resolve_strategy(options.strategy)
    fidelity = options.fidelity or settings.fidelity or "kinematic"

    scene = build_scene(options.scene, seed=options.seed)
    oracle = GeodesicOracle(scene)
    episode = sample_episode(scene, seed=options.seed, oracle=oracle)
    instructions = list(settings.instructions) or ([settings.instruction] if settings.instruction else [])
    if options.instruction or not instructions:
        instructions = [options.instruction or scene.instruction]

    config = resolve_config(
        strategy_overrides=strategy.config_overrides,
        mission_overrides=settings.config_overrides,
        command_line_overrides=options.config_overrides,
        strategy_source=f"strategy '{strategy.name}'",
        mission_source=str(options.mission_path),
    )
    stack = None
    if options.models is not None:
        from semexp_bt.perception.adapters.stack import ModelStack

        stack = ModelStack(options.models)
    request = ComponentRequest(
        seed=options.seed,
        strategy=strategy,
        fidelity=cast(Any, fidelity),
        scene=scene,
        start_pose=episode.start,
        models=stack,
    )
    observers: list[TickObserver] = [recorder, *options.observers, *view_observers]
    factor = options.models.simulation.real_time_factor if options.models is not None else 0.0
    if options.perception == "models" and factor > 0.0:
        from semexp_bt.app.pacing import WallClockPacer

        observers.append(WallClockPacer(real_time_factor=factor))
    robot = build_robot("mujoco", request)
    try:
        # The mission runs on the decorated robot; the episode is scored on the robot itself.
        mission_robot, perception = with_faults(
            robot, build_perception(options.perception, request), faults, seed=options.seed
        )
        components = MissionComponents(
            robot=mission_robot,
            perception=perception,
            relevance=build_relevance(options.relevance, request),
            planner=build_planner(options.planner),
            gait=build_gait(cast(Any, fidelity)),
        )
        privileged = None
        if strategy.switches.get("decision") == "oracle":
            privileged = privileged_goal(scene, oracle, success_radius_m=options.success_radius_m)
        elif strategy.switches.get("decision") == "oracle_nav":
            privileged = privileged_navigation(
                scene, oracle, start=episode.start, success_radius_m=options.success_radius_m
            )
        mission_start = time.perf_counter()
        result = run_mission(
            mission=mission,
            components=components,
            config=config,
            instructions=instructions,
            seed=options.seed,
            strategy_switches=strategy.switches,
            # Where the robot reports itself (None reads it), not the sampled start: the mission knows
            # what a robot tells it, so it starts from the same bits in process and over ROS 2.
            start_pose=None,
            max_time_s=options.max_sim_s,
            observers=observers,
            privileged=privileged,
            measure_tick_cpu=options.measure_tick_cpu,
        )
        mission_wall_s = time.perf_counter() - mission_start
        if stack is not None:  # relevance errors no perception result carried (an emulator run)
            for message in stack.drain_errors():
                result.services.log_event("perception_error", message=message)
        record = episode_record(
            options=options,
            scene=scene,
            episode=episode,
            oracle=oracle,
            result=result,
            fidelity=fidelity,
            strategy=strategy,
            wall_s=time.perf_counter() - wall_start,
            mission_wall_s=mission_wall_s,
            robot=robot,
        )
        if faults:
            record["faults"] = [fault.to_dict() for fault in faults]
        if stack is not None:
            record["models"] = stack.summary()
        if options.keep_trajectory:
            record["trajectory_xy"] = subsample_path(result.positions, step_m=TRAJECTORY_STEP_M)
            record["memory_snapshot"] = result.memory.snapshot()
        return record
    finally:
        robot.close()
        if stack is not None:
            stack.close()


def privileged_goal(
    scene: SceneSpec, oracle: GeodesicOracle, *, success_radius_m: float
) -> PrivilegedKnowledge:
    """PRIVILEGED, for the ``oracle`` reference strategy: the goal's position and the true geodesic distance
    ``(x, y) -> m`` into its success region, measured from the nearest free cell (within
    :data:`PRIVILEGED_SNAP_RADIUS_M`; ``inf`` when none is free or the goal is unreachable)."""
    goal_id = scene.goal.object_id

    def distance(xy: tuple[float, float]) -> float:
        point = snap_to_free(oracle, (float(xy[0]), float(xy[1])), max_m=PRIVILEGED_SNAP_RADIUS_M)
        if point is None:
            return math.inf
        return float(oracle.distance_to_object(point, goal_id, success_radius_m=success_radius_m))

    return PrivilegedKnowledge(
        goal_xy=(float(scene.goal.position_m[0]), float(scene.goal.position_m[1])), goal_distance=distance
    )


#: The true map handed to ``oracle_nav`` gets this many rings of occupied cells around the scene bounds
#: (the walls beyond them, as the oracle's own grid assumes).
PRIVILEGED_MAP_BORDER_CELLS = 2


def privileged_navigation(
    scene: SceneSpec, oracle: GeodesicOracle, *, start: Any, success_radius_m: float
) -> PrivilegedKnowledge:
    """PRIVILEGED, for the ``oracle_nav`` reference strategy (the execution layer's ceiling): the goal, a
    place to stand within the success radius (the end of the true shortest path from the start), the
    goal object's point nearest it, and the true occupancy map of the scene (``sims.geodesic``'s grid, not
    inflated: the navigation stack inflates it by the Go1's own footprint)."""
    knowledge = privileged_goal(scene, oracle, success_radius_m=success_radius_m)
    goal_id = scene.goal.object_id
    path = oracle.path_to_object((start.x_m, start.y_m), goal_id, success_radius_m=success_radius_m)
    standpoint = (float(path[-1][0]), float(path[-1][1])) if len(path) else knowledge.goal_xy
    goal_point = scene.goal.nearest_point_m(standpoint)
    geometry = oracle.occupancy.geometry
    border = PRIVILEGED_MAP_BORDER_CELLS
    occupied = np.pad(oracle.occupancy.occupied, border, constant_values=True)
    lower_left = (
        geometry.x_min_m - border * geometry.resolution_m,
        geometry.y_min_m - border * geometry.resolution_m,
    )
    return dataclasses.replace(
        knowledge,
        goal_point_xy=goal_point,
        standpoint_xy=standpoint,
        occupancy=(occupied, lower_left, geometry.resolution_m),
    )


def subsample_path(positions: list[np.ndarray], *, step_m: float) -> list[list[float]]:
    """``(x, y)`` points of the path, one each time the base moved ``step_m`` since the last kept one."""
    kept: list[list[float]] = []
    for p in positions:
        xy = [round(float(p[0]), 3), round(float(p[1]), 3)]
        if not kept or math.hypot(xy[0] - kept[-1][0], xy[1] - kept[-1][1]) >= step_m:
            kept.append(xy)
    if positions and kept[-1] != [round(float(positions[-1][0]), 3), round(float(positions[-1][1]), 3)]:
        kept.append([round(float(positions[-1][0]), 3), round(float(positions[-1][1]), 3)])
    return kept


def with_oracle_nodes(
    decision_log: list[dict[str, Any]], *, oracle: GeodesicOracle, goal_id: int, success_radius_m: float
) -> list[dict[str, Any]]:
    """Each decision step with GNSA's oracle node: the candidate minimising the true geodesic
    robot -> node + node -> goal region (one distance field from the robot per step, one for the goal)."""
    goal_field = oracle.object_distance_field(goal_id, success_radius_m=success_radius_m)
    out = []
    for step in decision_log:
        oracle_node, best = None, math.inf
        if step["candidates"]:
            robot_field = oracle.distance_field(tuple(step["robot_xy"]))
            for cand in step["candidates"]:
                xy = snap_to_free(
                    oracle, (cand["position_m"][0], cand["position_m"][1]), max_m=ORACLE_NODE_SNAP_RADIUS_M
                )
                if xy is None:
                    continue
                d = oracle.field_value(robot_field, xy) + oracle.field_value(goal_field, xy)
                if d < best:
                    best, oracle_node = d, cand["node_id"]
        out.append({**step, "oracle_node_id": oracle_node})
    return out


def episode_record(
    *,
    options: EpisodeOptions,
    scene: SceneSpec,
    episode: Episode,
    oracle: GeodesicOracle,
    result: MissionResult,
    fidelity: str,
    strategy: Strategy,
    wall_s: float,
    mission_wall_s: float | None = None,
    robot: Robot | None = None,
) -> dict[str, Any]:
    """The episode's record: the executive's result scored against the scene's ground truth.

    ``wall_s`` is the whole episode's wall time (set-up and scoring included); ``mission_wall_s`` the
    mission loop's alone (``run_mission``, as the ROS 2 executive's record has it), when measured.

    ``robot`` is the simulated robot itself (its true pose and contacts); the one the mission ran on
    when None (the same robot unless faults were injected between them).
    """
    goal = scene.goal
    robot = robot if robot is not None else result.services.robot
    found = result.found_objects
    score = score_episode(
        scene=scene,
        episode=episode,
        outcome=result.outcome,
        found_objects=found,
        positions=result.positions,
        final_pose=robot.base_pose(),
        safety=robot.safety(),
        success_radius_m=options.success_radius_m,
        clearance_m=options.clearance_m,
        instructions=result.instructions,
    )
    decisions = with_oracle_nodes(
        result.services.decision_log,
        oracle=oracle,
        goal_id=goal.object_id,
        success_radius_m=options.success_radius_m,
    )
    instructions = result.instructions
    return {
        "scene": scene.name,
        "seed": options.seed,
        "mission": str(options.mission_path),
        "strategy": strategy.name,
        "fidelity": fidelity,
        "instruction": instructions[0],
        "instructions": instructions,
        **score,
        "found_objects": found,
        "decisions": decisions,
        "events": result.services.events,
        "timings": result.services.timings.summary(),
        "tick_wall_ms": result.tick_wall_ms(),
        "tick_cpu_ms": result.tick_cpu_ms(),
        "ticks": result.ticks,
        "sim_time_s": result.sim_time_s,
        "wall_time_s": wall_s,
        **({} if mission_wall_s is None else {"mission_wall_s": mission_wall_s}),
    }
