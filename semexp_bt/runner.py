"""The executive runner: one mission tree on the MuJoCo backend, ticking in lockstep with sim time.

``run_mission`` builds the scene and the episode from the seed, the robot backend, the perception
emulator, the relevance scorer, the planner and the mission tree, then ticks the tree once per 20 ms of
simulated time (the gait rate) until the root succeeds or fails. It returns the episode record: outcome,
path length, L*, collisions, the reached object and its category, every decision with its candidates
and utilities, and per-stage timings. The same seed and options give the same record (timings aside).

Strategies (evidence and decision baselines of the paper's Tables I, II and IV) are configurations of
the same tree, selected with ``strategy``; see ``semexp_bt/strategies.py``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import py_trees

from behaviours.services import MissionServices
from semexp_bt.config import load_config
from semexp_bt.executive import build_tree, prepare_board
from semexp_bt.memory import TopologicalMemory
from semexp_bt.metrics import DEFAULT_CLEARANCE_M, DEFAULT_SUCCESS_RADIUS_M
from semexp_bt.recorder import TickRecorder
from semexp_bt.strategies import Strategy, resolve_strategy

if TYPE_CHECKING:
    from robots.mjcf_scene import Fidelity

#: One tree tick per 20 ms of backend time: the gait's 50 Hz.
TICK_PERIOD_S = 0.02
#: ``trajectory_xy`` keeps a base position each time the robot has moved this far (m) since the last kept one.
TRAJECTORY_STEP_M = 0.1


@dataclass
class RunOptions:
    """How to run one mission.

    Attributes:
        mission_path: the mission tree (YAML).
        scene: scene name (``semexp-bt scene list``).
        seed: seeds the scene layout, the start pose, the perception noise and everything else.
        instruction: overrides the mission's/scene's instruction.
        fidelity: ``kinematic`` or ``dynamic``; None takes the mission's setting.
        strategy: a named strategy (``ours`` by default) from ``semexp_bt.strategies``.
        relevance: ``embedding`` (default, offline MiniLM) or ``lexical`` (no torch).
        config_overrides: SemExpConfig overrides applied on top of the mission's.
        display: print the tick-level display to ``display_stream``.
        record_path: write the per-tick record (JSONL) here.
        success_radius_m: r_s for SR.
        clearance_m: the clearance threshold for OASR.
        max_sim_s: hard cap on simulated time, whatever the tree says (a safety net).
        keep_trajectory: add ``trajectory_xy`` (the base path, subsampled every
            :data:`TRAJECTORY_STEP_M`) and ``memory_snapshot`` (``TopologicalMemory.snapshot()`` at the
            end) to the record, for the harness's trajectory plots.
    """

    mission_path: Path
    scene: str
    seed: int
    instruction: str | None = None
    fidelity: str | None = None
    strategy: str = "ours"
    relevance: str = "embedding"
    config_overrides: Mapping[str, Any] | None = None
    display: bool = False
    record_path: Path | None = None
    success_radius_m: float = DEFAULT_SUCCESS_RADIUS_M
    clearance_m: float = DEFAULT_CLEARANCE_M
    max_sim_s: float = 900.0
    display_stream: Any = None
    extra_services: dict[str, Any] = field(default_factory=dict)
    keep_trajectory: bool = False


def _object_boundary_distance(obj: Any, xy: tuple[float, float]) -> float:
    """2D distance from ``xy`` to the footprint of a box or cylinder SceneObject (0 inside)."""
    dx, dy = xy[0] - obj.position_m[0], xy[1] - obj.position_m[1]
    if obj.shape == "cylinder":
        return max(0.0, math.hypot(dx, dy) - obj.size_m[0])
    c, s = math.cos(obj.yaw_rad), math.sin(obj.yaw_rad)
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    ex, ey = max(abs(lx) - obj.size_m[0], 0.0), max(abs(ly) - obj.size_m[1], 0.0)
    return math.hypot(ex, ey)


def run_mission(options: RunOptions) -> dict[str, Any]:
    """Run one mission and return its episode record (JSON-serialisable)."""
    from robots.mujoco_backend import MujocoRobot
    from semexp_bt.planner import DepthArcPlanner
    from sims.catalogue import build_scene
    from sims.episodes import sample_episode
    from sims.geodesic import GeodesicOracle
    from trees.loader import MissionLoadError, analyse_mission
    from trees.registry import default_registry

    wall_start = time.perf_counter()
    registry = default_registry()
    settings, _, errors = analyse_mission(options.mission_path, registry)
    if errors or settings is None:
        raise MissionLoadError(errors)
    strategy: Strategy = resolve_strategy(options.strategy)
    # MujocoRobot rejects anything but the two fidelities, naming the value.
    fidelity = cast("Fidelity", options.fidelity or settings.fidelity or "kinematic")

    scene = build_scene(options.scene, seed=options.seed)
    episode = sample_episode(scene, seed=options.seed)
    instructions = list(settings.instructions) or ([settings.instruction] if settings.instruction else [])
    instruction = options.instruction or (instructions[0] if instructions else None) or scene.instruction
    if not instructions or options.instruction:
        instructions = [instruction]

    # Precedence: defaults < strategy < command line; the mission's own `config:` is applied last by the
    # loader, so a mission file can pin a value that no strategy changes.
    config = load_config(overrides=_merge(dict(strategy.config_overrides), options.config_overrides))
    robot = MujocoRobot(scene=scene, fidelity=fidelity, start_pose=episode.start, seed=options.seed)
    try:
        services = MissionServices(
            robot=robot,
            perception=strategy.make_perception(scene=scene, seed=options.seed),
            relevance=strategy.make_relevance(options.relevance),
            config=config,
            planner=DepthArcPlanner(),
            gait=_gait_for(fidelity, options.extra_services.get("gait")),
            rng=np.random.default_rng(options.seed),
            strategy=strategy.switches,
            budget_s=float(settings.budget_s or 300.0),
        )
        if strategy.switches.get("decision") == "oracle":
            # PRIVILEGED, the oracle strategy only: the true goal, for an upper bound on decision quality.
            goal_oracle = GeodesicOracle(scene)
            services.privileged_goal_xy = (float(scene.goal.position_m[0]), float(scene.goal.position_m[1]))
            services.privileged_goal_distance = _privileged_goal_distance(
                goal_oracle, scene.goal.object_id, success_radius_m=options.success_radius_m
            )
        board = prepare_board(
            instructions=instructions,
            start_pose=episode.start,
            memory=TopologicalMemory(config.memory),
            activity_stream=options.display or options.record_path is not None,
        )
        tree = build_tree(mission_path=options.mission_path, services=services, registry=registry)
        recorder = TickRecorder(
            tree=tree,
            path=options.record_path,
            display=options.display,
            stream=options.display_stream,
            memory_getter=lambda: board.memory,
            subgoal_getter=lambda: board.subgoal,
        )
        tree.setup()

        budget_s = min(options.max_sim_s, float(settings.budget_s or options.max_sim_s) + 30.0)
        positions = [robot.base_pose().position()]
        ticks = 0
        status = py_trees.common.Status.RUNNING
        tick_wall: list[float] = []
        while True:
            t0 = time.perf_counter()
            tree.tick()
            tick_wall.append(time.perf_counter() - t0)
            ticks += 1
            recorder.after_tick(ticks, robot.now_s())
            status = tree.root.status
            if status != py_trees.common.Status.RUNNING:
                break
            if robot.now_s() >= budget_s:
                board.mission_outcome = "budget_exceeded"
                break
            robot.advance(TICK_PERIOD_S)
            positions.append(robot.base_pose().position())
        tree.interrupt()
        robot.stop()
        recorder.close()

        outcome = board.mission_outcome
        if status == py_trees.common.Status.SUCCESS and outcome == "running":
            outcome = "success"
        elif status == py_trees.common.Status.FAILURE and outcome == "running":
            outcome = "failed"
        record = _episode_record(
            options=options,
            scene=scene,
            episode=episode,
            robot=robot,
            services=services,
            positions=positions,
            outcome=outcome,
            found=list(board.found_objects),
            instructions=instructions,
            fidelity=fidelity,
            strategy=strategy,
            ticks=ticks,
            tick_wall=tick_wall,
            wall_s=time.perf_counter() - wall_start,
            oracle_factory=lambda: GeodesicOracle(scene),
        )
        if options.keep_trajectory:
            record["trajectory_xy"] = _subsample_path(positions, step_m=TRAJECTORY_STEP_M)
            record["memory_snapshot"] = board.memory.snapshot()
        return record
    finally:
        robot.close()


#: A memory node lies on the object it describes (a blocked cell); the oracle measures from the nearest
#: free cell within this radius (m), as the robot would stand next to the object.
PRIVILEGED_SNAP_RADIUS_M = 1.0


def _privileged_goal_distance(
    oracle: Any, goal_object_id: int, *, success_radius_m: float
) -> Callable[[Any], float]:
    """``(x, y) -> geodesic distance (m)`` into the goal's success region, from the nearest free cell
    (within :data:`PRIVILEGED_SNAP_RADIUS_M`); ``inf`` when none is free or the goal is unreachable."""

    def distance(xy: Any) -> float:
        point = _snap_to_free(oracle, (float(xy[0]), float(xy[1])), max_m=PRIVILEGED_SNAP_RADIUS_M)
        if point is None:
            return math.inf
        return float(oracle.distance_to_object(point, goal_object_id, success_radius_m=success_radius_m))

    return distance


def _subsample_path(positions: list[np.ndarray], *, step_m: float) -> list[list[float]]:
    """``(x, y)`` points of the path, one each time the base moved ``step_m`` since the last kept one."""
    kept: list[list[float]] = []
    for p in positions:
        xy = [round(float(p[0]), 3), round(float(p[1]), 3)]
        if not kept or math.hypot(xy[0] - kept[-1][0], xy[1] - kept[-1][1]) >= step_m:
            kept.append(xy)
    if positions and kept[-1] != [round(float(positions[-1][0]), 3), round(float(positions[-1][1]), 3)]:
        kept.append([round(float(positions[-1][0]), 3), round(float(positions[-1][1]), 3)])
    return kept


def _gait_for(fidelity: str, override: Any) -> Any:
    """The gait that realises twists: none in kinematic fidelity (the base follows the twist), the shipped
    RL policy in dynamic fidelity (one controller per mission: it keeps its own state)."""
    if override is not None or fidelity != "dynamic":
        return override
    from robots.gait_policy import make_gait_controller

    return make_gait_controller()


def _merge(base: dict[str, Any], extra: Mapping[str, Any] | None) -> dict[str, Any]:
    out = dict(base)
    for key, value in (extra or {}).items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merge(dict(out[key]), value)
        else:
            out[key] = value
    return out


def _snap_to_free(oracle: Any, xy: tuple[float, float], *, max_m: float = 1.5) -> tuple[float, float] | None:
    """The free cell centre nearest ``xy`` within ``max_m`` (memory nodes sit on object surfaces, inside
    the inflated obstacles; the place the robot would stand to reach them is the nearest free cell)."""
    if oracle.is_free(xy):
        return xy
    geometry = oracle.occupancy.geometry
    free = oracle.occupancy.free
    row, col = geometry.cell_of(xy)
    reach = int(math.ceil(max_m / geometry.resolution_m))
    r0, r1 = max(row - reach, 0), min(row + reach + 1, free.shape[0])
    c0, c1 = max(col - reach, 0), min(col + reach + 1, free.shape[1])
    rows, cols = np.nonzero(free[r0:r1, c0:c1])
    if rows.size == 0:
        return None
    centres = geometry.centre_of(rows + r0, cols + c0)
    dist = np.hypot(centres[:, 0] - xy[0], centres[:, 1] - xy[1])
    best = int(np.argmin(dist))
    return (float(centres[best, 0]), float(centres[best, 1])) if dist[best] <= max_m else None


def _with_oracle_nodes(
    decision_log: list[dict[str, Any]], *, oracle: Any, goal_id: int, success_radius_m: float
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
                xy = _snap_to_free(oracle, (cand["position_m"][0], cand["position_m"][1]))
                if xy is None:
                    continue
                d = oracle.field_value(robot_field, xy) + oracle.field_value(goal_field, xy)
                if d < best:
                    best, oracle_node = d, cand["node_id"]
        out.append({**step, "oracle_node_id": oracle_node})
    return out


def _episode_record(
    *,
    options: RunOptions,
    scene: Any,
    episode: Any,
    robot: Any,
    services: MissionServices,
    positions: list[np.ndarray],
    outcome: str,
    found: list[dict[str, Any]],
    instructions: list[str],
    fidelity: str,
    strategy: Strategy,
    ticks: int,
    tick_wall: list[float],
    wall_s: float,
    oracle_factory: Callable[[], Any],
) -> dict[str, Any]:
    goal = scene.goal
    final = robot.base_pose()
    final_xy = (final.x_m, final.y_m)
    path = np.asarray(positions)
    path_length = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) if len(path) > 1 else 0.0
    safety = robot.safety()
    collisions = [e for e in safety.events if e.kind == "collision"]
    breaches = [e for e in safety.events if e.kind == "clearance" and e.distance_m < options.clearance_m]

    # The reached object: the scene object nearest the confirmed target (or, with no confirmation, the
    # robot's final position), if it lies within the success radius of the robot.
    anchor = tuple(found[-1]["position_m"][:2]) if found else final_xy
    candidates = [o for o in scene.objects if o.role != "wall"]
    reached = min(candidates, key=lambda o: _object_boundary_distance(o, anchor), default=None)
    if reached is not None and _object_boundary_distance(reached, final_xy) > options.success_radius_m:
        reached = None

    decisions = _with_oracle_nodes(
        services.decision_log,
        oracle=oracle_factory(),
        goal_id=goal.object_id,
        success_radius_m=options.success_radius_m,
    )

    distance_to_goal = _object_boundary_distance(goal, final_xy)
    declared = outcome == "success"
    # For missions that move on after confirming (search, then return), success is judged where the
    # robot stood when it confirmed the goal object; for the paper's mission that is the final position.
    judged_xy = final_xy
    for entry in found:
        if (
            entry.get("robot_xy")
            and _object_boundary_distance(goal, tuple(entry["robot_xy"])) <= options.success_radius_m
        ):
            judged_xy = tuple(entry["robot_xy"])
    judged_distance = _object_boundary_distance(goal, judged_xy)
    return {
        "scene": scene.name,
        "seed": options.seed,
        "mission": str(options.mission_path),
        "strategy": strategy.name,
        "fidelity": fidelity,
        "instruction": instructions[0],
        "instructions": instructions,
        "goal": {
            "object_id": goal.object_id,
            "name": goal.name,
            "label": goal.label,
            "category": goal.category,
            "position_m": list(goal.position_m),
        },
        "start_pose": {"x_m": episode.start.x_m, "y_m": episode.start.y_m, "yaw_rad": episode.start.yaw_rad},
        "outcome": outcome,
        "success_declared": declared,
        "success": bool(declared and judged_distance <= options.success_radius_m),
        "success_radius_m": options.success_radius_m,
        "final_pose": {"x_m": final.x_m, "y_m": final.y_m, "yaw_rad": final.yaw_rad},
        "distance_to_goal_m": distance_to_goal,
        "path_length_m": path_length,
        "geodesic_length_m": float(episode.geodesic_length_m),
        "collision": bool(collisions or breaches),
        "collisions": len(collisions),
        "clearance_breaches": len(breaches),
        "min_clearance_m": float(safety.min_clearance_m) if math.isfinite(safety.min_clearance_m) else None,
        "reached_object": None
        if reached is None
        else {"name": reached.name, "label": reached.label, "category": reached.category},
        "reached_category": None if reached is None else reached.category,
        "goal_category": goal.category,
        "found_objects": found,
        "decisions": decisions,
        "events": services.events,
        "timings": services.timings.summary(),
        "tick_wall_ms": {
            "median": float(np.median(tick_wall) * 1e3),
            "p99": float(np.percentile(tick_wall, 99) * 1e3),
        },
        "ticks": ticks,
        "sim_time_s": robot.now_s(),
        "wall_time_s": wall_s,
    }
