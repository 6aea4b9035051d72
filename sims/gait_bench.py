"""The gait benchmark: the trained policy beside the reference trot (the same prior with a zero residual).

Every figure runs on the nominal Go1 (no domain randomisation, no observation noise) on flat ground, in
:class:`sims.gait_env.GaitEnv` with one environment per seed or per command:

- grid tracking: a grid of constant commands; RMS error of the horizontal velocity (vector norm, body
  frame) and of the yaw rate after ``SETTLE_S``;
- random commands: per seed, ``random_minutes`` of commands redrawn every ``COMMAND_HOLD_S``; RMS errors
  outside the ``SETTLE_S`` after each change; falls (the env resets a fallen robot and counts it);
  cost of transport (mean motor power / (m g mean speed)); joint-target rate; torque saturation;
- pushes: a lateral 0.5 m/s velocity kick every ``PUSH_PERIOD_S``; recovered = no fall before the next;
- contact (what falls in missions come from): walking into a wall, a post or a low box at 0.5 and 1 m/s,
  square or at 30 degrees, and pushing on for ``RUN_IN_PUSH_S`` before backing off and turning; turning in
  place at 1 rad/s beside a wall and in a corner; walking into a wall or a bush off-centre and then
  turning in place, reversing; ramped steps between the corners of the command range; and an obstacle
  course (the training task's random boxes and command holds, nominal robot, held-out seeds).
  The figures are the cases that fell and the falls;
- inference: median wall time of the numpy actor on one observation, and of actor + trot prior.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from robots.gait_policy import (
    COMMAND_HIGH,
    COMMAND_LOW,
    CONTROL_DT_S,
    OBS_DIM,
    CommandTracking,
    GaitPolicy,
    NearFallRecovery,
    StanceHold,
    load_policy,
    ramp_command,
    walking_command,
)
from semexp_bt.core import durable
from semexp_bt.core.types import FloatArray
from sims.gait_env import GaitEnv, GaitEnvConfig, NoiseConfig, ObstacleConfig, RandomizationConfig

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
    "contact_falls": 0,
}
GRID_VX = (-0.5, 0.0, 0.5, 1.0)
GRID_VY = (-0.3, 0.0, 0.3)
GRID_WZ = (-1.0, 0.0, 1.0)
#: Contact cases: forward speeds, wall angles (rad from square), obstacles (half sizes, lateral offset).
RUN_IN_SPEEDS_MPS = (0.5, 1.0)
RUN_IN_ANGLES_RAD = (0.0, math.radians(30.0), -math.radians(30.0))
RUN_IN_OBSTACLES = {
    "wall": ((0.1, 1.5, 0.5), 0.0),
    "post": ((0.1, 0.1, 0.4), 0.12),
    "low_box": ((0.15, 0.4, 0.06), 0.0),
}
#: Trunk centre to the obstacle's near face at the start (m).
RUN_IN_DISTANCE_M = 1.0
#: Seconds of the forward command (it reaches the obstacle after about half of it, then pushes on).
RUN_IN_PUSH_S = 6.0
#: Turn-in-place cases: trunk centre line to the side wall's face (m); turn seconds per direction.
TURN_GAPS_M = (0.2, 0.3)
TURN_S = 8.0
#: Bump-and-turn cases: walk at BUMP_SPEED_MPS into an obstacle (half sizes, yaw) placed off-centre, then
#: turn in place at 1 rad/s, reversing every BUMP_TURN_S.
BUMP_OBSTACLES = {
    "wall": ((0.1, 1.5, 0.6), 0.0),
    "bush": ((0.32, 0.32, 0.45), math.pi / 4.0),
}
BUMP_OFFSETS_M = (-0.2, 0.0, 0.2)
BUMP_DISTANCE_M = 0.6
BUMP_SPEED_MPS = 0.6
BUMP_WALK_S = 3.0
BUMP_TURN_S = 0.8
BUMP_REVERSALS = 6
#: Obstacle course: env seeds start here (training seeds are small), minutes per seed.
COURSE_SEED_OFFSET = 10_000
COURSE_MINUTES = 2.0
#: Command steps: commands held this long, envs, steps per env.
STEP_HOLD_S = 1.5
STEP_ENVS = 10
STEP_COUNT = 16


def _nominal_env(num_envs: int, *, trot_policy: GaitPolicy, seed: int) -> GaitEnv:
    config = GaitEnvConfig(
        num_envs=num_envs,
        episode_steps=10**9,
        command_resample_s=math.inf,
        trot=trot_policy.config.trot,
        residual_scale_rad=trot_policy.config.residual_scale_rad,
        randomization=RandomizationConfig(enabled=False),
        noise=NoiseConfig(enabled=False),
        obstacles=ObstacleConfig(enabled=False),
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
    env: GaitEnv,
    policy: GaitPolicy,
    steps: int,
    on_step: Any = None,
    *,
    ramp: bool = True,
    recovery: bool = True,
) -> tuple[int, _Stats, FloatArray]:
    """Step ``env`` under ``policy`` for ``steps``; ``on_step(k, env)`` may change commands or push.

    With ``ramp`` every step is :class:`GaitController`'s: the commands are ramped, the trot is gated at
    its walking deadband, the command tracking corrects what the policy is told (:class:`CommandTracking`),
    the stance hold fades the residual at a zero command (:class:`StanceHold`), and with ``recovery`` the
    commands are also held at zero through near falls (:class:`NearFallRecovery`). Without ``ramp``, the
    policy as trained: raw commands, the prior's own gate."""
    stats = _Stats()
    falls = np.zeros(env.num_envs, dtype=int)
    obs = env.observe(noisy=False)
    since_change = np.zeros(env.num_envs)
    # The on_step hooks write the requested command into env.commands; the policy sees it ramped, as
    # GaitController ramps it, and errors are measured against the request.
    requested = env.commands.copy()
    ramped = np.zeros_like(requested) if ramp else requested
    near_fall = NearFallRecovery(env.num_envs)
    stance = StanceHold(env.num_envs)
    tracking = CommandTracking(env.num_envs)
    share = np.ones(env.num_envs)
    gate: FloatArray | None = None
    for k in range(steps):
        if on_step is not None:
            env.commands[:] = requested
            changed = on_step(k, env)
            if changed is not None:
                since_change[changed] = 0.0
            requested = env.commands.copy()
        if ramp:
            # As GaitController: a near fall holds the command at zero, then the ramp.
            holding = near_fall.update(env.gravity_body) if recovery else np.zeros(env.num_envs, dtype=bool)
            asked = np.where(holding[:, None], 0.0, requested)
            ramped = ramp_command(ramped, asked)
            measured = np.concatenate([env.base_lin_vel_body[:, :2], env.base_ang_vel_body[:, 2:]], axis=1)
            env.commands[:], gate = walking_command(policy.prior, tracking, ramped, measured, holding)
            share = stance.update((gate <= 0.0) & ~holding)
            obs = env.observe(noisy=False)
        elif on_step is not None:
            obs = env.observe(noisy=False)
        before = env.prev_targets.copy()
        _, _, done, info = env.step(share[:, None] * policy.actor(obs), trot_gate=gate)
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

    def counting_step(actions: FloatArray, *, trot_gate: FloatArray | None = None) -> Any:
        result = original_step(actions, trot_gate=trot_gate)
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


