"""PPO for the residual gait policy with rsl_rl (the PPO of legged_gym and Isaac Lab), on the CPU.

rsl_rl (``rsl-rl-lib`` on PyPI, the ``gait-train`` extra) owns the algorithm: the actor and critic
models, the Gaussian action distribution, the rollout storage, GAE, the clipped surrogate, the clipped value
loss, the KL-adaptive learning rate and the empirical observation normalisers. This module owns what is
ours: :class:`RslGaitEnv` adapts :class:`sims.gait_env.GaitEnv` to rsl_rl's ``VecEnv``; :class:`PPOTrainer`
runs the rollout/update loop on one torch thread, warm-starts the actor from a shipped checkpoint
(``init_from``), keeps checkpoints (``state.pt``) that resume, writes ``log.csv`` and ``training.png``,
exports the numpy policy (``policy/``) and keeps the best-scoring one (``policy_best/``).

The actor sees the proprioceptive observation (robots.gait_policy), normalised and clipped at
``OBS_CLIP`` standard deviations exactly as :class:`robots.gait_policy.NumpyActor` does at run time; the
critic also sees privileged simulator state (body velocity, height, the randomised parameters, the
obstacle contact force), an asymmetric actor-critic that costs nothing at deployment.
"""

from __future__ import annotations

import csv
import json
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from rsl_rl.algorithms import PPO
from rsl_rl.env import VecEnv
from rsl_rl.models import MLPModel
from rsl_rl.modules import EmpiricalNormalization
from rsl_rl.modules.distribution import GaussianDistribution
from tensordict import TensorDict

from robots.gait_policy import (
    ACTION_DIM,
    OBS_CLIP,
    OBS_DIM,
    NumpyActor,
    PolicyConfig,
    actor_weights_from_torch,
    load_policy,
    save_policy,
)
from semexp_bt.core.types import FloatArray, InvalidInputError
from sims.gait_bench import SETTLE_S, _nominal_env, _run, _run_in
from sims.gait_env import GaitEnv, GaitEnvConfig

