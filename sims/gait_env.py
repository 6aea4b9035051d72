"""A vectorised Go1 locomotion environment for PPO: N (MjModel, MjData) pairs stepped in one Python loop.

MuJoCo Playground style: every constant is named once, configs are frozen dataclasses (data, not code),
the reward is a dictionary of named terms (:func:`reward_terms`, a pure function testable on hand-made
states) weighted by :class:`RewardScales`.

Each environment owns its MjModel copy so that domain randomisation (foot friction, link masses, trunk
centre of mass, motor strength) can differ per environment; latency is applied per environment by holding
the previous targets for the first ``latency_substeps`` physics steps of a control period.

Obstacles (:class:`ObstacleConfig`): each environment has ``OBSTACLE_SLOTS`` mocap boxes. At every command
change they are laid out around the robot as what a mission does to it: a box or wall in the commanded
path at 0.4-1.5 m (it walks into it at speed and keeps pushing), a long box beside the trunk (a turn in
place sweeps the trunk's corners into it) and a loose box nearby; sizes, yaw and friction are random, and
a layout that would start in penetration is not used. Unused slots are parked far below the floor.

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
    ramp_command,
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
#: motor strength, added trunk mass, latency, obstacle contact force on the robot.
CRITIC_EXTRA_DIM = 9
CRITIC_OBS_DIM = OBS_DIM + CRITIC_EXTRA_DIM
FLOOR_XML = '<geom name="floor" type="plane" size="0 0 0.05" contype="0" conaffinity="4"/>'
#: Mocap obstacle boxes per environment: in the path, beside the trunk, loose.
OBSTACLE_SLOTS = 3
OBSTACLE_NAME = "gait_obstacle{}"
#: Where an unused obstacle waits (far below the floor: it touches nothing).
PARKED_OBSTACLE_POS = (0.0, 0.0, -50.0)
#: A layout whose obstacle comes closer than this to any robot geom is not used (m).
OBSTACLE_MIN_GAP_M = 0.03
#: Contact force scale in the critic input (N).
CONTACT_FORCE_SCALE_N = 100.0


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
class ObstacleConfig:
    """Boxes the robot bumps into (see the module docstring); ``enabled=False`` gives open flat ground.

    Attributes:
        probability: share of command segments that get a layout (the others are on open ground).
        path_distance_m: trunk centre to the near face of the box in the commanded path.
        path_half_width_m: that box's half width across the path (0.15: a post; 1.2: a wall).
        path_half_depth_m: its half depth along the path.
        half_height_m: half height of a tall box (0.1: a stool; 0.5: a wall).
        low_half_height_m: half height of a low box (a pallet, a kerb: 14 cm is above the trot's foot lift).
        low_probability: share of boxes that are low.
        raised_bottom_m: the path box's underside above the floor when it is raised (a car body, a
            loading dock, a shelf: the trunk hits it and the legs pass under).
        raised_probability: share of path boxes that are raised.
        side_gap_m: trunk centre line to the near face of the box beside the robot.
        side_half_length_m: that box's half length along the trunk.
        loose_distance_m: trunk centre to the loose box's centre.
        friction: sliding friction of the boxes (the scenes' furniture has 1.0).
        yaw_jitter_rad: the path and side boxes are turned by up to this from square.
    """

    enabled: bool = True
    probability: float = 0.7
    path_distance_m: tuple[float, float] = (0.4, 1.5)
    path_half_width_m: tuple[float, float] = (0.15, 1.2)
    path_half_depth_m: tuple[float, float] = (0.05, 0.3)
    half_height_m: tuple[float, float] = (0.1, 0.5)
    low_half_height_m: tuple[float, float] = (0.03, 0.08)
    low_probability: float = 0.35
    raised_bottom_m: tuple[float, float] = (0.12, 0.25)
    raised_probability: float = 0.15
    side_gap_m: tuple[float, float] = (0.2, 0.45)
    side_half_length_m: tuple[float, float] = (0.3, 1.0)
    loose_distance_m: tuple[float, float] = (0.6, 1.2)
    friction: tuple[float, float] = (0.3, 1.0)
    yaw_jitter_rad: float = 0.6


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
    """Everything that defines the training task.

    Attributes:
        command_resample_s: the longest a command is held (inf: never resampled, as the benchmark does).
        min_command_hold_s: the shortest; each hold is uniform in between, per environment. A mission's
            planner changes its twist every second or so (a spin reverses, a subgoal switches from a turn
            to a walk): short holds put those changes into training.
        ramp_commands: the policy sees each new command ramped within ``COMMAND_ACCEL_LIMITS``, as
            :class:`robots.gait_policy.GaitController` ramps it at run time (False: the caller ramps).
    """

    num_envs: int = 32
    episode_steps: int = 1000
    command_resample_s: float = 5.0
    min_command_hold_s: float = 0.5
    ramp_commands: bool = True
    zero_command_probability: float = 0.15
    residual_scale_rad: float = RESIDUAL_SCALE_RAD
    trot: TrotConfig = field(default_factory=TrotConfig)
    reward: RewardScales = field(default_factory=RewardScales)
    randomization: RandomizationConfig = field(default_factory=RandomizationConfig)
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    obstacles: ObstacleConfig = field(default_factory=ObstacleConfig)

    def __post_init__(self) -> None:
        if self.num_envs < 1:
            raise InvalidInputError(f"GaitEnvConfig.num_envs must be >= 1, got {self.num_envs}")
        if not 0.0 < self.min_command_hold_s <= self.command_resample_s:
            raise InvalidInputError(
                f"GaitEnvConfig: need 0 < min_command_hold_s ({self.min_command_hold_s}) <= "
                f"command_resample_s ({self.command_resample_s})"
            )
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


def _obstacle_xml() -> str:
    x, y, z = PARKED_OBSTACLE_POS
    return "".join(
        f'<body name="{OBSTACLE_NAME.format(k)}" mocap="true" pos="{x} {y} {z}">'
        f'<geom name="{OBSTACLE_NAME.format(k)}" type="box" size="0.1 0.1 0.1" contype="0" conaffinity="4"'
        ' rgba="0.6 0.5 0.4 1"/></body>'
        for k in range(OBSTACLE_SLOTS)
    )


def _build_model() -> mujoco.MjModel:
    xml = GO1_XML_PATH.read_text().replace("<worldbody>", "<worldbody>" + FLOOR_XML + _obstacle_xml(), 1)
    return mujoco.MjModel.from_xml_string(xml)


def _yaw_of(quat_wxyz: FloatArray) -> float:
    w, x, y, z = quat_wxyz
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


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
        self._obstacle_geoms = np.array(
            [
                mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_GEOM, OBSTACLE_NAME.format(k))
                for k in range(OBSTACLE_SLOTS)
            ]
        )
        self._obstacle_mocap = np.array(
            [
                base.body_mocapid[mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_BODY, OBSTACLE_NAME.format(k))]
                for k in range(OBSTACLE_SLOTS)
            ]
        )
        trunk_subtree = [b for b in range(base.nbody) if self._is_in_trunk_subtree(base, b)]
        self._robot_geoms = np.array([g for g in range(base.ngeom) if base.geom_bodyid[g] in trunk_subtree])
        self._robot_geom_set = frozenset(int(g) for g in self._robot_geoms)
        self._obstacle_geom_set = frozenset(int(g) for g in self._obstacle_geoms)
        self._standing = self.spec.standing_pose_rad.copy()
        self._resamples_commands = math.isfinite(self.config.command_resample_s)
        n = self.num_envs
        #: What the policy is asked now (ramped towards ``command_targets`` when ``ramp_commands``).
        self.commands = np.zeros((n, 3))
        self.command_targets = np.zeros((n, 3))
        self.next_command_step = np.zeros(n, dtype=np.int64)
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
        self.contact_force_n = np.zeros(n)
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

    def _is_in_trunk_subtree(self, model: mujoco.MjModel, body: int) -> bool:
        while body > 0:
            if body == self._trunk:
                return True
            body = int(model.body_parentid[body])
        return False

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
        self.command_targets[ids] = commands
        if not self.config.ramp_commands:
            self.commands[ids] = commands
        hold_s = self.rng.uniform(self.config.min_command_hold_s, self.config.command_resample_s, size=count)
        self.next_command_step[ids] = self.episode_step[ids] + np.maximum(1, np.round(hold_s / CONTROL_DT_S))

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
        if self._resamples_commands:
            self.commands[i] = 0.0
            self._sample_commands(np.array([i]))
        self._lay_out_obstacles(i)

    # ------------------------------------------------------------------ obstacles

    def _park_obstacles(self, i: int) -> None:
        self.datas[i].mocap_pos[self._obstacle_mocap] = PARKED_OBSTACLE_POS

    def place_obstacle(
        self,
        i: int,
        slot: int,
        centre_xy: FloatArray,
        yaw: float,
        half_size: tuple[float, float, float],
        *,
        bottom_m: float = 0.0,
    ) -> None:
        """Put obstacle ``slot`` of environment ``i`` at ``centre_xy`` (world), turned by ``yaw``, its
        underside ``bottom_m`` above the floor."""
        model, data = self.models[i], self.datas[i]
        geom, mocap = int(self._obstacle_geoms[slot]), int(self._obstacle_mocap[slot])
        model.geom_size[geom] = half_size
        model.geom_rbound[geom] = float(np.linalg.norm(half_size))
        model.geom_aabb[geom] = [0.0, 0.0, 0.0, *half_size]
        data.mocap_pos[mocap] = [centre_xy[0], centre_xy[1], bottom_m + half_size[2]]
        data.mocap_quat[mocap] = [math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0)]
        mujoco.mj_kinematics(model, data)

    def _lay_out_obstacles(self, i: int) -> None:
        """Boxes around robot ``i`` for its current command (or none), never starting in penetration."""
        cfg = self.config.obstacles
        self._park_obstacles(i)
        if not cfg.enabled or self.rng.random() >= cfg.probability:
            return
        rng, model, data = self.rng, self.models[i], self.datas[i]
        position = data.qpos[0:2].copy()
        heading = _yaw_of(data.qpos[3:7])
        vx, vy, _ = self.command_targets[i] if self._resamples_commands else self.commands[i]
        path_angle = heading + (
            math.atan2(vy, vx) if math.hypot(vx, vy) > 0.1 else rng.uniform(-np.pi, np.pi)
        )

        def along(angle: float, distance: float) -> FloatArray:
            return position + distance * np.array([math.cos(angle), math.sin(angle)])

        def height() -> float:
            low = rng.random() < cfg.low_probability
            return float(rng.uniform(*(cfg.low_half_height_m if low else cfg.half_height_m)))

        depth = float(rng.uniform(*cfg.path_half_depth_m))
        raised = rng.random() < cfg.raised_probability
        self.place_obstacle(
            i,
            0,
            along(path_angle, float(rng.uniform(*cfg.path_distance_m)) + depth),
            path_angle + rng.uniform(-cfg.yaw_jitter_rad, cfg.yaw_jitter_rad),
            (
                depth,
                float(rng.uniform(*cfg.path_half_width_m)),
                float(rng.uniform(*cfg.half_height_m)) if raised else height(),
            ),
            bottom_m=float(rng.uniform(*cfg.raised_bottom_m)) if raised else 0.0,
        )
        side = heading + rng.choice([-0.5, 0.5]) * np.pi
        side_half_width = float(rng.uniform(0.05, 0.3))
        side_centre = along(side, float(rng.uniform(*cfg.side_gap_m)) + side_half_width) + rng.uniform(
            -0.3, 0.3
        ) * np.array([math.cos(heading), math.sin(heading)])
        self.place_obstacle(
            i,
            1,
            side_centre,
            heading + rng.uniform(-0.5, 0.5) * cfg.yaw_jitter_rad,
            (float(rng.uniform(*cfg.side_half_length_m)), side_half_width, height()),
        )
        loose = rng.uniform(0.1, 0.3, size=2)
        self.place_obstacle(
            i,
            2,
            along(rng.uniform(-np.pi, np.pi), float(rng.uniform(*cfg.loose_distance_m))),
            rng.uniform(-np.pi, np.pi),
            (float(loose[0]), float(loose[1]), height()),
        )
        model.geom_friction[self._obstacle_geoms, 0] = rng.uniform(*cfg.friction, size=OBSTACLE_SLOTS)
        mujoco.mj_kinematics(model, data)
        for slot, geom in enumerate(self._obstacle_geoms):
            gap = min(
                mujoco.mj_geomDistance(model, data, int(g), int(geom), OBSTACLE_MIN_GAP_M, None)
                for g in self._robot_geoms
            )
            if gap < OBSTACLE_MIN_GAP_M:
                data.mocap_pos[self._obstacle_mocap[slot]] = PARKED_OBSTACLE_POS
        mujoco.mj_kinematics(model, data)

    def _obstacle_contact_force(self, i: int) -> float:
        """Total normal force (N) between robot ``i`` and its obstacles now."""
        model, data = self.models[i], self.datas[i]
        if data.ncon == 0:
            return 0.0
        pairs = data.contact.geom[: data.ncon]
        hits = np.flatnonzero(np.isin(pairs, self._obstacle_geoms).any(axis=1))
        total, force = 0.0, np.zeros(6)
        for index in hits:
            mujoco.mj_contactForce(model, data, int(index), force)
            total += abs(float(force[0]))
        return total

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
            self.contact_force_n[i] = self._obstacle_contact_force(i)

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
                np.minimum(self.contact_force_n / CONTACT_FORCE_SCALE_N, 5.0),
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

    def step(
        self, actions: FloatArray, *, trot_gate: FloatArray | None = None
    ) -> tuple[FloatArray, FloatArray, BoolArray, dict[str, AnyArray]]:
        """Advance every environment by one control period.

        Args:
            actions: ``(N, 12)`` residual actions (clipped to [-1, 1]).
            trot_gate: ``(N,)`` trot gates in place of the prior's own gate of ``commands`` (the run-time
                controller's, :class:`robots.gait_policy.GaitController`); None in training.

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
            self.prior.joint_targets(self.phase, self.commands, trot_gate)
            + self.config.residual_scale_rad * actions
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

        if self._resamples_commands:
            resample = np.flatnonzero((self.episode_step >= self.next_command_step) & ~done)
            self._sample_commands(resample)
            for env_id in resample:
                self._lay_out_obstacles(int(env_id))
            if self.config.ramp_commands:
                self.commands = ramp_command(self.commands, self.command_targets)
        info: dict[str, AnyArray] = {
            "terminated": terminated,
            "truncated": truncated,
            "base_lin_vel_body": lin_vel,
            "yaw_rate": ang_vel[:, 2].copy(),
            "power_w": power,
            "contact_force_n": self.contact_force_n.copy(),
            **{f"reward/{name}": value for name, value in terms.items()},
        }
        if np.any(done):
            info["terminal_critic_obs"] = self.critic_observation()
            for env_id in np.flatnonzero(done):
                self._reset_env(int(env_id))
            self._read_state()
        info["critic_obs"] = self.critic_observation()
        return self.observe(), reward, done, info
