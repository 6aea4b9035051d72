"""``semexp-bt run MISSION.yaml [--backend mujoco] --scene SCENE --seed N``: run one mission.

On the MuJoCo backend (the default) the mission runs in a simulated episode: ``--scene`` and ``--seed``
choose the world and the start, and the record is scored against the scene's ground truth.
``--perception models --models PROFILE`` (or ``--vlm-url URL --vlm-model NAME``) sends the rendered
frames to real models instead of the perception emulator (docs/perception.md).

On the ROS 2 backend (``--backend ros2 [--robot-profile FILE]``) the same tree runs on whatever speaks the
profile's topics: a real Go1, or ``semexp-bt sim-bridge`` (then ``--perception emulator``, the default,
reads the bridge's scene catalogue and segmentation). The record is the executive's own (no ground truth;
the bridge scores the episode); the exit status is 0 for success, 1 for another outcome, 3 when the robot
halted (a silent or malformed topic, the bridge gone).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from semexp_bt.app.components import (
    DEFAULT_PLANNER,
    DEFAULT_RELEVANCE,
    PERCEPTION_SOURCES,
    PLANNERS,
    RELEVANCE_SCORERS,
    ROBOT_BACKENDS,
)
from semexp_bt.app.models_profile import add_models_arguments, models_profile_from_args
from semexp_bt.cli.arguments import output_file, print_error, scene_name, seed, strategy_name
from semexp_bt.core.durable import write_json
from trees.loader import MissionLoadError

if TYPE_CHECKING:
    # Types only: the view's modules load when --view asks for them (start-up stays light).
    from semexp_bt.app.viewer.observer import ViewOptions

#: Backends whose missions run in a simulated scene (they need ``--scene``).
SIMULATED_BACKENDS = ("mujoco",)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("mission", type=Path, help="mission tree (YAML), e.g. trees/object_search.yaml")
    parser.add_argument(
        "--backend", choices=sorted(ROBOT_BACKENDS), default="mujoco", help="robot backend (default: mujoco)"
    )
    parser.add_argument(
        "--scene", type=scene_name, default=None, help="scene name (see `semexp-bt scene list`); mujoco only"
    )
    parser.add_argument(
        "--seed", type=seed, default=0, help="seed for layout, start pose and perception noise (>= 0)"
    )
    parser.add_argument(
        "--instruction", default=None, help="override the instruction, e.g. 'find the bucket shelf'"
    )
    parser.add_argument(
        "--fidelity",
        choices=("kinematic", "dynamic"),
        default=None,
        help="robot fidelity (default: the mission's setting, else kinematic)",
    )
    parser.add_argument(
        "--strategy", type=strategy_name, default="ours", help="strategy (see semexp_bt/app/strategies.yaml)"
    )
    parser.add_argument(
        "--relevance",
        choices=sorted(RELEVANCE_SCORERS),
        default=DEFAULT_RELEVANCE,
        help=(
            "semantic relevance scorer (hybrid, the default: MiniLM or the object lexicon, the larger; "
            "embedding: offline MiniLM; lexical: no torch; llm: the profile's LLM)"
        ),
    )
    parser.add_argument(
        "--perception",
        choices=sorted(PERCEPTION_SOURCES),
        default="emulator",
        help="perception source (emulator: simulated models; models: the profile's real models)",
    )
    add_models_arguments(parser)
    parser.add_argument(
        "--robot-profile", type=Path, default=None, help="ros2: robot profile (default: robots/go1/ros2.yaml)"
    )
    parser.add_argument(
        "--planner", choices=sorted(PLANNERS), default=DEFAULT_PLANNER, help="path-following controller"
    )
    parser.add_argument(
        "--config", type=Path, default=None, help="YAML of config overrides (the last layer; docs/config.md)"
    )
    parser.add_argument("--json", type=output_file, default=None, help="write the episode record here")
    parser.add_argument(
        "--record", type=output_file, default=None, help="write the per-tick record (JSONL) here"
    )
    parser.add_argument("--display", action="store_true", help="show the tick-level display")
    parser.add_argument(
        "--faults",
        type=Path,
        default=None,
        help="YAML fault list to inject in simulation (docs/reliability.md); replaces the mission's faults:",
    )
    parser.add_argument(
        "--view",
        action="store_true",
        help="serve the live browser view (tree, world, memory; docs/viewer.md)",
    )
    parser.add_argument(
        "--view-record", type=Path, default=None, metavar="DIR", help="save the view (`semexp-bt view DIR`)"
    )
    parser.add_argument("--view-port", type=int, default=0, help="the live view's port (default: a free one)")


def run(args: argparse.Namespace) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    if args.backend in SIMULATED_BACKENDS and args.scene is None:
        print_error(f"--scene is required with --backend {args.backend}")
        return 2
    # The view's world process first: its Rerun import then overlaps the imports of the mission stack.
    view = _view_options(args)
    if args.backend == "ros2":
        return _run_ros2(args, view)
    try:
        record = _run(args, view)
    except MissionLoadError as exc:  # the mission file (missing, not YAML, invalid): one line per problem
        for error in exc.errors:
            print(error, file=sys.stderr)
        return 2
    except ValueError as exc:  # ConfigError, InvalidInputError
        print_error(str(exc))
        return 2
    except RuntimeError as exc:
        from semexp_bt.app.viewer.observer import ViewerUnavailableError

        if not isinstance(exc, ViewerUnavailableError):
            raise
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.json is not None:
        write_json(args.json, record)
    return _report(record)


def _run_ros2(args: argparse.Namespace, view: ViewOptions | None) -> int:
    """The mission over ROS 2: the executive's record, a one-line summary, the exit status."""
    import signal
    from types import FrameType

    from robots.ros2_backend import Ros2Error
    from semexp_bt.app.configuration import read_config_file
    from semexp_bt.app.ros2_mission import Ros2MissionOptions, run_ros2_mission
    from semexp_bt.cli.process_end import bound_the_teardown, dump_stacks_on_request

    def on_sigterm(signum: int, frame: FrameType | None) -> None:
        del signum, frame
        raise KeyboardInterrupt  # the mission stops the robot and writes its record

    dump_stacks_on_request()
    signal.signal(signal.SIGTERM, on_sigterm)
    try:
        record = run_ros2_mission(
            Ros2MissionOptions(
                mission_path=args.mission,
                profile_path=args.robot_profile,
                perception=args.perception,
                instruction=args.instruction,
                seed=args.seed,
                strategy=args.strategy,
                relevance=args.relevance,
                planner=args.planner,
                config_overrides=None if args.config is None else read_config_file(args.config),
                display=args.display,
                record_path=args.record,
                view=view,
            )
        )
    except (ValueError, RuntimeError) as exc:  # a bad mission, config or profile; no rclpy, no robot;
        from semexp_bt.app.viewer.observer import ViewerUnavailableError  # no viewer extra

        if not isinstance(exc, (ValueError, Ros2Error, ViewerUnavailableError)):
            raise
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.json is not None:
        write_json(args.json, record)
    bound_the_teardown()  # the robot is closed and the record written: only the interpreter's exit is left
    halted = record["halted_by"]
    if halted is not None and halted["topic"] is not None:
        print(f"error: robot halted: {halted['topic']}: {halted['reason']}", file=sys.stderr)
    found = ", ".join(f["label"] for f in record["found_objects"]) or "nothing"
    print(
        f"ros2 ({record['profile']}): {record['outcome']} | found {found} | {record['ticks']} ticks"
        f" | path {record.get('path_length_m', 0.0):.1f} m (odometry) | {len(record.get('decisions', []))} decisions"
        f" | sim {record.get('sim_time_s', 0.0):.1f} s in {record['wall_time_s']:.1f} s wall"
    )
    if record["outcome"] == "success":
        return 0
    if record["outcome"] == "halted":
        # The robot is stopped and the record written; a dead DDS peer can hold the interpreter's teardown
        # (Fast DDS participants) for seconds, and a halted executive must be gone at once (docs/ros2.md).
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(3)
    return 1


