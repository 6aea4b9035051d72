"""The gait benchmark: the trained policy beside the reference trot (the same prior with a zero residual).

Every figure runs on the nominal Go1 (no domain randomisation, no observation noise) on flat ground, in
:class:`sims.gait_env.GaitEnv` with one environment per seed or per command:

- grid tracking: a grid of constant commands; RMS error of the horizontal velocity (vector norm, body
  frame) and of the yaw rate after ``SETTLE_S``;
- random commands: per seed, ``random_minutes`` of commands redrawn every ``COMMAND_HOLD_S``; RMS errors
  outside the ``SETTLE_S`` after each change; falls (the env resets a fallen robot and counts it);
  cost of transport (mean motor power / (m g mean speed)); joint-target rate; torque saturation;
- pushes: a lateral 0.5 m/s velocity kick every ``PUSH_PERIOD_S``; recovered = no fall before the next;
- inference: median wall time of the numpy actor on one observation, and of actor + trot prior.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from robots.gait_policy import (
    COMMAND_HIGH,
    COMMAND_LOW,
    CONTROL_DT_S,
    OBS_DIM,
    GaitPolicy,
    load_policy,
    ramp_command,
)
from semexp_bt.core import durable
from semexp_bt.core.types import FloatArray
from sims.gait_env import GaitEnv, GaitEnvConfig, NoiseConfig, RandomizationConfig

SETTLE_S = 1.5
COMMAND_HOLD_S = 4.0
PUSH_PERIOD_S = 4.0
PUSH_SPEED_MPS = 0.5
GRAVITY_MPS2 = 9.81
FLOORS = {
    "lin_vel_rms_mps": 0.15,
    "yaw_rate_rms_radps": 0.3,
    "falls": 0,
    "push_recovery_rate": 0.9,
    "inference_ms": 0.5,
}
GRID_VX = (-0.5, 0.0, 0.5, 1.0)
GRID_VY = (-0.3, 0.0, 0.3)
GRID_WZ = (-1.0, 0.0, 1.0)


def _nominal_env(num_envs: int, *, trot_policy: GaitPolicy, seed: int) -> GaitEnv:
    config = GaitEnvConfig(
        num_envs=num_envs,
        episode_steps=10**9,
        command_resample_s=math.inf,
        trot=trot_policy.config.trot,
        residual_scale_rad=trot_policy.config.residual_scale_rad,
        randomization=RandomizationConfig(enabled=False),
        noise=NoiseConfig(enabled=False),
    )
    return GaitEnv(config, seed=seed)


def _random_commands(rng: np.random.Generator, count: int) -> FloatArray:
    commands = rng.uniform(COMMAND_LOW, COMMAND_HIGH, size=(count, 3))
    commands[rng.random(count) < 0.1] = 0.0
    return commands


class _Stats:
    """Accumulates squared tracking errors, power, speed and target rates over measured steps."""

    def __init__(self) -> None:
        self.lin_sq: list[float] = []
        self.yaw_sq: list[float] = []
        self.power_w: list[float] = []
        self.speed_mps: list[float] = []
        self.target_rate: list[float] = []
        self.saturation: list[float] = []
        self.height_m: list[float] = []

    def add(
        self,
        env: GaitEnv,
        info: dict[str, npt.NDArray[Any]],
        measured: npt.NDArray[np.bool_],
        target_step: FloatArray,
    ) -> None:
        if not np.any(measured):
            return
        lin_err = env.commands[:, :2] - info["base_lin_vel_body"][:, :2]
        self.lin_sq.extend(np.sum(lin_err**2, axis=1)[measured])
        self.yaw_sq.extend(((env.commands[:, 2] - info["yaw_rate"]) ** 2)[measured])
        self.power_w.extend(info["power_w"][measured])
        self.speed_mps.extend(np.linalg.norm(info["base_lin_vel_body"][:, :2], axis=1)[measured])
        self.target_rate.extend(np.mean(np.abs(target_step), axis=1)[measured] / CONTROL_DT_S)
        self.height_m.extend(env.qpos[:, 2][measured])
        limits = env.spec.torque_limit_nm
        self.saturation.extend(np.mean(np.abs(env.torques) > 0.99 * limits, axis=1)[measured])

    def summary(self, mass_kg: float) -> dict[str, float]:
        speed = float(np.mean(self.speed_mps)) if self.speed_mps else math.nan
        return {
            "lin_vel_rms_mps": float(np.sqrt(np.mean(self.lin_sq))),
            "yaw_rate_rms_radps": float(np.sqrt(np.mean(self.yaw_sq))),
            "cost_of_transport": float(np.mean(self.power_w) / (mass_kg * GRAVITY_MPS2 * max(speed, 1e-6))),
            "mean_speed_mps": speed,
            "joint_target_rate_radps": float(np.mean(self.target_rate)),
            "torque_saturation_fraction": float(np.mean(self.saturation)),
            "mean_trunk_height_m": float(np.mean(self.height_m)),
        }


def _run(
    env: GaitEnv, policy: GaitPolicy, steps: int, on_step: Any = None, *, ramp: bool = True
) -> tuple[int, _Stats, FloatArray]:
    """Step ``env`` under ``policy`` for ``steps``; ``on_step(k, env)`` may change commands or push."""
    stats = _Stats()
    falls = np.zeros(env.num_envs, dtype=int)
    obs = env.observe(noisy=False)
    since_change = np.zeros(env.num_envs)
    # The on_step hooks write the requested command into env.commands; the policy sees it ramped, as
    # GaitController ramps it, and errors are measured against the request.
    requested = env.commands.copy()
    ramped = np.zeros_like(requested) if ramp else requested
    for k in range(steps):
        if on_step is not None:
            env.commands[:] = requested
            changed = on_step(k, env)
            if changed is not None:
                since_change[changed] = 0.0
            requested = env.commands.copy()
        if ramp:
            ramped = ramp_command(ramped, requested)
            env.commands[:] = ramped
            obs = env.observe(noisy=False)
        elif on_step is not None:
            obs = env.observe(noisy=False)
        before = env.prev_targets.copy()
        _, _, done, info = env.step(policy.actor(obs))
        obs = env.observe(noisy=False)
        since_change += CONTROL_DT_S
        falls += info["terminated"].astype(int)
        measured = (since_change > SETTLE_S) & ~done
        env.commands[:] = requested
        stats.add(env, info, measured, env.prev_targets - before)
    return int(falls.sum()), stats, falls


def _grid(policy: GaitPolicy, *, quick: bool, seed: int) -> dict[str, Any]:
    vxs, vys, wzs = ((0.0, 0.5), (0.0,), (0.0, 1.0)) if quick else (GRID_VX, GRID_VY, GRID_WZ)
    commands = np.array([[vx, vy, wz] for vx in vxs for vy in vys for wz in wzs])
    env = _nominal_env(len(commands), trot_policy=policy, seed=seed)
    env.commands[:] = commands
    steps = int(round((SETTLE_S + (1.5 if quick else 4.0)) / CONTROL_DT_S))
    falls, stats, _ = _run(env, policy, steps)
    result = stats.summary(_mass(env))
    result["falls"] = falls
    result["commands"] = len(commands)
    return result


def _mass(env: GaitEnv) -> float:
    return float(np.sum(env.models[0].body_mass))


def _random(policy: GaitPolicy, *, seeds: int, minutes: float, seed: int) -> dict[str, Any]:
    env = _nominal_env(seeds, trot_policy=policy, seed=seed)
    rng = np.random.default_rng(seed)
    hold = int(round(COMMAND_HOLD_S / CONTROL_DT_S))

    def change(k: int, env: GaitEnv) -> npt.NDArray[Any] | None:
        if k % hold:
            return None
        env.commands[:] = _random_commands(rng, env.num_envs)
        return np.arange(env.num_envs)

    steps = int(round(minutes * 60.0 / CONTROL_DT_S))
    falls, stats, per_seed = _run(env, policy, steps, change)
    result = stats.summary(_mass(env))
    result.update(
        {"falls": falls, "falls_per_seed": per_seed.tolist(), "seeds": seeds, "minutes_per_seed": minutes}
    )
    return result


def _pushes(policy: GaitPolicy, *, seeds: int, pushes_per_seed: int, seed: int) -> dict[str, Any]:
    env = _nominal_env(seeds, trot_policy=policy, seed=seed + 1)
    rng = np.random.default_rng(seed + 1)
    period = int(round(PUSH_PERIOD_S / CONTROL_DT_S))
    outcomes: list[bool] = []
    falls_at_push = np.zeros(seeds, dtype=int)
    falls_total = np.zeros(seeds, dtype=int)

    def push(k: int, env: GaitEnv) -> npt.NDArray[Any] | None:
        if k % period != period // 2:
            return None
        if k > period:
            outcomes.extend((falls_total == falls_at_push).tolist())
        falls_at_push[:] = falls_total
        env.commands[:] = _random_commands(rng, env.num_envs) * (rng.random((env.num_envs, 1)) < 0.7)
        yaw = np.array([2.0 * math.atan2(d.qpos[6], d.qpos[3]) for d in env.datas])
        side = rng.choice([-1.0, 1.0], size=env.num_envs)
        lateral = np.column_stack([-np.sin(yaw), np.cos(yaw)]) * (side * PUSH_SPEED_MPS)[:, None]
        env.push(np.arange(env.num_envs), lateral)
        return None

    original_step = env.step

    def counting_step(actions: FloatArray) -> Any:
        result = original_step(actions)
        falls_total[:] += result[3]["terminated"].astype(int)
        return result

    env.step = counting_step  # type: ignore[method-assign]
    _run(env, policy, period * (pushes_per_seed + 1), push)
    outcomes.extend((falls_total == falls_at_push).tolist())
    return {
        "pushes": len(outcomes),
        "recovered": int(np.sum(outcomes)),
        "push_recovery_rate": float(np.mean(outcomes)) if outcomes else math.nan,
        "push_speed_mps": PUSH_SPEED_MPS,
    }


def _inference(policy: GaitPolicy, repeats: int) -> dict[str, float]:
    rng = np.random.default_rng(0)
    obs = rng.normal(size=(1, OBS_DIM))
    command = np.array([[0.5, 0.0, 0.2]])
    actor_s, full_s = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        action = policy.actor(obs)
        middle = time.perf_counter()
        policy.joint_targets(np.array([0.3]), command, action)
        end = time.perf_counter()
        actor_s.append(middle - start)
        full_s.append(end - start)
    return {
        "inference_ms": float(np.median(actor_s) * 1e3),
        "inference_with_prior_ms": float(np.median(full_s) * 1e3),
    }


def bench_one(policy: GaitPolicy, *, seeds: int, quick: bool, seed: int) -> dict[str, Any]:
    """Every figure for one gait."""
    minutes = 0.5 if quick else 10.0
    return {
        "grid": _grid(policy, quick=quick, seed=seed),
        "random_commands": _random(policy, seeds=seeds, minutes=minutes, seed=seed),
        "pushes": _pushes(policy, seeds=seeds, pushes_per_seed=3 if quick else 10, seed=seed),
        "inference": _inference(policy, 200 if quick else 2000),
    }


def floors_met(result: dict[str, Any]) -> dict[str, bool]:
    """The issue's floors checked on one gait's figures (the random-command run is the tracking figure)."""
    random = result["random_commands"]
    return {
        "lin_vel_rms": random["lin_vel_rms_mps"] <= FLOORS["lin_vel_rms_mps"],
        "yaw_rate_rms": random["yaw_rate_rms_radps"] <= FLOORS["yaw_rate_rms_radps"],
        "no_falls": random["falls"] <= FLOORS["falls"],
        "push_recovery": result["pushes"]["push_recovery_rate"] >= FLOORS["push_recovery_rate"],
        "inference": result["inference"]["inference_ms"] < FLOORS["inference_ms"],
    }


def run_gait_bench(
    *, checkpoint: Path | str | None = None, seeds: int = 10, quick: bool = False, seed: int = 0
) -> dict[str, Any]:
    """Benchmark the policy (shipped checkpoint when None) and the reference trot; returns the JSON record."""
    policy = load_policy(checkpoint)
    reference = GaitPolicy.reference(policy.config.trot)
    started = time.perf_counter()
    gaits = {
        "policy": bench_one(policy, seeds=seeds, quick=quick, seed=seed),
        "reference": bench_one(reference, seeds=seeds, quick=quick, seed=seed),
    }
    return {
        "kind": "gait",
        "checkpoint": str(checkpoint) if checkpoint is not None else "robots/gait_checkpoints",
        "checkpoint_info": policy.config.info,
        "seeds": seeds,
        "quick": quick,
        "seed": seed,
        "floors": FLOORS,
        "gaits": gaits,
        "floors_met": floors_met(gaits["policy"]),
        "reference_floors_met": floors_met(gaits["reference"]),
        "wall_s": round(time.perf_counter() - started, 1),
    }


ROWS = (
    ("grid lin-vel RMS (m/s)", "grid", "lin_vel_rms_mps", "{:.3f}"),
    ("grid yaw-rate RMS (rad/s)", "grid", "yaw_rate_rms_radps", "{:.3f}"),
    ("grid falls", "grid", "falls", "{}"),
    ("random lin-vel RMS (m/s)", "random_commands", "lin_vel_rms_mps", "{:.3f}"),
    ("random yaw-rate RMS (rad/s)", "random_commands", "yaw_rate_rms_radps", "{:.3f}"),
    ("random falls (all seeds)", "random_commands", "falls", "{}"),
    ("cost of transport", "random_commands", "cost_of_transport", "{:.2f}"),
    ("joint-target rate (rad/s)", "random_commands", "joint_target_rate_radps", "{:.2f}"),
    ("torque saturation", "random_commands", "torque_saturation_fraction", "{:.3f}"),
    ("mean trunk height (m)", "random_commands", "mean_trunk_height_m", "{:.3f}"),
    ("pushes recovered", "pushes", "push_recovery_rate", "{:.2f}"),
    ("inference (ms)", "inference", "inference_ms", "{:.3f}"),
    ("inference + prior (ms)", "inference", "inference_with_prior_ms", "{:.3f}"),
)


def format_table(result: dict[str, Any]) -> str:
    """A plain-text table: one row per figure, policy beside reference."""
    lines = [f"{'figure':30s} {'policy':>10s} {'reference':>10s}"]
    for label, section, key, fmt in ROWS:
        cells = [fmt.format(result["gaits"][g][section][key]) for g in ("policy", "reference")]
        lines.append(f"{label:30s} {cells[0]:>10s} {cells[1]:>10s}")
    met = ", ".join(f"{k}={'yes' if v else 'NO'}" for k, v in result["floors_met"].items())
    lines.append(f"policy floors: {met}")
    minutes = result["gaits"]["policy"]["random_commands"]["minutes_per_seed"]
    lines.append(f"seeds={result['seeds']} x {minutes} min random commands; wall {result['wall_s']} s")
    return "\n".join(lines)


def write_json(result: dict[str, Any], path: Path) -> None:
    """Write the benchmark's figures to ``path`` as JSON, whole or not at all."""
    durable.write_json(path, result, indent=2)
