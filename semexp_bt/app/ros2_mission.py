"""A mission on ROS 2: the same tree, on a real Go1 or on the simulation bridge, and the executive's record.

:func:`run_ros2_mission` builds the ``ros2`` robot backend (``robots.ros2_backend.Ros2Robot``) from a robot
profile, waits for the robot's streams, builds the perception source, runs the mission with
:func:`semexp_bt.app.runner.run_mission` and returns what the executive knows: outcome, confirmed targets,
the odometry path, decisions, events and timings. There is no ground truth on this side: against the
bridge, the bridge scores the episode (``semexp-bt sim-bridge --json``) once this side reports the
outcome on ``/sim/outcome``.

Perception:

- ``emulator`` (with the bridge): the perception emulator, built from the scene catalogue the bridge
  announces on ``/sim/scene`` (labels, categories, roles, sizes; no positions), reads each frame's
  segmentation from ``/sim/camera/segmentation``; seeded with ``seed`` as in-process.
- on a real Go1 the real model adapters (an OpenAI-compatible VLM endpoint and a transformers detector,
  registered in ``semexp_bt.app.components.PERCEPTION_SOURCES`` by their own issue) take the camera pair;
  the emulator cannot run there (no segmentation, no catalogue).

A halt of the robot (a sensor topic silent past its deadline, a malformed message, the bridge gone) ends
the mission at once with outcome ``halted`` and ``halted_by`` naming the topic; the robot has already been
sent a zero twist.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

import numpy as np

from semexp_bt.app.components import (
    DEFAULT_PLANNER,
    DEFAULT_RELEVANCE,
    ComponentRequest,
    build_perception,
    build_planner,
    build_relevance,
    build_robot,
)
from semexp_bt.app.configuration import resolve_config
from semexp_bt.app.recorder import TickRecorder
from semexp_bt.app.runner import MissionComponents, MissionResult, MissionRun, run_mission
from semexp_bt.app.strategies import resolve_strategy
from semexp_bt.core.types import InvalidInputError
from trees.loader import parse_mission

if TYPE_CHECKING:
    from semexp_bt.app.viewer.observer import ViewOptions
    from semexp_bt.core.scene import SceneSpec

#: How long (s) the executive waits for the bridge to acknowledge the outcome; after a halt, shorter.
OUTCOME_ACK_S = 2.0
HALTED_OUTCOME_ACK_S = 0.2
#: The perception source that needs the bridge's ``/sim/...`` topics.
SIMULATED_PERCEPTION = "emulator"


@dataclass
class Ros2MissionOptions:
    """How to run one mission over ROS 2.

    Attributes:
        mission_path: the mission tree (YAML).
        profile_path: the robot profile; the shipped Go1 profile when None.
        perception: the perception source (``emulator`` needs the simulation bridge).
        instruction: overrides the mission's (and, with the bridge, the scene's) instruction.
        seed: seeds the mission's random generator and the emulator's noise (give the bridge's seed for
            the in-process run's draws).
        strategy: a named strategy (``semexp_bt/app/strategies.yaml``); reference strategies that are told
            where the goal is cannot run here.
        relevance: the relevance scorer's name.
        planner: the path-following controller's name.
        config_overrides: SemExpConfig overrides from the command line (the last layer).
        display: print the tick-level display to ``display_stream``.
        display_stream: where the display prints.
        record_path: write the per-tick record (JSONL) here.
        max_time_s: hard cap on mission time (ROS time), whatever the tree says.
        view: serve and/or save the browser view (docs/viewer.md), as ``semexp-bt run --view`` does
            in-process; with the bridge, the title and the manifest name the scene it announced.
    """

    mission_path: Path
    profile_path: Path | None = None
    perception: str = SIMULATED_PERCEPTION
    instruction: str | None = None
    seed: int = 0
    strategy: str = "ours"
    relevance: str = DEFAULT_RELEVANCE
    planner: str = DEFAULT_PLANNER
    config_overrides: Mapping[str, Any] | None = None
    display: bool = False
    display_stream: TextIO | None = None
    record_path: Path | None = None
    max_time_s: float = 900.0
    view: ViewOptions | None = None


def _view_for(options: Ros2MissionOptions, scene: SceneSpec | None) -> ViewOptions:
    """The view's options with what only the robot knows: the backend, and the bridge's scene."""
    assert options.view is not None
    view = options.view
    where = "ROS 2" if scene is None else f"{scene.name} seed {options.seed} over ROS 2"
    return replace(
        view,
        title=view.title or f"{where}: {options.mission_path.name}",
        mission={**view.mission, "backend": "ros2", "scene": None if scene is None else scene.name},
    )


@dataclass
class _MissionWatch:
    """Keeps the running mission and the base path, so that a halted mission can still be recorded."""

    wants_activity_stream: bool = False
    run: MissionRun | None = None
    positions: list[np.ndarray] = field(default_factory=list)

    def start(self, run: MissionRun) -> None:
        self.run = run
        self.positions.append(run.robot.base_pose().position())

    def after_tick(self, run: MissionRun) -> None:
        self.positions.append(run.robot.base_pose().position())

    def finish(self, run: MissionRun, outcome: str) -> None:
        del run, outcome


def run_ros2_mission(options: Ros2MissionOptions) -> dict[str, Any]:
    """Run one mission over ROS 2 and return the executive's record (JSON-serialisable).

    Raises:
        Ros2Error: rclpy is missing, or the robot's streams never appeared.
        ValueError: a malformed mission, configuration, profile, or an unknown component.
    """
    from robots.ros2_backend import RobotHalted, Ros2Robot

    wall_start = time.perf_counter()
    mission = parse_mission(options.mission_path)
    settings = mission.settings
    strategy = resolve_strategy(options.strategy)
    if strategy.switches.get("decision") == "oracle":
        raise InvalidInputError(
            f"strategy {strategy.name!r} is told where the goal is: it runs in-process only"
        )
    config = resolve_config(
        strategy_overrides=strategy.config_overrides,
        mission_overrides=settings.config_overrides,
        command_line_overrides=options.config_overrides,
        strategy_source=f"strategy '{strategy.name}'",
        mission_source=str(options.mission_path),
    )
    simulation = options.perception == SIMULATED_PERCEPTION
    if options.view is not None and options.view.world:
        from semexp_bt.app.viewer.observer import require_world_view

        require_world_view()  # before waiting for the robot: a missing extra is one line, at once
    request = ComponentRequest(
        seed=options.seed,
        strategy=strategy,
        robot_options={"profile": options.profile_path, "simulation": simulation},
    )
    robot = build_robot("ros2", request)
    assert isinstance(robot, Ros2Robot)
    try:
        robot.wait_until_ready()
        info = robot.simulation_info
        scene = None if info is None else info.scene
        instructions = list(settings.instructions) or ([settings.instruction] if settings.instruction else [])
        if options.instruction or not instructions:
            if not options.instruction and scene is None:
                raise InvalidInputError(f"{options.mission_path} names no instruction: give --instruction")
            instructions = [options.instruction or (scene.instruction if scene is not None else "")]
        start_pose = robot.base_pose()
        perception_request = ComponentRequest(
            seed=options.seed, strategy=strategy, scene=scene, start_pose=start_pose if scene else None
        )
        components = MissionComponents(
            robot=robot,
            perception=build_perception(options.perception, perception_request),
            relevance=build_relevance(options.relevance),
            planner=build_planner(options.planner),
            gait=None,  # the Go1 (or the bridge) walks by itself
        )
        watch = _MissionWatch()
        recorder = TickRecorder(
            path=options.record_path, display=options.display, stream=options.display_stream
        )
        observers: list[Any] = [recorder, watch]
        if options.view is not None:
            from semexp_bt.app.viewer.observer import ViewObserver

            observers.append(ViewObserver(_view_for(options, scene), recorder=recorder))
        halted_by: dict[str, str | None] | None = None
        result: MissionResult | None = None
        mission_start = time.perf_counter()
        try:
            result = run_mission(
                mission=mission,
                components=components,
                config=config,
                instructions=instructions,
                seed=options.seed,
                strategy_switches=strategy.switches,
                start_pose=start_pose,
                max_time_s=options.max_time_s,
                observers=observers,
            )
        except RobotHalted as halt:
            halted_by = {"topic": halt.topic, "reason": halt.reason}
        except KeyboardInterrupt:
            halted_by = {"topic": None, "reason": "interrupted"}
        finally:
            robot.stop()
        mission_wall_s = time.perf_counter() - mission_start
        if result is None:
            outcome = "halted" if halted_by and halted_by["topic"] else "interrupted"
            record = _halted_record(watch, recorder, outcome, instructions)
        else:
            record = _result_record(result)
        record.update(
            {
                "backend": "ros2",
                "mission": str(options.mission_path),
                "strategy": strategy.name,
                "profile": robot.profile.source,
                "perception": options.perception,
                "halted_by": halted_by,
                "simulation": None
                if info is None
                else {"scene": info.scene.name, "seed": info.seed, "mode": info.mode},
                "ros_time_at_start_s": robot.epoch_s,
                "steps_resent": robot.steps_resent,
                "steps_taken_ahead": robot.steps_taken_ahead,
                "mission_wall_s": mission_wall_s,
                "wall_time_s": time.perf_counter() - wall_start,
            }
        )
        if simulation:
            # A halted robot may have lost its bridge: then nobody acknowledges, so do not wait long.
            record["outcome_reported"] = robot.report_outcome(
                record["outcome"],
                record["found_objects"],
                timeout_s=OUTCOME_ACK_S if halted_by is None else HALTED_OUTCOME_ACK_S,
            )
        return record
    finally:
        robot.close()


def _path_length_m(positions: list[np.ndarray]) -> float:
    path = np.asarray(positions, dtype=float)
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) if len(path) > 1 else 0.0


def _pose_dict(xy_yaw: tuple[float, float, float]) -> dict[str, float]:
    return {"x_m": xy_yaw[0], "y_m": xy_yaw[1], "yaw_rad": xy_yaw[2]}


def _result_record(result: MissionResult) -> dict[str, Any]:
    services = result.services
    final = services.robot.base_pose()
    start = result.positions[0]
    return {
        "outcome": result.outcome,
        "instructions": result.instructions,
        "found_objects": result.found_objects,
        "start_xy": [float(start[0]), float(start[1])],
        "final_pose": _pose_dict((final.x_m, final.y_m, final.yaw_rad)),
        "path_length_m": _path_length_m(result.positions),
        "decisions": services.decision_log,
        "events": services.events,
        "timings": services.timings.summary(),
        "tick_wall_ms": result.tick_wall_ms(),
        "tick_cpu_ms": result.tick_cpu_ms(),
        "ticks": result.ticks,
        "sim_time_s": result.sim_time_s,
    }


def _halted_record(
    watch: _MissionWatch, recorder: TickRecorder, outcome: str, instructions: list[str]
) -> dict[str, Any]:
    """What the executive knows of a mission the robot halted mid-tick."""
    run = watch.run
    if run is None:
        return {"outcome": outcome, "instructions": instructions, "found_objects": [], "ticks": 0}
    run.tree.interrupt()
    recorder.finish(run, outcome)
    services = run.services
    start, last = watch.positions[0], watch.positions[-1]
    return {
        "outcome": outcome,
        "instructions": instructions,
        "found_objects": list(run.board.found_objects),
        "start_xy": [float(start[0]), float(start[1])],
        "final_xy": [float(last[0]), float(last[1])],
        "path_length_m": _path_length_m(watch.positions),
        "decisions": services.decision_log,
        "events": services.events,
        "timings": services.timings.summary(),
        "ticks": run.tick,
        "sim_time_s": run.now_s(),
    }


__all__ = ["SIMULATED_PERCEPTION", "Ros2MissionOptions", "run_ros2_mission"]