def _run(args: argparse.Namespace, view: ViewOptions | None) -> dict[str, Any]:
    from semexp_bt.app.configuration import read_config_file
    from semexp_bt.app.episode import EpisodeOptions, run_episode
    from sims.faults import load_faults_file

    return run_episode(
        EpisodeOptions(
            mission_path=args.mission,
            scene=args.scene,
            seed=args.seed,
            instruction=args.instruction,
            fidelity=args.fidelity,
            strategy=args.strategy,
            relevance=args.relevance,
            perception=args.perception,
            models=models_profile_from_args(args),
            planner=args.planner,
            config_overrides=None if args.config is None else read_config_file(args.config),
            display=args.display,
            record_path=args.record,
            faults=None if args.faults is None else load_faults_file(args.faults),
            view=view,
        )
    )


def _view_options(args: argparse.Namespace) -> ViewOptions | None:
    """The view's options from ``--view`` / ``--view-record``, or None when neither is given."""
    if not args.view and args.view_record is None:
        return None
    from semexp_bt.app.viewer.tree_page import world_view_available
    from semexp_bt.app.viewer.world_process import WorldProcess

    # Spawned before anything heavy is imported (this module imports only the mission stack's light
    # parts): without the viewer extra there is nothing to spawn, and the observer says so.
    world_process = WorldProcess.spawn() if world_view_available() else None
    from semexp_bt.app.viewer.observer import ViewOptions

    def announce(url: str) -> None:
        print(f"view: {url}", flush=True)

    def keep_open(view: Any, outcome: str) -> None:
        # An interactive user is watching: keep the page and the stream until they are done.
        if sys.stdin.isatty():
            print(f"view: mission ended ({outcome}); the view stays at {view.url} until Ctrl-C", flush=True)
            try:
                while True:
                    time.sleep(1.0)
            except KeyboardInterrupt:
                pass

    return ViewOptions(
        live=args.view,
        record_dir=args.view_record,
        port=args.view_port,
        open_browser=args.view,
        # Over ROS 2 the scene is the bridge's, known once it has announced it (ros2_mission fills it in).
        title="" if args.backend == "ros2" else f"{args.scene} seed {args.seed}: {args.mission.name}",
        mission={
            "scene": args.scene,
            "seed": args.seed,
            "strategy": args.strategy,
            "mission": str(args.mission),
        },
        announce=announce,
        world_process=world_process,
        after_mission=keep_open,
    )


def _report(record: dict[str, Any]) -> int:
    """Print the one-line summary; exit status 0 only for a successful mission."""
    reached = record["reached_object"]["label"] if record["reached_object"] else "nothing"
    print(
        f"{record['scene']} seed {record['seed']}: {record['outcome']}"
        f" | success={record['success']} | reached {reached} | goal {record['goal']['label']}"
        f" | path {record['path_length_m']:.1f} m (L* {record['geodesic_length_m']:.1f} m)"
        f" | collisions {record['collisions']} | {len(record['decisions'])} decisions"
        f" | sim {record['sim_time_s']:.1f} s in {record['wall_time_s']:.1f} s wall"
    )
    return 0 if record["success"] else 1
