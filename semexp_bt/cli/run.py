"""``semexp-bt run MISSION.yaml [--backend mujoco] --scene SCENE --seed N``: run one mission.

On the MuJoCo backend (the default) the mission runs in a simulated episode: ``--scene`` and ``--seed``
choose the world and the start, and the record is scored against the scene's ground truth.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

from semexp_bt.app.components import DEFAULT_PLANNER, PLANNERS, RELEVANCE_SCORERS, ROBOT_BACKENDS

#: Backends whose missions run in a simulated scene (they need ``--scene``).
SIMULATED_BACKENDS = ("mujoco",)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("mission", type=Path, help="mission tree (YAML), e.g. trees/object_search.yaml")
    parser.add_argument(
        "--backend", choices=sorted(ROBOT_BACKENDS), default="mujoco", help="robot backend (default: mujoco)"
    )
    parser.add_argument("--scene", default=None, help="scene name (see `semexp-bt scene list`); mujoco only")
    parser.add_argument(
        "--seed", type=int, default=0, help="seed for layout, start pose and perception noise"
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
    parser.add_argument("--strategy", default="ours", help="strategy (see semexp_bt/app/strategies.yaml)")
    parser.add_argument(
        "--relevance",
        choices=sorted(RELEVANCE_SCORERS),
        default="embedding",
        help="semantic relevance scorer (embedding: offline MiniLM; lexical: no torch)",
    )
    parser.add_argument(
        "--planner", choices=sorted(PLANNERS), default=DEFAULT_PLANNER, help="path-following controller"
    )
    parser.add_argument(
        "--config", type=Path, default=None, help="YAML of config overrides (the last layer; docs/config.md)"
    )
    parser.add_argument("--json", type=Path, default=None, help="write the episode record here")
    parser.add_argument("--record", type=Path, default=None, help="write the per-tick record (JSONL) here")
    parser.add_argument("--display", action="store_true", help="show the tick-level display")


def run(args: argparse.Namespace) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    if not args.mission.is_file():
        print(f"error: mission file {args.mission} does not exist", file=sys.stderr)
        return 2
    if args.backend in SIMULATED_BACKENDS and args.scene is None:
        print(f"error: --scene is required with --backend {args.backend}", file=sys.stderr)
        return 2
    try:
        record = _run(args)
    except ValueError as exc:  # MissionLoadError, ConfigError, InvalidInputError, unknown scene or strategy
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(record, indent=1))
    return _report(record)


def _run(args: argparse.Namespace) -> dict[str, Any]:
    from semexp_bt.app.configuration import read_config_file
    from semexp_bt.app.episode import EpisodeOptions, run_episode

    return run_episode(
        EpisodeOptions(
            mission_path=args.mission,
            scene=args.scene,
            seed=args.seed,
            instruction=args.instruction,
            fidelity=args.fidelity,
            strategy=args.strategy,
            relevance=args.relevance,
            planner=args.planner,
            config_overrides=None if args.config is None else read_config_file(args.config),
            display=args.display,
            record_path=args.record,
        )
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
