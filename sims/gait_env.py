"""A vectorised Go1 locomotion environment for PPO: N (MjModel, MjData) pairs stepped in one Python loop.

MuJoCo Playground style: every constant is named once, configs are frozen dataclasses (data, not code),
the reward is a dictionary of named terms (:func:`reward_terms`, a pure function testable on hand-made
states) weighted by :class:`RewardScales`.

Each environment owns its MjModel copy so that domain randomisation (foot friction, link masses, trunk
centre of mass, motor strength) can differ per environment; latency is applied per environment by holding
the previous targets for the first ``latency_substeps`` physics steps of a control period.

One control step = 20 ms = 10 physics steps at 2 ms, the gait rate of the behaviour tree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from robots.gait_policy import (
    ACTION_DIM,
    COMMAND_HIGH,
    COMMAND_LOW,
    CONTROL_DT_S,
    OBS_DIM,
    RESIDUAL_SCALE_RAD,
    TrotConfig,
    TrotPrior,
    build_observation,
)
from robots.go1 import GO1_XML_PATH, LEG_NAMES, NUM_JOINTS, TRUNK_BODY_NAME, load_go1_spec
from semexp_bt.core.types import FloatArray, InvalidInputError

BoolArray = npt.NDArray[np.bool_]
AnyArray = npt.NDArray[Any]

#: Physics steps per control step (2 ms physics, 20 ms control).
PHYSICS_DT_S = 0.002
SUBSTEPS = int(round(CONTROL_DT_S / PHYSICS_DT_S))
#: Feet closer to the floor than foot radius + this count as in contact (m).
CONTACT_MARGIN_M = 0.01
#: A trunk up-vector z below cos(this) or a trunk lower than FALL_HEIGHT_M ends the episode (as the backend).
FALL_TILT_RAD = 1.0
FALL_HEIGHT_M = 0.15
#: Extra inputs of the (training-only) critic: body linear velocity (3), trunk height, friction,
#: motor strength, added trunk mass, latency.
CRITIC_EXTRA_DIM = 8
CRITIC_OBS_DIM = OBS_DIM + CRITIC_EXTRA_DIM
FLOOR_XML = '<geom name="floor" type="plane" size="0 0 0.05" contype="0" conaffinity="4"/>'


@dataclass(frozen=True)
class RewardScales:
    """Weights of the reward terms (the total is their weighted sum times the control period)."""

    tracking_lin_vel: float = 1.5
    tracking_ang_vel: float = 0.8
    lin_vel_z: float = -2.0
    ang_vel_xy: float = -0.05
    orientation: float = -5.0
    torques: float = -2e-4
    action_rate: float = -0.02
    feet_slip: float = -0.1
    feet_air_time: float = 0.2
    stand_still: float = -0.5
    #: Without these two the policy learns to crouch on saturated residuals (low and stable, but the camera
    #: drops 7 cm and the trunk nears the fall height): keep the trunk at the trot height, residuals small.
    base_height: float = -80.0
    action_magnitude: float = -0.02
    termination: float = -50.0
    #: Width of the exponential tracking kernels ((m/s)^2 and (rad/s)^2).
    tracking_sigma: float = 0.25
    #: Trunk height (m) the base-height term holds (the standing sag is 0.254 m, a trot rides slightly lower).
    target_height_m: float = 0.25


@dataclass(frozen=True)
class RandomizationConfig:
    """Domain randomisation and pushes; ``enabled=False`` gives the nominal robot (benchmarks)."""

    enabled: bool = True
    foot_friction: tuple[float, float] = (0.4, 1.1)
    link_mass_scale: tuple[float, float] = (0.9, 1.1)
    trunk_added_mass_kg: tuple[float, float] = (-0.5, 1.5)
    trunk_com_shift_m: float = 0.03
    motor_strength: tuple[float, float] = (0.85, 1.15)
    max_latency_substeps: int = SUBSTEPS
    push_interval_s: tuple[float, float] = (4.0, 8.0)
    push_speed_mps: float = 0.6
    initial_joint_noise_rad: float = 0.1


@dataclass(frozen=True)
class NoiseConfig:
    """Uniform observation noise half-widths (in the observation's own units before scaling)."""

    enabled: bool = True
    gyro_radps: float = 0.2
    gravity: float = 0.05
    joint_position_rad: float = 0.03
    joint_velocity_radps: float = 1.5


@dataclass(frozen=True)
class GaitEnvConfig:
    """Everything that defines the training task."""

    num_envs: int = 32
    episode_steps: int = 1000
    command_resample_s: float = 5.0
    zero_command_probability: float = 0.15
    residual_scale_rad: float = RESIDUAL_SCALE_RAD
    trot: TrotConfig = field(default_factory=TrotConfig)
    reward: RewardScales = field(default_factory=RewardScales)
    randomization: RandomizationConfig = field(default_factory=RandomizationConfig)
    noise: NoiseConfig = field(default_factory=NoiseConfig)

    def __post_init__(self) -> None:
        if self.num_envs < 1:
            raise InvalidInputError(f"GaitEnvConfig.num_envs must be >= 1, got {self.num_envs}")
        if self.episode_steps < 1:
            raise InvalidInputError(f"GaitEnvConfig.episode_steps must be >= 1, got {self.episode_steps}")


def reward_terms(
    *,
    command: FloatArray,
    base_lin_vel_body: FloatArray,
    base_ang_vel_body: FloatArray,
    gravity_body: FloatArray,
    torques_nm: FloatArray,
    action: FloatArray,
    last_action: FloatArray,
    foot_contact: FloatArray,
    foot_velocity_xy: FloatArray,
    first_contact: FloatArray,
    air_time_s: FloatArray,
    joint_position_rel_rad: FloatArray,
    base_height_m: FloatArray,
    tracking_sigma: float,
    target_height_m: float,
) -> dict[str, FloatArray]:
    """Unweighted reward terms ``(N,)`` from batched state (body frame; feet ``(N, 4)``/``(N, 4, 2)``).

    Tracking terms are exponential kernels (1 when perfect); the rest are squared penalties, except the
    air-time term which rewards steps longer than 0.2 s while the robot is asked to move.
    """
    moving = (np.linalg.norm(command, axis=1) > 0.05).astype(float)
    lin_error = np.sum((command[:, :2] - base_lin_vel_body[:, :2]) ** 2, axis=1)
    yaw_error = (command[:, 2] - base_ang_vel_body[:, 2]) ** 2
    return {
        "tracking_lin_vel": np.exp(-lin_error / tracking_sigma),
        "tracking_ang_vel": np.exp(-yaw_error / tracking_sigma),
        "lin_vel_z": base_lin_vel_body[:, 2] ** 2,
        "ang_vel_xy": np.sum(base_ang_vel_body[:, :2] ** 2, axis=1),
        "orientation": np.sum(gravity_body[:, :2] ** 2, axis=1),
        "torques": np.sum(torques_nm**2, axis=1),
        "action_rate": np.sum((action - last_action) ** 2, axis=1),
        "feet_slip": np.sum(foot_contact * np.sum(foot_velocity_xy**2, axis=2), axis=1),
        "feet_air_time": np.sum((air_time_s - 0.2) * first_contact, axis=1) * moving,
        "stand_still": np.sum(np.abs(joint_position_rel_rad), axis=1) * (1.0 - moving),
        "base_height": (base_height_m - target_height_m) ** 2,
        "action_magnitude": np.sum(action**2, axis=1),
    }


def _build_model() -> mujoco.MjModel:
    xml = GO1_XML_PATH.read_text().replace("<worldbody>", "<worldbody>" + FLOOR_XML, 1)
    return mujoco.MjModel.from_xml_string(xml)


class GaitEnv:
    """``num_envs`` Go1s on flat ground; ``step(actions)`` advances all of them by one control period.

    Args:
        config: the task.
        seed: seeds the environment's numpy Generator (commands, randomisation, noise, pushes).
    """

    def __init__(self, config: GaitEnvConfig | None = None, *, seed: int = 0) -> None:
        self.config = config or GaitEnvConfig()
        self.rng = np.random.default_rng(seed)
        self.spec = load_go1_spec()
        self.prior = TrotPrior(self.config.trot)
        self.num_envs = self.config.num_envs
        base = _build_model()
        self._nominal = base
        self.models = [_build_model() for _ in range(self.num_envs)]
        self.datas = [mujoco.MjData(m) for m in self.models]
        self._trunk = mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_BODY, TRUNK_BODY_NAME)
        self._feet = np.array(
            [mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_GEOM, f"{leg}_foot") for leg in LEG_NAMES]
        )
        self._home = base.key("home").qpos.copy()
        self._standing = self.spec.standing_pose_rad.copy()
        self._command_resample_steps = (
            int(round(self.config.command_resample_s / CONTROL_DT_S))
            if math.isfinite(self.config.command_resample_s)
            else 0
        )
        n = self.num_envs
        self.commands = np.zeros((n, 3))
        self.phase = np.zeros(n)
        self.last_action = np.zeros((n, ACTION_DIM))
        self.prev_targets = np.tile(self._standing, (n, 1))
        self.episode_step = np.zeros(n, dtype=np.int64)
        self.air_time = np.zeros((n, 4))
        self.last_contact = np.ones((n, 4), dtype=bool)
        self.latency = np.zeros(n, dtype=np.int64)
        self.next_push_step = np.zeros(n, dtype=np.int64)
        self.friction = np.ones(n)
        self.motor_strength = np.ones(n)
        self.trunk_added_mass = np.zeros(n)
        # Physical state read after every step.
        self.qpos = np.zeros((n, base.nq))
        self.qvel = np.zeros((n, base.nv))
        self.rotation = np.zeros((n, 3, 3))
        self.feet_pos = np.zeros((n, 4, 3))
        self.torques = np.zeros((n, NUM_JOINTS))
        self.joint_power_w = np.zeros(n)
        for i in range(n):
            self._reset_env(i)
        self._read_state()

    # ------------------------------------------------------------------ reset and randomisation

    def _randomise(self, i: int) -> None:
        cfg = self.config.randomization
        model, nominal = self.models[i], self._nominal
        model.geom_friction[:] = nominal.geom_friction
        model.body_mass[:] = nominal.body_mass
        model.body_ipos[:] = nominal.body_ipos
        model.actuator_gainprm[:] = nominal.actuator_gainprm
        model.actuator_biasprm[:] = nominal.actuator_biasprm
        model.actuator_forcerange[:] = nominal.actuator_forcerange
        if not cfg.enabled:
            self.friction[i], self.motor_strength[i], self.trunk_added_mass[i], self.latency[i] = (
                0.8,
                1.0,
                0.0,
                0,
            )
            return
        rng = self.rng
        self.friction[i] = rng.uniform(*cfg.foot_friction)
        model.geom_friction[self._feet, 0] = self.friction[i]
        model.body_mass[1:] *= rng.uniform(*cfg.link_mass_scale, size=model.nbody - 1)
        self.trunk_added_mass[i] = rng.uniform(*cfg.trunk_added_mass_kg)
        model.body_mass[self._trunk] += self.trunk_added_mass[i]
        model.body_ipos[self._trunk, :2] += rng.uniform(-cfg.trunk_com_shift_m, cfg.trunk_com_shift_m, size=2)
        strength = rng.uniform(*cfg.motor_strength)
        self.motor_strength[i] = strength
        model.actuator_gainprm[:, 0] *= strength
        model.actuator_biasprm[:, 1:3] *= strength
        model.actuator_forcerange[:] *= strength
        self.latency[i] = int(rng.integers(0, cfg.max_latency_substeps + 1))

    def _sample_commands(self, ids: npt.ArrayLike) -> None:
        ids = np.asarray(ids, dtype=int)
        count = len(ids)
        if count == 0:
            return
        commands = self.rng.uniform(COMMAND_LOW, COMMAND_HIGH, size=(count, 3))
        # Some commands along one axis only (what a planner mostly sends), some zero (stand still).
        one_axis = self.rng.random(count) < 0.3
        axis = self.rng.integers(0, 3, size=count)
        mask = np.ones((count, 3))
        mask[one_axis] = 0.0
        mask[one_axis, axis[one_axis]] = 1.0
        commands *= mask
        commands[self.rng.random(count) < self.config.zero_command_probability] = 0.0
        self.commands[ids] = commands

    def _reset_env(self, i: int) -> None:
        self._randomise(i)
        model, data = self.models[i], self.datas[i]
        mujoco.mj_resetData(model, data)
        data.qpos[:] = self._home
        yaw = self.rng.uniform(-np.pi, np.pi)
        data.qpos[3:7] = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
        noise = (
            self.config.randomization.initial_joint_noise_rad if self.config.randomization.enabled else 0.0
        )
        data.qpos[7:19] += self.rng.uniform(-noise, noise, size=NUM_JOINTS)
        data.ctrl[:] = self._standing
        mujoco.mj_forward(model, data)
        self.phase[i] = self.rng.random() if self.config.randomization.enabled else 0.0
        self.last_action[i] = 0.0
        self.prev_targets[i] = self._standing
        self.episode_step[i] = 0
        self.air_time[i] = 0.0
        self.last_contact[i] = True
        self.next_push_step[i] = self._push_delay_steps()
        if self._command_resample_steps:
            self._sample_commands(np.array([i]))

    def _push_delay_steps(self) -> int:
        low, high = self.config.randomization.push_interval_s
        return int(self.rng.uniform(low, high) / CONTROL_DT_S)

    def reset(self) -> FloatArray:
        """Reset every environment; returns the actor observations ``(N, OBS_DIM)``."""
        for i in range(self.num_envs):
            self._reset_env(i)
        self._read_state()
        return self.observe()

    # ------------------------------------------------------------------ state

    def _read_state(self) -> None:
        for i, data in enumerate(self.datas):
            self.qpos[i] = data.qpos
            self.qvel[i] = data.qvel
            self.rotation[i] = data.xmat[self._trunk].reshape(3, 3)
            self.feet_pos[i] = data.geom_xpos[self._feet]
            self.torques[i] = data.actuator_force

    @property
    def gravity_body(self) -> FloatArray:
        return -self.rotation[:, 2, :]

    @property
    def base_lin_vel_body(self) -> FloatArray:
        return np.einsum("nji,nj->ni", self.rotation, self.qvel[:, 0:3])

    @property
    def base_ang_vel_body(self) -> FloatArray:
        return self.qvel[:, 3:6].copy()

    def observe(self, *, noisy: bool = True) -> FloatArray:
        """Actor observations ``(N, OBS_DIM)`` (with observation noise when configured and ``noisy``)."""
        noise = self.config.noise
        n = self.num_envs

        def jitter(width: float, size: tuple[int, ...]) -> FloatArray:
            if not (noise.enabled and noisy):
                return np.zeros(size)
            return self.rng.uniform(-width, width, size=size)

        return build_observation(
            command=self.commands,
            gyro_radps=self.base_ang_vel_body + jitter(noise.gyro_radps, (n, 3)),
            gravity_body=self.gravity_body + jitter(noise.gravity, (n, 3)),
            joint_position_rel_rad=self.qpos[:, 7:19]
            - self._standing
            + jitter(noise.joint_position_rad, (n, 12)),
            joint_velocity_radps=self.qvel[:, 6:18] + jitter(noise.joint_velocity_radps, (n, 12)),
            last_action=self.last_action,
            phase=self.phase,
        )

    def critic_observation(self) -> FloatArray:
        """Privileged critic input ``(N, CRITIC_OBS_DIM)``: clean observation plus what only a simulator knows."""
        extra = np.column_stack(
            [
                self.base_lin_vel_body * 2.0,
                (self.qpos[:, 2] - self.spec.standing_trunk_height_m) * 10.0,
                self.friction - 0.8,
                self.motor_strength - 1.0,
                self.trunk_added_mass,
                self.latency / SUBSTEPS,
            ]
        )
        return np.concatenate([self.observe(noisy=False), extra], axis=1)

    def fallen(self) -> BoolArray:
        up_z = self.rotation[:, 2, 2]
        return (up_z < math.cos(FALL_TILT_RAD)) | (self.qpos[:, 2] < FALL_HEIGHT_M)

    # ------------------------------------------------------------------ stepping

    def push(self, ids: npt.ArrayLike, velocity_world_xy: FloatArray) -> None:
        """Add a horizontal velocity ``(len(ids), 2)`` (world frame) to the trunks of environments ``ids``."""
        for i, dv in zip(np.asarray(ids, dtype=int), np.atleast_2d(velocity_world_xy), strict=True):
            self.datas[i].qvel[0:2] += dv

    def _random_pushes(self) -> None:
        cfg = self.config.randomization
        due = np.flatnonzero(self.episode_step >= self.next_push_step)
        if not cfg.enabled or len(due) == 0:
            return
        angle = self.rng.uniform(-np.pi, np.pi, size=len(due))
        speed = self.rng.uniform(0.0, cfg.push_speed_mps, size=len(due))
        self.push(due, np.column_stack([np.cos(angle), np.sin(angle)]) * speed[:, None])
        self.next_push_step[due] = self.episode_step[due] + np.array([self._push_delay_steps() for _ in due])

    def step(self, actions: FloatArray) -> tuple[FloatArray, FloatArray, BoolArray, dict[str, AnyArray]]:
        """Advance every environment by one control period.

        Args:
            actions: ``(N, 12)`` residual actions (clipped to [-1, 1]).

        Returns:
            ``(obs, reward, done, info)``: next actor observations (of the reset state where an episode
            ended), rewards ``(N,)``, done flags ``(N,)`` and ``info`` with ``terminated`` (a fall),
            ``truncated`` (time limit), ``critic_obs``, ``terminal_critic_obs`` (before the reset),
            per-term rewards and physical figures (``base_lin_vel_body``, ``yaw_rate``, ``power_w``).
        """
        actions = np.clip(np.asarray(actions, dtype=float), -1.0, 1.0)
        if actions.shape != (self.num_envs, ACTION_DIM):
            raise InvalidInputError(
                f"actions must have shape ({self.num_envs}, {ACTION_DIM}), got {actions.shape}"
            )
        targets = (
            self.prior.joint_targets(self.phase, self.commands) + self.config.residual_scale_rad * actions
        )
        targets = np.clip(targets, self.spec.joint_lower_rad, self.spec.joint_upper_rad)
        feet_before = self.feet_pos[:, :, :2].copy()
        self._random_pushes()
        power = np.zeros(self.num_envs)
        for i, (model, data) in enumerate(zip(self.models, self.datas, strict=True)):
            delay = int(self.latency[i])
            if delay > 0:
                data.ctrl[:] = self.prev_targets[i]
                mujoco.mj_step(model, data, nstep=delay)
            data.ctrl[:] = targets[i]
            mujoco.mj_step(model, data, nstep=SUBSTEPS - delay)
            power[i] = float(np.sum(np.abs(data.actuator_force * data.qvel[6:18])))
        self.prev_targets = targets
        self._read_state()
        self.phase = (self.phase + CONTROL_DT_S * self.config.trot.frequency_hz) % 1.0
        self.episode_step += 1

        contact = self.feet_pos[:, :, 2] < self.spec.foot_radius_m + CONTACT_MARGIN_M
        first_contact = contact & ~self.last_contact
        self.air_time += CONTROL_DT_S
        foot_velocity = (self.feet_pos[:, :, :2] - feet_before) / CONTROL_DT_S
        lin_vel = self.base_lin_vel_body
        ang_vel = self.base_ang_vel_body
        terms = reward_terms(
            command=self.commands,
            base_lin_vel_body=lin_vel,
            base_ang_vel_body=ang_vel,
            gravity_body=self.gravity_body,
            torques_nm=self.torques,
            action=actions,
            last_action=self.last_action,
            foot_contact=contact.astype(float),
            foot_velocity_xy=foot_velocity,
            first_contact=first_contact.astype(float),
            air_time_s=self.air_time,
            joint_position_rel_rad=self.qpos[:, 7:19] - self._standing,
            base_height_m=self.qpos[:, 2],
            tracking_sigma=self.config.reward.tracking_sigma,
            target_height_m=self.config.reward.target_height_m,
        )
        self.air_time[contact] = 0.0
        self.last_contact = contact
        self.last_action = actions
        scales = self.config.reward
        terminated = self.fallen()
        reward = sum(getattr(scales, name) * value for name, value in terms.items())
        reward = (reward + scales.termination * terminated) * CONTROL_DT_S
        truncated = (self.episode_step >= self.config.episode_steps) & ~terminated
        done = terminated | truncated

        if self._command_resample_steps:
            resample = np.flatnonzero((self.episode_step % self._command_resample_steps) == 0)
            self._sample_commands(resample)
        info: dict[str, AnyArray] = {
            "terminated": terminated,
            "truncated": truncated,
            "base_lin_vel_body": lin_vel,
            "yaw_rate": ang_vel[:, 2].copy(),
            "power_w": power,
            **{f"reward/{name}": value for name, value in terms.items()},
        }
        if np.any(done):
            info["terminal_critic_obs"] = self.critic_observation()
            for env_id in np.flatnonzero(done):
                self._reset_env(int(env_id))
            self._read_state()
        info["critic_obs"] = self.critic_observation()
        return self.observe(), reward, done, info
