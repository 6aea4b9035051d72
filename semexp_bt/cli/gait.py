"""``semexp-bt gait``: train the RL gait (PPO, MuJoCo, CPU) or inspect a checkpoint.

semexp-bt gait train --out DIR [--resume] [--init CHECKPOINT] [--steps N] [--minutes M] [--seed S]
semexp-bt gait export --out DIR --to robots/gait_checkpoints
semexp-bt gait show [--checkpoint DIR]
semexp-bt gait probe --scene SCENE --seed N --json FILE [--checkpoint DIR]

``probe`` runs one dynamic-fidelity mission and records, every tick, what the gait was asked and what the
body did: the requested twist, the ramped command the policy saw, the body's twist, roll, pitch, trunk
height and every contact between the robot and an obstacle (robot geom, object, normal force). A fall
gets a summary of the seconds before it (what preceded it: contact, a turn, a command step).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from semexp_bt.app.runner import MissionRun

#: What ``probe`` summarises before a fall (s).
FALL_LOOKBACK_S = 3.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("train", "export", "show", "probe"), help="what to do")
    parser.add_argument(
        "--out", type=Path, default=None, help="training directory (state.pt, log.csv, policy/)"
    )
    parser.add_argument("--resume", action="store_true", help="continue from DIR/state.pt")
    parser.add_argument(
        "--init", type=Path, default=None, help="train: warm-start the actor from this checkpoint directory"
    )
    parser.add_argument(
        "--steps", type=int, default=None, help="stop at this many env steps (across resumes)"
    )
    parser.add_argument(
        "--minutes", type=float, default=None, help="stop after this many wall minutes (this run)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--num-envs", type=int, default=32, help="parallel environments")
    parser.add_argument(
        "--initial-std", type=float, default=None, help="train: initial action std (default: PPOConfig's)"
    )
    parser.add_argument(
        "--best", action="store_true", help="export: the best-scoring checkpoint (policy_best/), not the last"
    )
    parser.add_argument("--to", type=Path, default=None, help="export: checkpoint directory to write")
    parser.add_argument(
        "--checkpoint", type=Path, default=None, help="show / probe: checkpoint directory (shipped one)"
    )
    parser.add_argument("--scene", default=None, help="probe: scene name")
    parser.add_argument("--json", type=Path, default=None, help="probe: write the per-tick probe here")
    parser.add_argument(
        "--relevance", choices=("embedding", "lexical"), default="embedding", help="probe: relevance scorer"
    )


def run(args: argparse.Namespace) -> int:
    if args.action == "train":
        if args.out is None:
            raise SystemExit("semexp-bt gait train: --out DIR is required")
        if args.steps is None and args.minutes is None:
            args.steps = 3_000_000
        import torch

        torch.set_num_threads(1)
        from sims.gait_env import GaitEnvConfig
        from sims.gait_train import PPOConfig, PPOTrainer

        config = PPOConfig(env=GaitEnvConfig(num_envs=args.num_envs))
        if args.initial_std is not None:
            config = dataclasses.replace(config, initial_std=args.initial_std)
        trainer = PPOTrainer(args.out, config=config, seed=args.seed, resume=args.resume, init_from=args.init)
        trainer.train(total_steps=args.steps, max_minutes=args.minutes)
        print(
            f"trained to {trainer.env_steps} env steps in {trainer.wall_s:.0f} s; policy in {args.out}/policy"
        )
        return 0
    if args.action == "export":
        if args.out is None or args.to is None:
            raise SystemExit("semexp-bt gait export: --out DIR and --to DIR are required")
        from robots.gait_policy import CONFIG_FILE, WEIGHTS_FILE, load_policy

        source = args.out / ("policy_best" if args.best else "policy")
        load_policy(source)  # validates before anything is overwritten
        args.to.mkdir(parents=True, exist_ok=True)
        for name in (WEIGHTS_FILE, CONFIG_FILE):
            shutil.copy2(source / name, args.to / name)
        print(f"exported {source} -> {args.to}")
        return 0
    if args.action == "probe":
        return _probe(args)
    from robots.gait_policy import load_policy

    policy = load_policy(args.checkpoint)
    print(json.dumps(policy.config.to_json(), indent=2))
    return 0


class GaitProbe:
    """A tick observer that records what the gait was asked and what the body did, every tick."""

    wants_activity_stream = False

    def __init__(self) -> None:
        self.ticks: list[dict[str, Any]] = []
        self._requested = (0.0, 0.0, 0.0)
        self._geom_names: dict[int, str] = {}
        self._object_names: dict[int, str] = {}

    def start(self, run: MissionRun) -> None:
        from robots.mjcf_scene import geom_object_ids

        robot: Any = run.robot
        model = robot.model
        self._object_of_geom = geom_object_ids(model)
        self._robot_geoms = {int(g) for g in robot._robot_geoms}
        self._geom_names = {g: model.geom(g).name or f"geom{g}" for g in self._robot_geoms}
        gait = run.services.gait
        assert gait is not None, "probe needs dynamic fidelity (a gait)"
        self._controller: Any = gait

        def recording_gait(robot: Any, twist: Any) -> None:
            self._requested = (twist.linear_x_mps, twist.linear_y_mps, twist.angular_z_radps)
            gait(robot, twist)

        run.services.gait = recording_gait

    def after_tick(self, run: MissionRun) -> None:
        import mujoco
        import numpy as np

        robot: Any = run.robot
        model, data = robot.model, robot.data
        w, x, y, z = data.qpos[3:7]
        roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
        pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
        twist = robot.base_twist()
        contacts: dict[str, float] = {}
        force = np.zeros(6)
        for index in range(data.ncon):
            contact = data.contact[index]
            pair = (int(contact.geom1), int(contact.geom2))
            robot_geom = next((g for g in pair if g in self._robot_geoms), None)
            other = pair[1] if robot_geom == pair[0] else pair[0]
            object_id = int(self._object_of_geom[other])
            if robot_geom is None or object_id < 0:
                continue
            mujoco.mj_contactForce(model, data, index, force)
            key = f"{self._geom_names[robot_geom]}>obj{object_id}"
            contacts[key] = round(contacts.get(key, 0.0) + float(force[0]), 1)
        self.ticks.append(
            {
                "t": round(robot.now_s(), 2),
                "requested": [round(v, 3) for v in self._requested],
                "command": [round(float(v), 3) for v in self._controller.command],
                "body": [
                    round(twist.linear_x_mps, 3),
                    round(twist.linear_y_mps, 3),
                    round(twist.angular_z_radps, 3),
                ],
                "roll": round(roll, 3),
                "pitch": round(pitch, 3),
                "height": round(float(data.qpos[2]), 3),
                "contacts": contacts,
                "fallen": robot.safety().fallen,
                "recovering": bool(getattr(self._controller, "recovering", False)),
            }
        )

    def finish(self, run: MissionRun, outcome: str) -> None:
        pass

    def fall_summary(self) -> dict[str, Any] | None:
        """What the :data:`FALL_LOOKBACK_S` before the first fallen tick held, or None without a fall."""
        fall = next((k for k, tick in enumerate(self.ticks) if tick["fallen"]), None)
        if fall is None:
            return None
        t_fall = self.ticks[fall]["t"]
        window = [tick for tick in self.ticks[: fall + 1] if tick["t"] >= t_fall - FALL_LOOKBACK_S]
        contact_forces: dict[str, float] = {}
        for tick in window:
            for key, value in tick["contacts"].items():
                contact_forces[key] = max(contact_forces.get(key, 0.0), value)
        first_contact = next((tick["t"] for tick in window if tick["contacts"]), None)

        def span(index: int, field: str) -> list[float]:
            values = [tick[field][index] for tick in window]
            return [min(values), max(values)]

        return {
            "t_fall_s": t_fall,
            "first_contact_in_window_s": first_contact,
            "max_contact_force_n": contact_forces,
            "requested_vx": span(0, "requested"),
            "requested_wz": span(2, "requested"),
            "command_vx": span(0, "command"),
            "command_wz": span(2, "command"),
            "body_vy": span(1, "body"),
            "roll_at_fall": self.ticks[fall]["roll"],
            "pitch_at_fall": self.ticks[fall]["pitch"],
            "height_at_fall": self.ticks[fall]["height"],
        }


def _probe(args: argparse.Namespace) -> int:
    """Run one dynamic mission with :class:`GaitProbe` attached; write ticks and the fall summary."""
    from unittest import mock

    import semexp_bt.app.episode as episode_module
    from semexp_bt.app.episode import EpisodeOptions, run_episode
    from semexp_bt.core.durable import write_json

    if args.scene is None or args.json is None:
        raise SystemExit("semexp-bt gait probe: --scene and --json are required")
    probe = GaitProbe()
    plain_recorder: Callable[..., Any] = episode_module.TickRecorder

    def with_probe(**kwargs: Any) -> Any:
        recorder = plain_recorder(**kwargs)
        return _Both(recorder, probe)

    with mock.patch.object(episode_module, "TickRecorder", with_probe):
        if args.checkpoint is not None:
            from robots.gait_policy import make_gait_controller

            mock.patch.object(
                episode_module, "build_gait", lambda _fidelity: make_gait_controller(args.checkpoint)
            ).start()
        try:
            record = run_episode(
                EpisodeOptions(
                    mission_path=Path("trees/object_search.yaml"),
                    scene=args.scene,
                    seed=args.seed,
                    fidelity="dynamic",
                    relevance=args.relevance,
                )
            )
        finally:
            mock.patch.stopall()
    summary = probe.fall_summary()
    near_falls = int(getattr(probe._controller, "near_falls", 0))
    write_json(
        args.json,
        {
            "scene": args.scene,
            "seed": args.seed,
            "outcome": record["outcome"],
            "fall": summary,
            "ticks": probe.ticks,
        },
    )
    print(
        f"{args.scene} seed {args.seed}: {record['outcome']}; near falls {near_falls}; "
        f"fall: {json.dumps(summary)}"
    )
    return 0


class _Both:
    """Two tick observers as one."""

    def __init__(self, first: Any, second: Any) -> None:
        self._observers = (first, second)
        self.wants_activity_stream = any(o.wants_activity_stream for o in self._observers)

    def start(self, run: MissionRun) -> None:
        for observer in self._observers:
            observer.start(run)

    def after_tick(self, run: MissionRun) -> None:
        for observer in self._observers:
            observer.after_tick(run)

    def finish(self, run: MissionRun, outcome: str) -> None:
        for observer in self._observers:
            observer.finish(run, outcome)