STATE_FILE = "state.pt"
LOG_FILE = "log.csv"
PLOT_FILE = "training.png"
POLICY_DIR = "policy"
BEST_POLICY_DIR = "policy_best"
#: rsl_rl's normaliser adds this to the standard deviation (its default); the export folds it in.
NORMALIZER_EPS = 1e-2
#: Commands (vx, vy, yaw rate) of the selection evaluation: axes, combinations and the corners of the range.
SELECTION_COMMANDS = (
    (0.0, 0.0, 0.0), (0.5, 0.0, 0.0), (1.0, 0.0, 0.0), (-0.5, 0.0, 0.0), (0.0, 0.3, 0.0), (0.0, -0.3, 0.0),
    (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (0.5, 0.0, 1.0), (1.0, 0.3, 1.0), (1.0, -0.3, -1.0), (-0.5, -0.3, -1.0),
)  # fmt: skip

#: Run-in cases of the selection score (the benchmark's obstacles at other speeds and angles).
SELECTION_RUN_IN_SPEEDS_MPS = (0.75,)
SELECTION_RUN_IN_ANGLES_RAD = (math.radians(15.0), -math.radians(15.0))


@dataclass(frozen=True)
class PPOConfig:
    """PPO hyperparameters (rsl_rl's names in the comments) and the training task.

    Attributes:
        initial_std: the action distribution's initial standard deviation (in action units, x 0.3 rad).
        critic_warmup_iterations: after a warm start, iterations that train only the critic (the actor
            is frozen) so that a fresh critic's advantages do not undo the loaded actor.
        select_every: score the mean policy on SELECTION_COMMANDS (nominal robot) every this many
            iterations (0: never) and keep the best in ``policy_best/``: PPO's last iterate is not
            always its best.
    """

    hidden_sizes: tuple[int, ...] = (128, 128)
    rollout_steps: int = 48  # num_steps_per_env
    epochs: int = 5  # num_learning_epochs
    minibatches: int = 2  # num_mini_batches
    gamma: float = 0.99
    gae_lambda: float = 0.95  # lam
    clip_ratio: float = 0.2  # clip_param
    learning_rate: float = 1e-4
    desired_kl: float = 0.01
    value_coef: float = 1.0  # value_loss_coef
    entropy_coef: float = 0.002
    max_grad_norm: float = 1.0
    initial_std: float = math.exp(-1.0)
    critic_warmup_iterations: int = 30
    checkpoint_every: int = 10
    select_every: int = 40
    env: GaitEnvConfig = field(default_factory=GaitEnvConfig)

    def rsl_rl_config(self) -> dict[str, Any]:
        """The train_cfg dictionary rsl_rl's ``PPO.construct_algorithm`` reads."""
        model = {"class_name": MLPModel, "hidden_dims": list(self.hidden_sizes), "activation": "elu"}
        return {
            "algorithm": {
                "class_name": PPO,
                "num_learning_epochs": self.epochs,
                "num_mini_batches": self.minibatches,
                "clip_param": self.clip_ratio,
                "gamma": self.gamma,
                "lam": self.gae_lambda,
                "value_loss_coef": self.value_coef,
                "entropy_coef": self.entropy_coef,
                "learning_rate": self.learning_rate,
                "max_grad_norm": self.max_grad_norm,
                "use_clipped_value_loss": True,
                "schedule": "adaptive",
                "desired_kl": self.desired_kl,
            },
            "actor": {
                **model,
                "obs_normalization": True,
                "distribution_cfg": {
                    "class_name": GaussianDistribution,
                    "init_std": self.initial_std,
                    "std_type": "log",
                },
            },
            "critic": {**model, "obs_normalization": True},
            "obs_groups": {"actor": ["policy"], "critic": ["critic"]},
            "num_steps_per_env": self.rollout_steps,
            "multi_gpu": None,
        }


class ClippedNormalization(EmpiricalNormalization):
    """rsl_rl's empirical normaliser, with the output clipped at ``OBS_CLIP`` as the numpy actor clips it."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.clamp(super().forward(x), -OBS_CLIP, OBS_CLIP)


class RslGaitEnv(VecEnv):
    """:class:`GaitEnv` as an rsl_rl ``VecEnv``: torch tensors in and out, observation groups
    ``policy`` (the actor's, noisy) and ``critic`` (privileged, clean).

    ``last_info`` keeps the wrapped env's info of the last step (reward terms, falls, contact force).
    """

    def __init__(self, env: GaitEnv) -> None:
        self.env = env
        self.num_envs = env.num_envs
        self.num_actions = ACTION_DIM
        self.max_episode_length = env.config.episode_steps
        self.episode_length_buf = torch.zeros(env.num_envs, dtype=torch.long)
        self.device = "cpu"
        self.cfg = json.loads(json.dumps(asdict(env.config), default=str))
        self.last_info: dict[str, Any] = {}
        self._obs = env.observe()
        self._critic = env.critic_observation()

    def _group(self) -> TensorDict:
        return TensorDict(
            {
                "policy": torch.as_tensor(self._obs, dtype=torch.float32),
                "critic": torch.as_tensor(self._critic, dtype=torch.float32),
            },
            batch_size=[self.num_envs],
        )

    def get_observations(self) -> TensorDict:
        return self._group()

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict[str, Any]]:
        obs, reward, done, info = self.env.step(actions.detach().cpu().numpy().astype(float))
        self._obs, self._critic, self.last_info = obs, info["critic_obs"], info
        self.episode_length_buf = torch.as_tensor(self.env.episode_step, dtype=torch.long)
        extras = {"time_outs": torch.as_tensor(info["truncated"], dtype=torch.float32)}
        return (
            self._group(),
            torch.as_tensor(reward, dtype=torch.float32),
            torch.as_tensor(done, dtype=torch.float32),
            extras,
        )


class PPOTrainer:
    """Owns the env, rsl_rl's PPO, the log and the checkpoints of one training run.

    Args:
        out_dir: where ``state.pt``, ``log.csv``, ``training.png``, ``policy/`` and ``policy_best/`` go.
        config: hyperparameters and the training task.
        seed: seeds torch and the env (a resumed run adds its iteration, so it does not replay commands).
        resume: continue from ``out_dir/state.pt``.
        init_from: a checkpoint directory whose actor (weights and observation statistics) starts the
            run (a warm start; the critic starts fresh and trains alone for ``critic_warmup_iterations``).
    """

    def __init__(
        self,
        out_dir: Path,
        *,
        config: PPOConfig | None = None,
        seed: int = 0,
        resume: bool = False,
        init_from: Path | None = None,
    ) -> None:
        torch.set_num_threads(1)
        self.config = config or PPOConfig()
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.seed = seed
        torch.manual_seed(seed)
        self.iteration = 0
        self.env_steps = 0
        self.wall_s = 0.0
        self.best_score = math.inf
        self.warmup_until = 0
        self.init_from = str(init_from) if init_from is not None else None
        state: dict[str, Any] | None = None
        if resume:
            path = self.out_dir / STATE_FILE
            if not path.is_file():
                raise FileNotFoundError(f"--resume: no checkpoint at {path}")
            state = torch.load(path, weights_only=False)
            self.iteration = int(state["iteration"])
        self.env = GaitEnv(self.config.env, seed=seed + self.iteration)
        self.vec_env = RslGaitEnv(self.env)
        self.alg = PPO.construct_algorithm(
            self.vec_env.get_observations(), self.vec_env, self.config.rsl_rl_config(), "cpu"
        )
        self._actor_normalizer()
        if state is not None:
            self._restore(state)
        elif init_from is not None:
            self._warm_start(Path(init_from))
        else:
            # A near-zero last layer: training starts from the reference gait, not from random flailing.
            last = self._actor_linears()[-1]
            with torch.no_grad():
                last.weight.mul_(0.01)
                last.bias.zero_()
        self._episode_return = np.zeros(self.env.num_envs)
        self._finished_returns: list[float] = []

    # ------------------------------------------------------------------ models

    def _actor_linears(self) -> list[torch.nn.Linear]:
        return [m for m in self.alg.actor.mlp if isinstance(m, torch.nn.Linear)]

    def _actor_normalizer(self) -> None:
        """Swap the actor's normaliser for the clipped one (same statistics; it holds buffers only)."""
        clipped = ClippedNormalization(OBS_DIM, eps=NORMALIZER_EPS)
        clipped.load_state_dict(self.alg.actor.obs_normalizer.state_dict())
        self.alg.actor.obs_normalizer = clipped
        self.alg._raw_actor.obs_normalizer = clipped

    def _warm_start(self, directory: Path) -> None:
        policy = load_policy(directory)
        if tuple(policy.config.hidden_sizes) != tuple(self.config.hidden_sizes):
            raise InvalidInputError(
                f"{directory}: hidden sizes {policy.config.hidden_sizes} differ from the run's "
                f"{self.config.hidden_sizes}"
            )
        normalizer = self.alg.actor.obs_normalizer
        std = torch.as_tensor(policy.actor.obs_std - NORMALIZER_EPS, dtype=torch.float32)
        if torch.any(std <= 0):
            raise InvalidInputError(f"{directory}: an observation std is below rsl_rl's eps {NORMALIZER_EPS}")
        with torch.no_grad():
            for layer, (w, b) in zip(self._actor_linears(), policy.actor.weights, strict=True):
                layer.weight.copy_(torch.as_tensor(w.T, dtype=torch.float32))
                layer.bias.copy_(torch.as_tensor(b, dtype=torch.float32))
            normalizer._mean.copy_(torch.as_tensor(policy.actor.obs_mean, dtype=torch.float32)[None, :])
            normalizer._std.copy_(std[None, :])
            normalizer._var.copy_(std[None, :] ** 2)
            # The loaded statistics count as the samples they came from: new data moves them slowly.
            normalizer.count.fill_(int(policy.config.info.get("env_steps", 1_000_000)))
        self.warmup_until = self.config.critic_warmup_iterations

    def _set_actor_trainable(self, trainable: bool) -> None:
        for parameter in self.alg.actor.parameters():
            parameter.requires_grad_(trainable)

    # ------------------------------------------------------------------ persistence

    def _restore(self, state: dict[str, Any]) -> None:
        self.alg.load(state["alg"], None, strict=True)
        self.alg.learning_rate = float(state["learning_rate"])
        self.env_steps = int(state["env_steps"])
        self.wall_s = float(state["wall_s"])
        self.best_score = float(state.get("best_score", math.inf))
        self.warmup_until = int(state.get("warmup_until", 0))
        self.init_from = state.get("init_from")

    def save(self) -> None:
        """Export the policy, score it when due (keeping the best), then write ``state.pt`` (resumable)."""
        self.export(self.out_dir / POLICY_DIR)
        if self.config.select_every and self.iteration % self.config.select_every == 0:
            score = selection_score(self.out_dir / POLICY_DIR)
            if score < self.best_score:
                self.best_score = score
                self.export(self.out_dir / BEST_POLICY_DIR, extra_info={"selection_score": round(score, 4)})
        state = {
            "alg": self.alg.save(),
            "learning_rate": self.alg.learning_rate,
            "iteration": self.iteration,
            "env_steps": self.env_steps,
            "wall_s": self.wall_s,
            "best_score": self.best_score,
            "warmup_until": self.warmup_until,
            "init_from": self.init_from,
            "config": json.loads(json.dumps(asdict(self.config), default=str)),
        }
        tmp = self.out_dir / (STATE_FILE + ".tmp")
        torch.save(state, tmp)
        tmp.replace(self.out_dir / STATE_FILE)

    def numpy_actor(self) -> NumpyActor:
        """The current mean policy as the run-time numpy actor (the same normalisation and clip)."""
        normalizer = self.alg.actor.obs_normalizer
        return NumpyActor(
            actor_weights_from_torch(self.alg.actor.mlp),
            normalizer.mean.numpy().astype(float),
            normalizer.std.numpy().astype(float) + normalizer.eps,
        )

    def export(self, directory: Path, *, extra_info: dict[str, Any] | None = None) -> None:
        """Write the numpy policy (weights + observation statistics + config) to ``directory``."""
        info = {
            "trainer": "sims/gait_train.py (rsl_rl PPO)",
            "seed": self.seed,
            "init_from": self.init_from,
            "iterations": self.iteration,
            "env_steps": self.env_steps,
            "train_wall_s": round(self.wall_s, 1),
            **(extra_info or {}),
        }
        config = PolicyConfig(
            hidden_sizes=self.config.hidden_sizes,
            trot=self.config.env.trot,
            residual_scale_rad=self.config.env.residual_scale_rad,
            info=info,
        )
        save_policy(directory, config=config, actor=self.numpy_actor())

    # ------------------------------------------------------------------ PPO

    def iterate(self, obs: TensorDict) -> tuple[TensorDict, dict[str, float]]:
        """One rollout + update; returns the next observations and the iteration's statistics."""
        cfg = self.config
        steps, n = cfg.rollout_steps, self.env.num_envs
        falls = 0
        contact_steps = 0
        term_sums: dict[str, float] = {}
        rewards_sum = 0.0
        warming_up = self.iteration < self.warmup_until
        self._set_actor_trainable(not warming_up)
        started = time.perf_counter()
        with torch.inference_mode():
            for _ in range(steps):
                actions = self.alg.act(obs)
                obs, rewards, dones, extras = self.vec_env.step(actions)
                self.alg.process_env_step(obs, rewards, dones, extras)
                info = self.vec_env.last_info
                falls += int(np.sum(info["terminated"]))
                contact_steps += int(np.sum(info["contact_force_n"] > 1.0))
                for key, value in info.items():
                    if key.startswith("reward/"):
                        term_sums[key] = term_sums.get(key, 0.0) + float(np.mean(value))
                reward = rewards.numpy()
                rewards_sum += float(reward.mean())
                self._episode_return += reward
                for i in np.flatnonzero(dones.numpy()):
                    self._finished_returns.append(float(self._episode_return[i]))
                    self._episode_return[i] = 0.0
            rollout_s = time.perf_counter() - started
            self.alg.compute_returns(obs)
        losses = self.alg.update()
        if warming_up:
            # The frozen actor's KL is zero, which would have grown the adaptive rate: start afresh.
            self.alg.learning_rate = cfg.learning_rate
            for group in self.alg.optimizer.param_groups:
                group["lr"] = cfg.learning_rate
        self._set_actor_trainable(True)
        self.iteration += 1
        self.env_steps += steps * n
        stats = {
            "rollout_s": rollout_s,
            "mean_step_reward": rewards_sum / steps,
            "falls_per_1k_steps": 1000.0 * falls / (steps * n),
            "contact_share": contact_steps / (steps * n),
            "episode_return": float(np.mean(self._finished_returns[-50:]))
            if self._finished_returns
            else math.nan,
            "value_loss": losses["value"],
            "policy_loss": losses["surrogate"],
            "entropy": losses["entropy"],
            "learning_rate": self.alg.learning_rate,
            "action_std": float(self.alg.actor.distribution.log_std_param.detach().exp().mean()),
            "critic_warmup": float(warming_up),
            **{key.replace("reward/", "r_"): value / steps for key, value in term_sums.items()},
        }
        return obs, stats

    # ------------------------------------------------------------------ loop

    def train(
        self, *, total_steps: int | None = None, max_minutes: float | None = None, verbose: bool = True
    ) -> None:
        """Train until ``total_steps`` env steps (counted across resumes) or ``max_minutes`` of this run."""
        if total_steps is None and max_minutes is None:
            raise InvalidInputError("train needs total_steps or max_minutes")
        log_path = self.out_dir / LOG_FILE
        new_log = not log_path.is_file()
        obs = self.vec_env.get_observations()
        self.alg.train_mode()
        started = time.perf_counter()
        last_tick = started
        with log_path.open("a", newline="") as handle:
            writer: csv.DictWriter[str] | None = None
            while True:
                if total_steps is not None and self.env_steps >= total_steps:
                    break
                obs, stats = self.iterate(obs)
                now = time.perf_counter()
                self.wall_s += now - last_tick
                last_tick = now
                row: dict[str, Any] = {
                    "iteration": self.iteration,
                    "env_steps": self.env_steps,
                    "wall_s": round(self.wall_s, 1),
                }
                row.update({k: round(v, 5) for k, v in stats.items()})
                if writer is None:
                    writer = csv.DictWriter(handle, fieldnames=list(row), extrasaction="ignore")
                    if new_log:
                        writer.writeheader()
                writer.writerow(row)
                handle.flush()
                if verbose and self.iteration % 5 == 0:
                    print(
                        f"it {self.iteration} steps {self.env_steps} wall {self.wall_s:.0f}s "
                        f"ret {stats['episode_return']:.2f} lin {stats.get('r_tracking_lin_vel', 0):.3f} "
                        f"yaw {stats.get('r_tracking_ang_vel', 0):.3f} falls/1k {stats['falls_per_1k_steps']:.2f} "
                        f"contact {stats['contact_share']:.2f} std {stats['action_std']:.3f} "
                        f"lr {stats['learning_rate']:.1e}",
                        flush=True,
                    )
                done_steps = total_steps is not None and self.env_steps >= total_steps
                done_time = max_minutes is not None and (now - started) / 60.0 >= max_minutes
                if self.iteration % self.config.checkpoint_every == 0 or done_steps or done_time:
                    self.save()
                    plot_log(log_path, self.out_dir / PLOT_FILE)
                if done_steps or done_time:
                    break


def selection_score(policy_dir: Path, *, seconds: float = 5.0) -> float:
    """Lower is better: RMS tracking errors (horizontal m/s + 0.5 x yaw rad/s) after 1.5 s of each
    SELECTION_COMMANDS command on the nominal robot, plus 1 per fall, plus 1 per fallen case of walking into
    the benchmark's obstacles at SELECTION_RUN_IN_SPEEDS_MPS and SELECTION_RUN_IN_ANGLES_RAD (speeds and
    angles the benchmark does not use, so that selection does not fit its test)."""
    policy = load_policy(policy_dir)
    env = _nominal_env(len(SELECTION_COMMANDS), trot_policy=policy, seed=0)
    env.commands[:] = np.array(SELECTION_COMMANDS)
    falls, stats, _ = _run(env, policy, int(round((SETTLE_S + seconds) / 0.02)), ramp=False)
    summary = stats.summary(1.0)
    # The policy alone, without the controller's near-fall recovery: selection judges what training made.
    run_in = _run_in(
        policy, speeds=SELECTION_RUN_IN_SPEEDS_MPS, angles=SELECTION_RUN_IN_ANGLES_RAD, recovery=False
    )
    return summary["lin_vel_rms_mps"] + 0.5 * summary["yaw_rate_rms_radps"] + float(falls + run_in["fell"])


def plot_log(log_path: Path, plot_path: Path) -> None:
    """Plot episode return, tracking rewards and falls against env steps from ``log.csv``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with log_path.open() as handle:
        rows = list(csv.DictReader(handle))
    if not rows:
        return
    steps = np.array([float(r["env_steps"]) for r in rows]) / 1e6

    def column(name: str) -> FloatArray:
        return np.array([float(r.get(name) or "nan") for r in rows])

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.5))
    axes[0].plot(steps, column("episode_return"))
    axes[0].set_title("episode return (last 50)")
    axes[1].plot(steps, column("r_tracking_lin_vel"), label="lin vel")
    axes[1].plot(steps, column("r_tracking_ang_vel"), label="yaw rate")
    axes[1].set_title("tracking reward (1 = perfect)")
    axes[1].legend()
    axes[2].plot(steps, column("falls_per_1k_steps"))
    axes[2].set_title("falls per 1000 steps")
    for ax in axes:
        ax.set_xlabel("env steps (M)")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(plot_path, dpi=80)
    plt.close(fig)
