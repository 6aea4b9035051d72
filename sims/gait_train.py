"""PPO for the residual gait policy, in plain torch on the CPU (one process, one torch thread).

The actor sees the proprioceptive observation (robots.gait_policy); the critic also sees privileged
simulator state (body velocity, height, the randomised parameters), an asymmetric actor-critic that
learns faster and costs nothing at deployment. Every iteration: a rollout of ``rollout_steps`` control
steps in each of the env's ``num_envs`` environments, GAE, ``epochs`` passes of clipped-surrogate updates
over ``minibatches`` minibatches, a KL-adaptive learning rate. Checkpoints (``state.pt``) resume; the
exported numpy policy (``policy/``) is written with every checkpoint; ``log.csv`` gets one row per
iteration and ``training.png`` plots it.
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

from robots.gait_policy import (
    ACTION_DIM,
    OBS_DIM,
    NumpyActor,
    PolicyConfig,
    actor_weights_from_torch,
    build_torch_actor,
    save_policy,
)
from semexp_bt.core.types import FloatArray, InvalidInputError
from sims.gait_env import CRITIC_OBS_DIM, GaitEnv, GaitEnvConfig

STATE_FILE = "state.pt"
LOG_FILE = "log.csv"
PLOT_FILE = "training.png"
POLICY_DIR = "policy"
BEST_POLICY_DIR = "policy_best"
#: Commands (vx, vy, yaw rate) of the selection evaluation: axes, combinations and the corners of the range.
SELECTION_COMMANDS = (
    (0.0, 0.0, 0.0), (0.5, 0.0, 0.0), (1.0, 0.0, 0.0), (-0.5, 0.0, 0.0), (0.0, 0.3, 0.0), (0.0, -0.3, 0.0),
    (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (0.5, 0.0, 1.0), (1.0, 0.3, 1.0), (1.0, -0.3, -1.0), (-0.5, -0.3, -1.0),
)  # fmt: skip


@dataclass(frozen=True)
class PPOConfig:
    """PPO hyperparameters."""

    hidden_sizes: tuple[int, ...] = (128, 128)
    rollout_steps: int = 48
    epochs: int = 5
    minibatches: int = 4
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_ratio: float = 0.2
    learning_rate: float = 3e-4
    desired_kl: float = 0.01
    value_coef: float = 1.0
    entropy_coef: float = 0.002
    max_grad_norm: float = 1.0
    initial_log_std: float = -1.0
    checkpoint_every: int = 10
    #: Evaluate the mean policy on SELECTION_COMMANDS (nominal robot) every this many iterations (0: never)
    #: and keep the best one in ``policy_best/``: PPO's last iterate is not always its best.
    select_every: int = 20
    env: GaitEnvConfig = field(default_factory=GaitEnvConfig)


def compute_gae(
    *,
    rewards: FloatArray,
    values: FloatArray,
    dones: FloatArray,
    last_values: FloatArray,
    gamma: float,
    lam: float,
) -> tuple[FloatArray, FloatArray]:
    """Generalised advantage estimation over a ``(T, N)`` rollout.

    ``dones[t]`` marks that the episode ended after step ``t`` (no bootstrap across it; time-limit
    truncations are handled by the caller by adding ``gamma * V(terminal state)`` to that reward).

    Returns:
        ``(advantages, returns)``, both ``(T, N)``; returns = advantages + values.
    """
    steps = rewards.shape[0]
    advantages = np.zeros_like(rewards, dtype=float)
    running = np.zeros(rewards.shape[1:], dtype=float)
    for t in reversed(range(steps)):
        next_values = last_values if t == steps - 1 else values[t + 1]
        not_done = 1.0 - dones[t]
        delta = rewards[t] + gamma * next_values * not_done - values[t]
        running = delta + gamma * lam * not_done * running
        advantages[t] = running
    return advantages, advantages + values


class RunningNormalizer:
    """Running mean and variance (parallel Welford) of observation vectors."""

    def __init__(self, dim: int) -> None:
        self.mean = np.zeros(dim)
        self.var = np.ones(dim)
        self.count = 1e-4

    def update(self, batch: FloatArray) -> None:
        batch_mean, batch_var, batch_count = batch.mean(axis=0), batch.var(axis=0), batch.shape[0]
        delta = batch_mean - self.mean
        total = self.count + batch_count
        self.mean = self.mean + delta * batch_count / total
        m2 = self.var * self.count + batch_var * batch_count + delta**2 * self.count * batch_count / total
        self.var = m2 / total
        self.count = total

    @property
    def std(self) -> FloatArray:
        return np.sqrt(self.var) + 1e-6

    def normalize(self, x: FloatArray) -> FloatArray:
        return np.clip((x - self.mean) / self.std, -5.0, 5.0)

    def state(self) -> dict[str, Any]:
        return {"mean": self.mean, "var": self.var, "count": self.count}

    def load(self, state: dict[str, Any]) -> None:
        self.mean, self.var, self.count = (
            np.asarray(state["mean"]),
            np.asarray(state["var"]),
            float(state["count"]),
        )


def _mlp(in_dim: int, out_dim: int, hidden: tuple[int, ...]) -> torch.nn.Sequential:
    return build_torch_actor(in_dim, out_dim, hidden)


class PPOTrainer:
    """Owns the env, the networks, the optimiser, the normalisers and the log of one training run."""

    def __init__(
        self, out_dir: Path, *, config: PPOConfig | None = None, seed: int = 0, resume: bool = False
    ) -> None:
        torch.set_num_threads(1)
        self.config = config or PPOConfig()
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.seed = seed
        torch.manual_seed(seed)
        cfg = self.config
        self.actor = build_torch_actor(OBS_DIM, ACTION_DIM, cfg.hidden_sizes)
        # A near-zero last layer: training starts from the reference gait, not from random flailing.
        last_layer = self.actor[-1]
        assert isinstance(last_layer, torch.nn.Linear)
        with torch.no_grad():
            last_layer.weight.mul_(0.01)
            last_layer.bias.zero_()
        self.critic = _mlp(CRITIC_OBS_DIM, 1, cfg.hidden_sizes)
        self.log_std = torch.nn.Parameter(torch.full((ACTION_DIM,), cfg.initial_log_std))
        self.optimizer = torch.optim.Adam(
            [*self.actor.parameters(), *self.critic.parameters(), self.log_std], lr=cfg.learning_rate
        )
        self.learning_rate = cfg.learning_rate
        self.obs_norm = RunningNormalizer(OBS_DIM)
        self.critic_norm = RunningNormalizer(CRITIC_OBS_DIM)
        self.iteration = 0
        self.env_steps = 0
        self.wall_s = 0.0
        self.best_score = math.inf
        env_seed = seed
        if resume:
            env_seed = self._load() + seed
        self.env = GaitEnv(cfg.env, seed=env_seed)
        self._episode_return = np.zeros(self.env.num_envs)
        self._finished_returns: list[float] = []

    # ------------------------------------------------------------------ persistence

    def _load(self) -> int:
        path = self.out_dir / STATE_FILE
        if not path.is_file():
            raise FileNotFoundError(f"--resume: no checkpoint at {path}")
        state = torch.load(path, weights_only=False)
        self.actor.load_state_dict(state["actor"])
        self.critic.load_state_dict(state["critic"])
        with torch.no_grad():
            self.log_std.copy_(state["log_std"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.learning_rate = float(state["learning_rate"])
        self.obs_norm.load(state["obs_norm"])
        self.critic_norm.load(state["critic_norm"])
        self.iteration = int(state["iteration"])
        self.env_steps = int(state["env_steps"])
        self.wall_s = float(state["wall_s"])
        self.best_score = float(state.get("best_score", math.inf))
        # A fresh env seed per resumed run, so a resumed run does not replay the same commands.
        return self.iteration

    def save(self) -> None:
        state = {
            "actor": self.actor.state_dict(),
            "critic": self.critic.state_dict(),
            "log_std": self.log_std.detach().clone(),
            "optimizer": self.optimizer.state_dict(),
            "learning_rate": self.learning_rate,
            "obs_norm": self.obs_norm.state(),
            "critic_norm": self.critic_norm.state(),
            "iteration": self.iteration,
            "env_steps": self.env_steps,
            "wall_s": self.wall_s,
            "best_score": self.best_score,
            "config": json.loads(json.dumps(asdict(self.config), default=str)),
        }
        tmp = self.out_dir / (STATE_FILE + ".tmp")
        torch.save(state, tmp)
        tmp.replace(self.out_dir / STATE_FILE)
        self.export(self.out_dir / POLICY_DIR)
        if self.config.select_every and self.iteration % self.config.select_every == 0:
            score = selection_score(self.out_dir / POLICY_DIR)
            if score < self.best_score:
                self.best_score = score
                self.export(self.out_dir / BEST_POLICY_DIR, extra_info={"selection_score": round(score, 4)})

    def export(self, directory: Path, *, extra_info: dict[str, Any] | None = None) -> None:
        """Write the numpy policy (weights + observation statistics + config) to ``directory``."""
        actor = NumpyActor(actor_weights_from_torch(self.actor), self.obs_norm.mean, self.obs_norm.std)
        info = {
            "trainer": "sims/gait_train.py (PPO)",
            "seed": self.seed,
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
        save_policy(directory, config=config, actor=actor)

    # ------------------------------------------------------------------ PPO

    def _distribution(self, obs_t: torch.Tensor) -> torch.distributions.Normal:
        return torch.distributions.Normal(self.actor(obs_t), self.log_std.exp())

    def _values(self, critic_obs: FloatArray) -> FloatArray:
        with torch.no_grad():
            x = torch.as_tensor(self.critic_norm.normalize(critic_obs), dtype=torch.float32)
            return self.critic(x).squeeze(-1).numpy().astype(float)

    def iterate(
        self, obs: FloatArray, critic_obs: FloatArray
    ) -> tuple[FloatArray, FloatArray, dict[str, float]]:
        """One rollout + update; returns the next observations and the iteration's statistics."""
        cfg = self.config
        steps, n = cfg.rollout_steps, self.env.num_envs
        buf_obs = np.zeros((steps, n, OBS_DIM))
        buf_critic = np.zeros((steps, n, CRITIC_OBS_DIM))
        buf_act = np.zeros((steps, n, ACTION_DIM))
        buf_logp = np.zeros((steps, n))
        buf_rew = np.zeros((steps, n))
        buf_done = np.zeros((steps, n))
        buf_val = np.zeros((steps, n))
        falls = 0
        term_sums: dict[str, float] = {}
        started = time.perf_counter()
        for t in range(steps):
            self.obs_norm.update(obs)
            self.critic_norm.update(critic_obs)
            norm_obs = self.obs_norm.normalize(obs)
            with torch.no_grad():
                dist = self._distribution(torch.as_tensor(norm_obs, dtype=torch.float32))
                action = dist.sample()
                logp = dist.log_prob(action).sum(-1)
            buf_obs[t], buf_critic[t] = norm_obs, self.critic_norm.normalize(critic_obs)
            buf_act[t], buf_logp[t] = action.numpy(), logp.numpy()
            buf_val[t] = self._values(critic_obs)
            obs, reward, done, info = self.env.step(action.numpy())
            if np.any(info["truncated"]):
                # Time limit: bootstrap from the state the episode was cut in.
                reward = reward + cfg.gamma * self._values(info["terminal_critic_obs"]) * info["truncated"]
            critic_obs = info["critic_obs"]
            buf_rew[t], buf_done[t] = reward, done
            falls += int(np.sum(info["terminated"]))
            for key, value in info.items():
                if key.startswith("reward/"):
                    term_sums[key] = term_sums.get(key, 0.0) + float(np.mean(value))
            self._episode_return += reward
            for i in np.flatnonzero(done):
                self._finished_returns.append(float(self._episode_return[i]))
                self._episode_return[i] = 0.0
        rollout_s = time.perf_counter() - started
        advantages, returns = compute_gae(
            rewards=buf_rew,
            values=buf_val,
            dones=buf_done,
            last_values=self._values(critic_obs),
            gamma=cfg.gamma,
            lam=cfg.gae_lambda,
        )
        stats = self._update(buf_obs, buf_critic, buf_act, buf_logp, advantages, returns)
        self.iteration += 1
        self.env_steps += steps * n
        stats.update(
            {
                "rollout_s": rollout_s,
                "mean_step_reward": float(buf_rew.mean()),
                "falls_per_1k_steps": 1000.0 * falls / (steps * n),
                "episode_return": float(np.mean(self._finished_returns[-50:]))
                if self._finished_returns
                else math.nan,
                **{key.replace("reward/", "r_"): value / steps for key, value in term_sums.items()},
            }
        )
        return obs, critic_obs, stats

    def _update(
        self,
        obs: FloatArray,
        critic_obs: FloatArray,
        actions: FloatArray,
        old_logp: FloatArray,
        advantages: FloatArray,
        returns: FloatArray,
    ) -> dict[str, float]:
        cfg = self.config
        flat = lambda x: torch.as_tensor(x.reshape(-1, *x.shape[2:]), dtype=torch.float32)  # noqa: E731
        obs_t, critic_t, act_t, logp_t = flat(obs), flat(critic_obs), flat(actions), flat(old_logp)
        adv_t, ret_t = flat(advantages), flat(returns)
        adv_t = (adv_t - adv_t.mean()) / (adv_t.std() + 1e-8)
        total = obs_t.shape[0]
        batch = total // cfg.minibatches
        generator = torch.Generator().manual_seed(self.seed * 100003 + self.iteration)
        kls, policy_losses, value_losses = [], [], []
        for _ in range(cfg.epochs):
            order = torch.randperm(total, generator=generator)
            for start in range(0, batch * cfg.minibatches, batch):
                idx = order[start : start + batch]
                dist = self._distribution(obs_t[idx])
                logp = dist.log_prob(act_t[idx]).sum(-1)
                ratio = torch.exp(logp - logp_t[idx])
                surrogate = torch.min(
                    ratio * adv_t[idx],
                    torch.clamp(ratio, 1 - cfg.clip_ratio, 1 + cfg.clip_ratio) * adv_t[idx],
                )
                policy_loss = -surrogate.mean()
                value_loss = (self.critic(critic_t[idx]).squeeze(-1) - ret_t[idx]).pow(2).mean()
                entropy = dist.entropy().sum(-1).mean()
                loss = policy_loss + cfg.value_coef * value_loss - cfg.entropy_coef * entropy
                self.optimizer.zero_grad()
                loss.backward()
                torch.nn.utils.clip_grad_norm_(
                    [*self.actor.parameters(), *self.critic.parameters(), self.log_std], cfg.max_grad_norm
                )
                self.optimizer.step()
                with torch.no_grad():
                    kl = float((logp_t[idx] - logp).mean())
                kls.append(kl)
                policy_losses.append(float(policy_loss.detach()))
                value_losses.append(float(value_loss.detach()))
                # KL-adaptive step size (as in rsl_rl): shrink when the policy moves too far, grow when timid.
                if kl > 2.0 * cfg.desired_kl:
                    self.learning_rate = max(1e-5, self.learning_rate / 1.5)
                elif 0.0 < kl < 0.5 * cfg.desired_kl:
                    self.learning_rate = min(1e-3, self.learning_rate * 1.5)
                for group in self.optimizer.param_groups:
                    group["lr"] = self.learning_rate
        return {
            "policy_loss": float(np.mean(policy_losses)),
            "value_loss": float(np.mean(value_losses)),
            "approx_kl": float(np.mean(kls)),
            "learning_rate": self.learning_rate,
            "action_std": float(self.log_std.detach().exp().mean()),
        }

    # ------------------------------------------------------------------ loop

    def train(
        self, *, total_steps: int | None = None, max_minutes: float | None = None, verbose: bool = True
    ) -> None:
        """Train until ``total_steps`` env steps (counted across resumes) or ``max_minutes`` of this run."""
        if total_steps is None and max_minutes is None:
            raise InvalidInputError("train needs total_steps or max_minutes")
        log_path = self.out_dir / LOG_FILE
        new_log = not log_path.is_file()
        obs = self.env.reset()
        critic_obs = self.env.critic_observation()
        started = time.perf_counter()
        last_tick = started
        fields: list[str] | None = None
        with log_path.open("a", newline="") as handle:
            writer: csv.DictWriter[str] | None = None
            while True:
                obs, critic_obs, stats = self.iterate(obs, critic_obs)
                now = time.perf_counter()
                self.wall_s += now - last_tick
                last_tick = now
                row = {
                    "iteration": self.iteration,
                    "env_steps": self.env_steps,
                    "wall_s": round(self.wall_s, 1),
                }
                row.update({k: round(v, 5) for k, v in stats.items()})
                if writer is None:
                    fields = list(row)
                    writer = csv.DictWriter(handle, fieldnames=fields, extrasaction="ignore")
                    if new_log:
                        writer.writeheader()
                writer.writerow(row)
                handle.flush()
                if verbose and self.iteration % 5 == 0:
                    print(
                        f"it {self.iteration} steps {self.env_steps} wall {self.wall_s:.0f}s "
                        f"ret {stats['episode_return']:.2f} lin {stats.get('r_tracking_lin_vel', 0):.3f} "
                        f"yaw {stats.get('r_tracking_ang_vel', 0):.3f} falls/1k {stats['falls_per_1k_steps']:.2f} "
                        f"std {stats['action_std']:.3f} kl {stats['approx_kl']:.4f}",
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
    SELECTION_COMMANDS command on the nominal robot, plus 1 per fall."""
    from robots.gait_policy import load_policy
    from sims.gait_bench import SETTLE_S, _nominal_env, _run

    policy = load_policy(policy_dir)
    env = _nominal_env(len(SELECTION_COMMANDS), trot_policy=policy, seed=0)
    env.commands[:] = np.array(SELECTION_COMMANDS)
    falls, stats, _ = _run(env, policy, int(round((SETTLE_S + seconds) / 0.02)), ramp=False)
    summary = stats.summary(1.0)
    return summary["lin_vel_rms_mps"] + 0.5 * summary["yaw_rate_rms_radps"] + float(falls)


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
