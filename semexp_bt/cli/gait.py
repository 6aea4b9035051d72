"""``semexp-bt gait``: train the RL gait (PPO, MuJoCo, CPU) or inspect a checkpoint.

semexp-bt gait train --out DIR [--resume] [--steps N] [--minutes M] [--seed S]
semexp-bt gait export --out DIR --to robots/gait_checkpoints
semexp-bt gait show [--checkpoint DIR]
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("train", "export", "show"), help="what to do")
    parser.add_argument(
        "--out", type=Path, default=None, help="training directory (state.pt, log.csv, policy/)"
    )
    parser.add_argument("--resume", action="store_true", help="continue from DIR/state.pt")
    parser.add_argument(
        "--steps", type=int, default=None, help="stop at this many env steps (across resumes)"
    )
    parser.add_argument(
        "--minutes", type=float, default=None, help="stop after this many wall minutes (this run)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--num-envs", type=int, default=32, help="parallel environments")
    parser.add_argument(
        "--best", action="store_true", help="export: the best-scoring checkpoint (policy_best/), not the last"
    )
    parser.add_argument("--to", type=Path, default=None, help="export: checkpoint directory to write")
    parser.add_argument(
        "--checkpoint", type=Path, default=None, help="show: checkpoint directory (shipped one)"
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
        trainer = PPOTrainer(args.out, config=config, seed=args.seed, resume=args.resume)
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
    from robots.gait_policy import load_policy

    policy = load_policy(args.checkpoint)
    print(json.dumps(policy.config.to_json(), indent=2))
    return 0