def _obstacle_env(policy: GaitPolicy, cases: int) -> GaitEnv:
    env = _nominal_env(cases, trot_policy=policy, seed=0)
    for i in range(cases):
        # Every robot faces +x from its spawn point (the nominal env spawns at a random yaw).
        data = env.datas[i]
        data.qpos[3:7] = [1.0, 0.0, 0.0, 0.0]
        data.qvel[:] = 0.0
        mujoco.mj_forward(env.models[i], data)
    env._read_state()
    return env


def _fell(env: GaitEnv, policy: GaitPolicy, steps: int, on_step: Any, *, recovery: bool = True) -> FloatArray:
    """Per-env falls over ``steps`` (a fallen robot is reset and moved away: its first fall is the count)."""
    _, _, per_env = _run(env, policy, steps, on_step, recovery=recovery)
    return per_env


def _cases_fell(names: list[str], per_env: FloatArray) -> dict[str, Any]:
    """How many cases (one per env, named) fell, and which."""
    return {
        "cases": len(names),
        "fell": int(np.sum(per_env > 0)),
        "fell_cases": [name for name, falls in zip(names, per_env, strict=True) if falls],
    }


def _run_in(
    policy: GaitPolicy,
    *,
    speeds: tuple[float, ...] = RUN_IN_SPEEDS_MPS,
    angles: tuple[float, ...] = RUN_IN_ANGLES_RAD,
    recovery: bool = True,
) -> dict[str, Any]:
    """Walk into each obstacle at each speed and angle, push on, back off, turn; count the cases that fell."""
    cases = [(name, speed, angle) for name in RUN_IN_OBSTACLES for speed in speeds for angle in angles]
    env = _obstacle_env(policy, len(cases))
    for i, (name, _, angle) in enumerate(cases):
        half, lateral = RUN_IN_OBSTACLES[name]
        x, y = env.datas[i].qpos[0:2]
        centre = np.array([x + RUN_IN_DISTANCE_M + half[0], y + lateral])
        env.place_obstacle(i, 0, centre, angle, half)
    case_speeds = np.array([speed for _, speed, _ in cases])
    forward, back, turn = (int(round(s / CONTROL_DT_S)) for s in (RUN_IN_PUSH_S, 2.0, 2.0))

    def script(k: int, env: GaitEnv) -> None:
        if k < forward:
            env.commands[:] = np.column_stack([case_speeds, np.zeros((len(cases), 2))])
        elif k < forward + back:
            env.commands[:] = [-0.3, 0.0, 0.0]
        else:
            env.commands[:] = [0.0, 0.0, 1.0]

    per_env = _fell(env, policy, forward + back + turn, script, recovery=recovery)
    return _cases_fell([f"{n} {s} m/s {math.degrees(a):.0f} deg" for n, s, a in cases], per_env)


def _turn_beside(policy: GaitPolicy) -> dict[str, Any]:
    cases = [
        (layout, gap, rate) for layout in ("side", "corner") for gap in TURN_GAPS_M for rate in (1.0, -1.0)
    ]
    env = _obstacle_env(policy, len(cases))
    wall = (1.0, 0.1, 0.5)
    for i, (layout, gap, _) in enumerate(cases):
        x, y = env.datas[i].qpos[0:2]
        env.place_obstacle(i, 0, np.array([x, y + gap + wall[1]]), 0.0, wall)
        if layout == "corner":
            env.place_obstacle(i, 1, np.array([x + 0.4 + wall[1], y]), math.pi / 2.0, wall)
    rates = np.array([rate for _, _, rate in cases])
    steps = int(round(TURN_S / CONTROL_DT_S))

    def script(k: int, env: GaitEnv) -> None:
        env.commands[:] = np.column_stack([np.zeros((len(cases), 2)), rates])

    per_env = _fell(env, policy, steps, script)
    return _cases_fell([f"{lay} gap {g} m, {r:+.0f} rad/s" for lay, g, r in cases], per_env)


def _bump_and_turn(policy: GaitPolicy) -> dict[str, Any]:
    """Walk into an obstacle off-centre, then turn in place, reversing every BUMP_TURN_S (a stuck
    planner's spin, as in garden_real's fall), walk on into it, and turn again."""
    cases = [
        (name, offset, rate) for name in BUMP_OBSTACLES for offset in BUMP_OFFSETS_M for rate in (1.0, -1.0)
    ]
    env = _obstacle_env(policy, len(cases))
    for i, (name, offset, _) in enumerate(cases):
        half, yaw = BUMP_OBSTACLES[name]
        x, y = env.datas[i].qpos[0:2]
        env.place_obstacle(i, 0, np.array([x + BUMP_DISTANCE_M + half[0], y + offset]), yaw, half)
    rates = np.array([rate for _, _, rate in cases])
    walk, turn = (int(round(s / CONTROL_DT_S)) for s in (BUMP_WALK_S, BUMP_TURN_S))

    spin = walk + BUMP_REVERSALS * turn

    def script(k: int, env: GaitEnv) -> None:
        zeros = np.zeros(len(cases))
        forward = np.column_stack([np.full(len(cases), BUMP_SPEED_MPS), zeros, zeros])
        if k < walk or spin <= k < spin + walk // 2:
            env.commands[:] = forward
        else:
            sign = 1.0 if ((k - walk) // turn) % 2 == 0 else -1.0
            env.commands[:] = np.column_stack([zeros, zeros, sign * rates])

    per_env = _fell(env, policy, spin + walk // 2 + 2 * turn, script)
    return _cases_fell([f"{n} offset {o:+.2f} m, {r:+.0f} rad/s" for n, o, r in cases], per_env)


def _obstacle_course(policy: GaitPolicy, *, seeds: int, minutes: float, seed: int) -> dict[str, Any]:
    """The training task's obstacle layouts and command schedule (holds of 0.5-5 s), on the nominal robot,
    at seeds training never used: falls and the share of steps in contact."""
    config = GaitEnvConfig(
        num_envs=seeds,
        episode_steps=10**9,
        ramp_commands=False,  # _run ramps (and recovers) as GaitController does
        trot=policy.config.trot,
        residual_scale_rad=policy.config.residual_scale_rad,
        randomization=RandomizationConfig(enabled=False),
        noise=NoiseConfig(enabled=False),
    )
    env = GaitEnv(config, seed=COURSE_SEED_OFFSET + seed)
    contact_steps = np.zeros(seeds)
    original_step = env.step

    def counting_step(actions: FloatArray, *, trot_gate: FloatArray | None = None) -> Any:
        result = original_step(actions, trot_gate=trot_gate)
        contact_steps[:] += result[3]["contact_force_n"] > 1.0
        return result

    def follow(k: int, env: GaitEnv) -> None:
        env.commands[:] = env.command_targets

    env.step = counting_step  # type: ignore[method-assign]
    steps = int(round(minutes * 60.0 / CONTROL_DT_S))
    _, _, per_env = _run(env, policy, steps, follow)
    return {
        "seeds": seeds,
        "minutes_per_seed": minutes,
        "falls": int(per_env.sum()),
        "falls_per_seed": per_env.tolist(),
        "contact_share": float(contact_steps.sum() / (seeds * steps)),
    }


def _command_steps(policy: GaitPolicy, *, seed: int) -> dict[str, Any]:
    rng = np.random.default_rng(seed + 2)
    corners = np.array(
        [[vx, vy, wz] for vx in (-0.5, 0.0, 1.0) for vy in (-0.3, 0.0, 0.3) for wz in (-1.0, 0.0, 1.0)]
    )
    sequence = corners[rng.integers(0, len(corners), size=(STEP_COUNT, STEP_ENVS))]
    env = _nominal_env(STEP_ENVS, trot_policy=policy, seed=seed + 2)
    hold = int(round(STEP_HOLD_S / CONTROL_DT_S))

    def script(k: int, env: GaitEnv) -> None:
        env.commands[:] = sequence[min(k // hold, STEP_COUNT - 1)]

    _, _, per_env = _run(env, policy, hold * STEP_COUNT, script)
    return {"envs": STEP_ENVS, "steps_per_env": STEP_COUNT, "falls": int(per_env.sum())}


def _contact(policy: GaitPolicy, *, seeds: int, quick: bool, seed: int) -> dict[str, Any]:
    run_in, turn, bump = _run_in(policy), _turn_beside(policy), _bump_and_turn(policy)
    steps = _command_steps(policy, seed=seed)
    course = _obstacle_course(policy, seeds=seeds, minutes=0.5 if quick else COURSE_MINUTES, seed=seed)
    return {
        "run_in": run_in,
        "turn_beside": turn,
        "bump_and_turn": bump,
        "command_steps": steps,
        "obstacle_course": course,
        "run_in_fell": run_in["fell"],
        "turn_beside_fell": turn["fell"],
        "bump_and_turn_fell": bump["fell"],
        "command_step_falls": steps["falls"],
        "course_falls": course["falls"],
        "falls": run_in["fell"] + turn["fell"] + bump["fell"] + steps["falls"] + course["falls"],
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


def bench_one(
    policy: GaitPolicy, *, seeds: int, quick: bool, seed: int, contact: bool = True
) -> dict[str, Any]:
    """Every figure for one gait (the contact section only with ``contact``)."""
    minutes = 0.5 if quick else 10.0
    result = {
        "grid": _grid(policy, quick=quick, seed=seed),
        "random_commands": _random(policy, seeds=seeds, minutes=minutes, seed=seed),
        "pushes": _pushes(policy, seeds=seeds, pushes_per_seed=3 if quick else 10, seed=seed),
        "inference": _inference(policy, 200 if quick else 2000),
    }
    if contact:
        result["contact"] = _contact(policy, seeds=seeds, quick=quick, seed=seed)
    return result


def floors_met(result: dict[str, Any]) -> dict[str, bool]:
    """The issue's floors checked on one gait's figures (the random-command run is the tracking figure)."""
    random = result["random_commands"]
    met = {
        "lin_vel_rms": random["lin_vel_rms_mps"] <= FLOORS["lin_vel_rms_mps"],
        "yaw_rate_rms": random["yaw_rate_rms_radps"] <= FLOORS["yaw_rate_rms_radps"],
        "no_falls": random["falls"] <= FLOORS["falls"],
        "push_recovery": result["pushes"]["push_recovery_rate"] >= FLOORS["push_recovery_rate"],
        "inference": result["inference"]["inference_ms"] < FLOORS["inference_ms"],
    }
    if "contact" in result:
        met["no_contact_falls"] = result["contact"]["falls"] <= FLOORS["contact_falls"]
    return met


def run_gait_bench(
    *,
    checkpoint: Path | str | None = None,
    seeds: int = 10,
    quick: bool = False,
    seed: int = 0,
    contact_only: bool = False,
) -> dict[str, Any]:
    """Benchmark the policy (shipped checkpoint when None) and the reference trot; returns the JSON record.

    ``contact_only``: only the policy's contact section (to compare checkpoints under contact quickly).
    """
    policy = load_policy(checkpoint)
    reference = GaitPolicy.reference(policy.config.trot)
    started = time.perf_counter()
    header = {
        "checkpoint": str(checkpoint) if checkpoint is not None else "robots/gait_checkpoints",
        "checkpoint_info": policy.config.info,
        "seeds": seeds,
        "quick": quick,
        "seed": seed,
        "floors": FLOORS,
    }
    if contact_only:
        contact = {"contact": _contact(policy, seeds=seeds, quick=quick, seed=seed)}
        return {
            "kind": "gait_contact",
            **header,
            "gaits": {"policy": contact, "reference": {}},
            "floors_met": {"no_contact_falls": contact["contact"]["falls"] <= FLOORS["contact_falls"]},
            "wall_s": round(time.perf_counter() - started, 1),
        }
    gaits = {
        "policy": bench_one(policy, seeds=seeds, quick=quick, seed=seed),
        # The reference trot falls on open ground already: the contact section is the policy's only.
        "reference": bench_one(reference, seeds=seeds, quick=quick, seed=seed, contact=False),
    }
    return {
        "kind": "gait",
        **header,
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
    ("contact: run-in cases fell", "contact", "run_in_fell", "{}"),
    ("contact: turn-beside cases fell", "contact", "turn_beside_fell", "{}"),
    ("contact: bump-and-turn cases fell", "contact", "bump_and_turn_fell", "{}"),
    ("contact: command-step falls", "contact", "command_step_falls", "{}"),
    ("contact: obstacle-course falls", "contact", "course_falls", "{}"),
    ("inference (ms)", "inference", "inference_ms", "{:.3f}"),
    ("inference + prior (ms)", "inference", "inference_with_prior_ms", "{:.3f}"),
)


def format_table(result: dict[str, Any]) -> str:
    """A plain-text table: one row per figure, policy beside reference."""
    lines = [f"{'figure':34s} {'policy':>10s} {'reference':>10s}"]
    for label, section, key, fmt in ROWS:
        cells = [
            fmt.format(result["gaits"][g][section][key]) if section in result["gaits"][g] else "-"
            for g in ("policy", "reference")
        ]
        lines.append(f"{label:34s} {cells[0]:>10s} {cells[1]:>10s}")
    met = ", ".join(f"{k}={'yes' if v else 'NO'}" for k, v in result["floors_met"].items())
    lines.append(f"policy floors: {met}")
    policy = result["gaits"]["policy"]
    if "random_commands" in policy:
        minutes = policy["random_commands"]["minutes_per_seed"]
        lines.append(f"seeds={result['seeds']} x {minutes} min random commands; wall {result['wall_s']} s")
    if "contact" in policy:
        course = policy["contact"]["obstacle_course"]
        fell = [
            c for k in ("run_in", "turn_beside", "bump_and_turn") for c in policy["contact"][k]["fell_cases"]
        ]
        lines.append(
            f"obstacle course: {course['seeds']} x {course['minutes_per_seed']} min, "
            f"{course['contact_share']:.0%} of steps in contact; cases that fell: {', '.join(fell) or 'none'}"
        )
    return "\n".join(lines)


def write_json(result: dict[str, Any], path: Path) -> None:
    """Write the benchmark's figures to ``path`` as JSON, whole or not at all."""
    durable.write_json(path, result, indent=2)
