"""The RL gait for the Go1: a trot prior, the residual policy on top of it, numpy inference and loading.

Structure (see docs/gait.md): a periodic trot generator maps the velocity command and a phase clock to
12 joint targets (foot trajectories through analytic leg IK); the learned policy adds a bounded residual
to those targets. Residual zero is the "simple reference gait" that the benchmark reports beside the policy.

Everything the runtime needs is numpy only (:class:`NumpyActor`, :class:`TrotPrior`, :func:`build_observation`,
:class:`GaitController`): the ROS 2 side can run it on a Jetson without torch. :func:`build_torch_actor`
(imports torch lazily) is the same network as a torch module, used by training.

Observation layout (``OBS_DIM`` = 47, every term in the body frame):
    command (vx, vy, yaw rate) * COMMAND_SCALE, gyro * GYRO_SCALE, projected gravity,
    (q - q_standing), qdot * JOINT_VELOCITY_SCALE, last action, sin/cos of the trot phase.
Action: 12 numbers clipped to [-1, 1]; joint targets = prior(phase, command) + RESIDUAL_SCALE_RAD * action.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from robots.go1 import LEG_NAMES, NUM_JOINTS, load_go1_spec
from semexp_bt.core.clock import CLOCK_TOLERANCE_S
from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.types import FloatArray, InvalidInputError, Twist, require_finite

if TYPE_CHECKING:
    import torch

    from robots.interface import Robot

#: The policy's control period (s): one behaviour-tree tick.
CONTROL_DT_S = 0.02
#: Observation term scales (chosen so that every term is O(1) on a walking robot).
COMMAND_SCALE = np.array([2.0, 2.0, 0.5])
GYRO_SCALE = 0.25
JOINT_VELOCITY_SCALE = 0.05
#: Largest change the residual policy may make to a prior joint target (rad).
RESIDUAL_SCALE_RAD = 0.3
OBS_DIM = 3 + 3 + 3 + NUM_JOINTS + NUM_JOINTS + NUM_JOINTS + 2
ACTION_DIM = NUM_JOINTS
#: Command ranges a navigation planner needs (vx, vy, yaw rate): commands are clipped to them.
COMMAND_LOW = np.array([-0.5, -0.3, -1.0])
COMMAND_HIGH = np.array([1.0, 0.3, 1.0])
#: Command acceleration limits (vx, vy in m/s^2, yaw in rad/s^2) applied before the policy: the kinematic
#: backend's BaseMotionLimits, so both fidelities ramp alike. A step from 1 m/s to reverse or to a stop is
#: what made the policy fall in the benchmark; ramped, the command stays inside what training showed.
COMMAND_ACCEL_LIMITS = np.array([2.0, 2.0, 4.0])
#: Trunk tilt (rad, from the IMU's gravity) at which the controller stops walking: the command ramps to
#: zero and the policy balances standing. Both dynamic-mission falls measured in docs/gait.md built up
#: over 0.4-1.5 s from a push into furniture or a turn with a foot caught on it, passing 0.25 rad
#: 0.3-0.6 s before the fall; missions without a fall stay below 0.16 rad.
NEAR_FALL_TILT_RAD = 0.25
#: The controller walks again (ramping up from zero) once the tilt has stayed below this for
#: RECOVERY_HOLD_S.
RECOVERED_TILT_RAD = 0.1
RECOVERY_HOLD_S = 1.0
#: Time (s) over which the residual fades out once the ramped command is inside the walking deadband, and
#: back in once it leaves it (:class:`StanceHold`). The trot prior stands still there; the residual policy,
#: trained on commands that rarely sit at zero, keeps stepping and swaying: 0.023 m/s median trunk speed on
#: flat ground against 0.0003 with the hold (docs/gait.md, "Stance hold"). 0.4 s is one trot cycle and a half.
STANCE_FADE_S = 0.4
#: The run-time controller's trot deadband (command norm as :meth:`TrotPrior.gate` weighs it), in place of
#: the trained prior's 0.05: that one stands still for turns slower than 0.17 rad/s and creeps slower than
#: 0.05 m/s, which the navigation controllers ask for (14 % of a dynamic mission's moving commands,
#: docs/gait.md "Walking slow commands, and command tracking"). Trotting at such commands the policy drifts instead; the tracking
#: correction (:class:`CommandTracking`) takes the drift out.
WALKING_DEADBAND = 0.005
#: Command tracking (:class:`CommandTracking`): integral gain (1/s) on the velocity error, the time constant
#: (s) of the low-pass on the measured body velocity (the trot rocks it at 2.5 Hz), and the largest
#: correction (vx, vy in m/s, yaw rate in rad/s). The shipped policy's drift on flat ground is about
#: -0.04 m/s and +0.1 rad/s (docs/gait.md); the limits leave room for slopes and wear, not for a fight with
#: furniture.
TRACKING_GAIN_PER_S = 1.0
TRACKING_FILTER_S = 0.4
TRACKING_LIMIT = np.array([0.15, 0.1, 0.4])
#: Where the shipped checkpoint lives.
DEFAULT_CHECKPOINT_DIR = Path(__file__).resolve().parent / "gait_checkpoints"
WEIGHTS_FILE = "policy.npz"
CONFIG_FILE = "policy.json"


@dataclass(frozen=True)
class TrotConfig:
    """The trot generator's parameters (a diagonal-pair trot at a fixed frequency).

    Attributes:
        frequency_hz: gait cycles per second; each leg swings for half a cycle.
        foot_lift_m: swing apex height above the stance foot.
        stand_height_m: thigh-joint-to-foot height of the standing pose (IK target of zero command).
        stride_gain: stance foot speed relative to the commanded body speed; >1 compensates the slip and
            compliance of an open-loop trot.
        command_deadband: below this command norm the prior stands still (no foot lift); above twice it
            the trot is fully on.
    """

    frequency_hz: float = 2.5
    foot_lift_m: float = 0.07
    stand_height_m: float = 0.2648
    stride_gain: float = 1.5
    command_deadband: float = 0.05

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not math.isfinite(value) or value < 0.0:
                raise InvalidInputError(
                    f"TrotConfig.{name} must be a non-negative finite number, got {value}"
                )
        if self.frequency_hz <= 0.0:
            raise InvalidInputError(f"TrotConfig.frequency_hz must be > 0, got {self.frequency_hz}")


#: Phase offsets per leg (FR, FL, RR, RL): diagonal pairs FR+RL and FL+RR half a cycle apart.
TROT_PHASE_OFFSETS = np.array([0.0, 0.5, 0.5, 0.0])


class TrotPrior:
    """Joint targets of a command-following trot (the reference gait), batched over environments.

    Each leg's foot follows, in the hip frame, a swing arc (cycloid forward, cosine lift) for half a
    cycle and a straight stance stroke for the other half; the stroke's length and direction are the foot
    velocity that the command asks for (body velocity plus yaw rate x foot position) times the stance time.
    Analytic IK of the 3-DoF leg turns foot positions into joint angles.
    """

    def __init__(self, config: TrotConfig | None = None) -> None:
        self.config = config or TrotConfig()
        spec = load_go1_spec()
        self._standing = spec.standing_pose_rad.copy()
        self._lower = spec.joint_lower_rad
        self._upper = spec.joint_upper_rad
        self._link_m = spec.thigh_length_m
        hip_x, hip_y, _ = spec.hip_offset_m
        # Per leg: +1 for front/left, -1 for rear/right.
        front = np.array([1.0 if leg[0] == "F" else -1.0 for leg in LEG_NAMES])
        left = np.array([1.0 if leg[1] == "L" else -1.0 for leg in LEG_NAMES])
        self._abduction_offset_m = left * spec.thigh_offset_y_m
        # Nominal foot positions in the trunk frame (for the yaw-rate part of the foot velocity).
        self._foot_x_m = front * hip_x
        self._foot_y_m = left * (hip_y + spec.thigh_offset_y_m)

    @property
    def standing_pose_rad(self) -> FloatArray:
        return self._standing.copy()

    def gate(self, command: FloatArray, deadband: float | None = None) -> FloatArray:
        """How much trot (0 = stand, 1 = full) each command in ``(N, 3)`` asks for: none below
        ``deadband`` (the config's ``command_deadband`` when None), in full above twice it."""
        norm = np.sqrt(command[:, 0] ** 2 + command[:, 1] ** 2 + (0.3 * command[:, 2]) ** 2)
        deadband = self.config.command_deadband if deadband is None else deadband
        return np.clip((norm - deadband) / max(deadband, 1e-9), 0.0, 1.0)

    def foot_positions(
        self, phase: FloatArray, command: FloatArray, gate: FloatArray | None = None
    ) -> FloatArray:
        """Foot targets ``(N, 4, 3)`` relative to each leg's nominal foot point (x fwd, y left, z up).

        ``gate`` ``(N,)`` overrides :meth:`gate` of the command (the run-time controller gates by what was
        asked, not by the tracking-corrected command it passes: :class:`GaitController`)."""
        cfg = self.config
        stance_s = 0.5 / cfg.frequency_hz
        gate = (self.gate(command) if gate is None else np.asarray(gate, dtype=float))[:, None]
        vx = command[:, 0:1] - command[:, 2:3] * self._foot_y_m[None, :]
        vy = command[:, 1:2] + command[:, 2:3] * self._foot_x_m[None, :]
        half_x = 0.5 * cfg.stride_gain * vx * stance_s * gate
        half_y = 0.5 * cfg.stride_gain * vy * stance_s * gate
        leg_phase = np.mod(phase[:, None] + TROT_PHASE_OFFSETS[None, :], 1.0)
        swing = leg_phase < 0.5
        s_swing = leg_phase / 0.5
        s_stance = (leg_phase - 0.5) / 0.5
        cycloid = s_swing - np.sin(2.0 * np.pi * s_swing) / (2.0 * np.pi)
        progress = np.where(swing, -1.0 + 2.0 * cycloid, 1.0 - 2.0 * s_stance)
        lift = np.where(swing, cfg.foot_lift_m * 0.5 * (1.0 - np.cos(2.0 * np.pi * s_swing)), 0.0) * gate
        return np.stack([half_x * progress, half_y * progress, lift], axis=-1)

    def joint_targets(
        self, phase: FloatArray, command: FloatArray, gate: FloatArray | None = None
    ) -> FloatArray:
        """Reference joint targets ``(N, 12)`` for phases ``(N,)`` in [0, 1) and commands ``(N, 3)``
        (``gate`` as in :meth:`foot_positions`)."""
        feet = self.foot_positions(np.asarray(phase, dtype=float), np.asarray(command, dtype=float), gate)
        return np.clip(self.leg_ik(feet), self._lower, self._upper)

    def leg_ik(self, feet: FloatArray) -> FloatArray:
        """Joint angles ``(N, 12)`` putting each foot at its offset ``(N, 4, 3)`` from the nominal point."""
        link = self._link_m
        d = self._abduction_offset_m[None, :]
        x = feet[..., 0]
        y = d + feet[..., 1]
        z = -self.config.stand_height_m + feet[..., 2]
        # Abduction: the leg plane's in-plane length L, then the angle turning (d, -L) onto (y, z).
        plane_sq = np.maximum(y**2 + z**2 - d**2, 1e-6)
        plane = np.sqrt(plane_sq)
        hip = np.arctan2(z, y) - np.arctan2(-plane, d)
        # Sagittal two-link IK with equal links: the knee angle from the reach, the thigh from the direction.
        reach_sq = np.clip(x**2 + plane_sq, 1e-6, (2.0 * link) ** 2 * 0.999)
        cos_knee = np.clip((reach_sq - 2.0 * link**2) / (2.0 * link**2), -1.0, 1.0)
        knee = -np.arccos(cos_knee)
        thigh = np.arctan2(-x, plane) - 0.5 * knee
        hip = wrap_angle(hip)
        return np.stack([hip, thigh, knee], axis=-1).reshape(feet.shape[0], NUM_JOINTS)


def projected_gravity(orientation_wxyz: FloatArray) -> FloatArray:
    """The unit gravity vector in the body frame from a ``(4,)`` or ``(N, 4)`` wxyz quaternion."""
    q = np.atleast_2d(np.asarray(orientation_wxyz, dtype=float))
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    # Third row of the rotation matrix, negated: R^T (0, 0, -1).
    g = -np.stack([2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)], axis=-1)
    return g if np.ndim(orientation_wxyz) == 2 else g[0]


def build_observation(
    *,
    command: FloatArray,
    gyro_radps: FloatArray,
    gravity_body: FloatArray,
    joint_position_rel_rad: FloatArray,
    joint_velocity_radps: FloatArray,
    last_action: FloatArray,
    phase: FloatArray,
) -> FloatArray:
    """Stack the policy input ``(N, OBS_DIM)`` from batched terms (see the module docstring for the layout)."""
    phase = np.asarray(phase, dtype=float).reshape(-1, 1)
    return np.concatenate(
        [
            command * COMMAND_SCALE,
            gyro_radps * GYRO_SCALE,
            gravity_body,
            joint_position_rel_rad,
            joint_velocity_radps * JOINT_VELOCITY_SCALE,
            last_action,
            np.sin(2.0 * np.pi * phase),
            np.cos(2.0 * np.pi * phase),
        ],
        axis=1,
    )


def ramp_command(current: FloatArray, requested: FloatArray, dt_s: float = CONTROL_DT_S) -> FloatArray:
    """Move ``current`` towards ``requested`` (both ``(N, 3)`` or ``(3,)``) within the acceleration limits."""
    step = COMMAND_ACCEL_LIMITS * dt_s
    return np.asarray(current, dtype=float) + np.clip(np.asarray(requested) - current, -step, step)


@dataclass
class PolicyConfig:
    """What a checkpoint's JSON holds besides the weights.

    Attributes:
        hidden_sizes: actor hidden layer widths (ELU activations, linear output).
        trot: the trot prior's parameters.
        residual_scale_rad: action -> joint target offset scale.
        obs_dim: observation size the weights expect.
        info: free-form provenance (training command, steps, wall time).
    """

    hidden_sizes: tuple[int, ...] = (128, 128)
    trot: TrotConfig = field(default_factory=TrotConfig)
    residual_scale_rad: float = RESIDUAL_SCALE_RAD
    obs_dim: int = OBS_DIM
    info: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "hidden_sizes": list(self.hidden_sizes),
            "trot": asdict(self.trot),
            "residual_scale_rad": self.residual_scale_rad,
            "obs_dim": self.obs_dim,
            "info": self.info,
        }

    @classmethod
    def from_json(cls, raw: dict[str, Any], *, where: str = "policy config") -> PolicyConfig:
        for key in ("hidden_sizes", "trot", "residual_scale_rad", "obs_dim"):
            if key not in raw:
                raise InvalidInputError(f"{where}: missing key '{key}'")
        try:
            trot = TrotConfig(**raw["trot"])
        except TypeError as err:
            raise InvalidInputError(f"{where}: bad 'trot' section: {err}") from None
        return cls(
            hidden_sizes=tuple(int(h) for h in raw["hidden_sizes"]),
            trot=trot,
            residual_scale_rad=float(raw["residual_scale_rad"]),
            obs_dim=int(raw["obs_dim"]),
            info=dict(raw.get("info", {})),
        )


class NumpyActor:
    """The actor MLP in numpy: normalise the observation, ELU hidden layers, linear mean action, clip.

    Args:
        weights: ``[(W, b), ...]`` with ``W`` of shape ``(in, out)``.
        obs_mean: running mean of the observations seen in training.
        obs_std: their standard deviation.
    """

    def __init__(
        self, weights: Sequence[tuple[FloatArray, FloatArray]], obs_mean: FloatArray, obs_std: FloatArray
    ) -> None:
        if not weights:
            raise InvalidInputError("NumpyActor needs at least one layer")
        self.weights = [
            (np.asarray(w, dtype=np.float64), np.asarray(b, dtype=np.float64)) for w, b in weights
        ]
        self.obs_mean = np.asarray(obs_mean, dtype=np.float64)
        self.obs_std = np.asarray(obs_std, dtype=np.float64)
        self.obs_dim = self.weights[0][0].shape[0]
        if self.obs_mean.shape != (self.obs_dim,) or self.obs_std.shape != (self.obs_dim,):
            raise InvalidInputError(f"obs_mean/obs_std must have shape ({self.obs_dim},)")
        for (w_in, _), (w_out, _) in zip(self.weights[:-1], self.weights[1:], strict=True):
            if w_in.shape[1] != w_out.shape[0]:
                raise InvalidInputError(f"layer shapes do not chain: {w_in.shape} -> {w_out.shape}")

    @classmethod
    def zeros(cls, obs_dim: int = OBS_DIM, action_dim: int = ACTION_DIM) -> NumpyActor:
        """An actor whose action is always zero: the reference gait."""
        return cls(
            [(np.zeros((obs_dim, action_dim)), np.zeros(action_dim))], np.zeros(obs_dim), np.ones(obs_dim)
        )

    def __call__(self, obs: FloatArray) -> FloatArray:
        """Actions ``(N, 12)`` in [-1, 1] for observations ``(N, obs_dim)`` (or ``(12,)`` for ``(obs_dim,)``)."""
        x = np.asarray(obs, dtype=np.float64)
        single = x.ndim == 1
        x = np.clip((np.atleast_2d(x) - self.obs_mean) / self.obs_std, -OBS_CLIP, OBS_CLIP)
        for index, (w, b) in enumerate(self.weights):
            x = x @ w + b
            if index < len(self.weights) - 1:
                x = np.where(x > 0.0, x, np.expm1(np.minimum(x, 0.0)))
        action = np.clip(x, -1.0, 1.0)
        return action[0] if single else action


#: Normalised observations are clipped to this many standard deviations.
OBS_CLIP = 5.0


def build_torch_actor(obs_dim: int, action_dim: int, hidden_sizes: Sequence[int]) -> torch.nn.Sequential:
    """The actor as a torch module (Linear + ELU layers, linear output): its mean is the policy's action."""
    import torch

    layers: list[torch.nn.Module] = []
    width = obs_dim
    for hidden in hidden_sizes:
        layers += [torch.nn.Linear(width, hidden), torch.nn.ELU()]
        width = hidden
    layers.append(torch.nn.Linear(width, action_dim))
    return torch.nn.Sequential(*layers)


def actor_weights_from_torch(module: torch.nn.Sequential) -> list[tuple[FloatArray, FloatArray]]:
    """``[(W, b), ...]`` (W as ``(in, out)``) from a module built by :func:`build_torch_actor`."""
    import torch

    return [
        (layer.weight.detach().cpu().numpy().T.copy(), layer.bias.detach().cpu().numpy().copy())
        for layer in module
        if isinstance(layer, torch.nn.Linear)
    ]


@dataclass
class GaitPolicy:
    """A loaded gait: the trot prior, the residual actor and their config."""

    config: PolicyConfig
    actor: NumpyActor
    prior: TrotPrior

    @classmethod
    def reference(cls, trot: TrotConfig | None = None) -> GaitPolicy:
        """The reference gait: the trot prior with a zero residual."""
        config = PolicyConfig(trot=trot or TrotConfig(), hidden_sizes=())
        return cls(config=config, actor=NumpyActor.zeros(), prior=TrotPrior(config.trot))

    def joint_targets(
        self, phase: FloatArray, command: FloatArray, action: FloatArray, gate: FloatArray | None = None
    ) -> FloatArray:
        """Joint targets ``(N, 12)`` = prior + residual_scale * action (``gate`` as in
        :meth:`TrotPrior.foot_positions`)."""
        return self.prior.joint_targets(phase, command, gate) + self.config.residual_scale_rad * action


def save_policy(directory: Path, *, config: PolicyConfig, actor: NumpyActor) -> None:
    """Write ``policy.npz`` (weights, observation statistics) and ``policy.json`` (config) into ``directory``."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    arrays: dict[str, npt.NDArray[Any]] = {"obs_mean": actor.obs_mean, "obs_std": actor.obs_std}
    for index, (w, b) in enumerate(actor.weights):
        arrays[f"w{index}"] = w.astype(np.float32)
        arrays[f"b{index}"] = b.astype(np.float32)
    np.savez_compressed(directory / WEIGHTS_FILE, **arrays)  # type: ignore[arg-type]
    (directory / CONFIG_FILE).write_text(json.dumps(config.to_json(), indent=2) + "\n")


def load_policy(directory: Path | str | None = None) -> GaitPolicy:
    """Load a checkpoint directory (the shipped one when None).

    Raises:
        FileNotFoundError: naming the missing file.
        InvalidInputError: a malformed config or weights that do not fit it (naming the file and key).
    """
    directory = Path(directory) if directory is not None else DEFAULT_CHECKPOINT_DIR
    config_path, weights_path = directory / CONFIG_FILE, directory / WEIGHTS_FILE
    for path in (config_path, weights_path):
        if not path.is_file():
            raise FileNotFoundError(f"gait checkpoint file not found: {path}")
    try:
        raw = json.loads(config_path.read_text())
    except json.JSONDecodeError as err:
        raise InvalidInputError(f"{config_path}: not valid JSON ({err})") from None
    config = PolicyConfig.from_json(raw, where=str(config_path))
    with np.load(weights_path) as data:
        layers = []
        for index in range(len(config.hidden_sizes) + 1):
            for key in (f"w{index}", f"b{index}"):
                if key not in data:
                    raise InvalidInputError(f"{weights_path}: missing array '{key}'")
            layers.append((data[f"w{index}"], data[f"b{index}"]))
        for key in ("obs_mean", "obs_std"):
            if key not in data:
                raise InvalidInputError(f"{weights_path}: missing array '{key}'")
        for name in data.files:
            require_finite(f"{weights_path}:{name}", data[name])
        actor = NumpyActor(layers, data["obs_mean"], data["obs_std"])
    if actor.obs_dim != config.obs_dim:
        raise InvalidInputError(
            f"{weights_path}: weights take {actor.obs_dim} inputs, config says {config.obs_dim}"
        )
    return GaitPolicy(config=config, actor=actor, prior=TrotPrior(config.trot))


class NearFallRecovery:
    """Per robot of a batch: whether a near fall holds its command at zero (see :class:`GaitController`).

    A robot enters recovery when its trunk tilt (the angle between the body's z axis and the vertical,
    from the projected gravity) exceeds :data:`NEAR_FALL_TILT_RAD` and leaves it once the tilt has stayed
    below :data:`RECOVERED_TILT_RAD` for :data:`RECOVERY_HOLD_S`.

    Args:
        count: robots in the batch.
        control_dt_s: the period between :meth:`update` calls.
    """

    def __init__(self, count: int, *, control_dt_s: float = CONTROL_DT_S) -> None:
        self.control_dt_s = control_dt_s
        self.recovering = np.zeros(count, dtype=bool)
        self.near_falls = 0
        self._calm_s = np.zeros(count)

    def update(self, gravity_body: FloatArray) -> npt.NDArray[np.bool_]:
        """Advance one period with the projected gravity ``(count, 3)``; returns who is recovering."""
        tilt = np.arccos(np.clip(-np.asarray(gravity_body, dtype=float)[:, 2], -1.0, 1.0))
        tipping = tilt > NEAR_FALL_TILT_RAD
        self.near_falls += int(np.sum(tipping & ~self.recovering))
        level = tilt < RECOVERED_TILT_RAD
        self._calm_s = np.where(self.recovering & level, self._calm_s + self.control_dt_s, 0.0)
        # The one clock rule (semexp_bt/core/clock.py): a hold reached within the tolerance counts as done.
        held = self._calm_s >= RECOVERY_HOLD_S - CLOCK_TOLERANCE_S
        self.recovering = tipping | (self.recovering & ~held)
        self._calm_s[tipping] = 0.0
        return self.recovering.copy()


class StanceHold:
    """Per robot of a batch: the share of the residual policy's action that is applied (0 to 1).

    The share falls to 0 over :data:`STANCE_FADE_S` while a robot is idle (its ramped command inside the
    controller's walking deadband and no near-fall recovery under way) and rises back to 1 over the same time once it is
    not, so a robot told to stop stands on the trot prior's standing pose instead of the policy's sway.
    A recovering robot keeps the full residual: balancing a tilt is what the policy is for.

    Example: a robot that has walked and is then held at a zero command applies 95 %, 90 %, ... of the
    action each 20 ms tick and none after 0.4 s; asked to walk again, the share climbs back in 0.4 s.

    Args:
        count: robots in the batch.
        control_dt_s: the period between :meth:`update` calls.
    """

    def __init__(self, count: int, *, control_dt_s: float = CONTROL_DT_S) -> None:
        self.control_dt_s = control_dt_s
        # A robot starts standing, as one that has stood for a while.
        self.share = np.zeros(count)

    def update(self, idle: npt.NDArray[np.bool_]) -> FloatArray:
        """Advance one period with who is idle ``(count,)``; returns the share to apply ``(count,)``."""
        step = self.control_dt_s / STANCE_FADE_S
        self.share = np.clip(self.share + np.where(idle, -step, step), 0.0, 1.0)
        return self.share.copy()


class CommandTracking:
    """Per robot of a batch: the correction added to the ramped command so the body realises it.

    The residual policy does not walk exactly what it is told: on flat ground, asked for small commands, it
    walks about 0.04 m/s forward and turns about 0.1 rad/s right of them, so a turn asked at 0.2 rad/s
    realises 0.08 and one at -0.2 realises -0.3 (docs/gait.md, "Walking slow commands, and command
    tracking"). The correction integrates
    the error between the ramped command and the measured body velocity (low-passed over
    :data:`TRACKING_FILTER_S`) at :data:`TRACKING_GAIN_PER_S`, clipped to :data:`TRACKING_LIMIT`. It
    integrates only while the robot walks and is held, not cleared, while it stands: the drift belongs to the
    gait, so the next walk starts corrected.

    Example: asked for a 0.2 rad/s turn in place, the robot turns at 0.08 rad/s at first; within a few
    seconds the correction has climbed to about +0.12 rad/s and the body turns at 0.2.

    Args:
        count: robots in the batch.
        control_dt_s: the period between :meth:`update` calls.
    """

    def __init__(self, count: int, *, control_dt_s: float = CONTROL_DT_S) -> None:
        self.control_dt_s = control_dt_s
        self.correction = np.zeros((count, 3))
        self._measured = np.zeros((count, 3))

    def update(self, command: FloatArray, measured: FloatArray, walking: npt.NDArray[np.bool_]) -> FloatArray:
        """Advance one period with the ramped ``command`` and the body's ``measured`` (vx, vy, yaw rate),
        both ``(count, 3)``, and who is ``walking`` ``(count,)``; returns the command to pass on."""
        self._measured += (np.asarray(measured, dtype=float) - self._measured) * (
            self.control_dt_s / TRACKING_FILTER_S
        )
        step = TRACKING_GAIN_PER_S * self.control_dt_s * (command - self._measured)
        updated = np.clip(self.correction + step, -TRACKING_LIMIT, TRACKING_LIMIT)
        # Back-calculation: what the command range leaves of the correction is all it keeps, so a command
        # the gait cannot reach (a full-speed turn) does not wind it up past the range.
        told = np.clip(command + updated, COMMAND_LOW, COMMAND_HIGH)
        self.correction = np.where(walking[:, None], told - command, self.correction)
        return np.where(walking[:, None], told, command)


def walking_command(
    prior: TrotPrior,
    tracking: CommandTracking,
    ramped: FloatArray,
    measured: FloatArray,
    recovering: npt.NDArray[np.bool_],
) -> tuple[FloatArray, FloatArray]:
    """The run-time controller's walking rule for a batch: ``(command, gate)``.

    ``gate`` ``(N,)`` is each ramped command's trot gate at :data:`WALKING_DEADBAND`; ``command`` ``(N, 3)`` is
    what the policy and the prior are told, ``tracking``'s correction added while the robot walks (gated in
    and not ``recovering``). :class:`GaitController` and the gait benchmark's loop both call it.
    """
    gate = prior.gate(ramped, WALKING_DEADBAND)
    return tracking.update(ramped, measured, (gate > 0.0) & ~recovering), gate


class GaitController:
    """Runs a gait on a :class:`~robots.interface.Robot` every tick: ``controller(robot, twist)``.

    It clips the twist to the command ranges and ramps it within :data:`COMMAND_ACCEL_LIMITS`, reads
    ``robot.joint_state()`` and ``robot.imu()``, keeps its own phase clock, ramped command and last action,
    and calls ``robot.command_joint_targets()``. One call = one control period (:data:`CONTROL_DT_S`).

    Near-fall recovery (:class:`NearFallRecovery`): past :data:`NEAR_FALL_TILT_RAD` of trunk tilt the
    requested twist is replaced by zero (ramped down: a raw step is itself a fall risk) until the robot
    has been level again for :data:`RECOVERY_HOLD_S`.

    Walking (:data:`WALKING_DEADBAND`): the trot prior is gated by the ramped command against this
    controller's deadband, ten times below the trained prior's, so slow turns and creeps are walked, not
    stood through; :class:`CommandTracking` corrects what the policy and the prior are told (from the body
    velocity, ``robot.base_twist()``) so the body realises the command.

    Stance hold (:class:`StanceHold`): while the ramped command is inside that deadband and no recovery is
    under way, the residual fades out, and the policy's next observation holds the action as applied, so a
    stopped robot is in the reference gait's own standing state.
    """

    def __init__(self, policy: GaitPolicy, *, control_dt_s: float = CONTROL_DT_S) -> None:
        self.policy = policy
        self.control_dt_s = control_dt_s
        self.phase = 0.0
        self.last_action = np.zeros(ACTION_DIM)
        self.command = np.zeros(3)
        self.recovery = NearFallRecovery(1, control_dt_s=control_dt_s)
        self.stance = StanceHold(1, control_dt_s=control_dt_s)
        self.tracking = CommandTracking(1, control_dt_s=control_dt_s)
        self._standing = policy.prior.standing_pose_rad

    @property
    def recovering(self) -> bool:
        """Whether the near-fall recovery holds the command at zero now."""
        return bool(self.recovery.recovering[0])

    @property
    def near_falls(self) -> int:
        """Near falls (tilt past NEAR_FALL_TILT_RAD) since the controller was made."""
        return self.recovery.near_falls

    def reset(self) -> None:
        self.phase = 0.0
        self.last_action = np.zeros(ACTION_DIM)
        self.command = np.zeros(3)
        self.recovery = NearFallRecovery(1, control_dt_s=self.control_dt_s)
        self.stance = StanceHold(1, control_dt_s=self.control_dt_s)
        self.tracking = CommandTracking(1, control_dt_s=self.control_dt_s)

    def __call__(self, robot: Robot, twist: Twist) -> None:
        raw = [twist.linear_x_mps, twist.linear_y_mps, twist.angular_z_radps]
        require_finite("twist", raw)
        requested = np.clip(np.asarray(raw, dtype=float), COMMAND_LOW, COMMAND_HIGH)
        joints = robot.joint_state()
        imu = robot.imu()
        gravity = projected_gravity(np.asarray(imu.orientation_wxyz, dtype=float))
        recovering = self.recovery.update(gravity[None, :])
        if recovering[0]:
            requested = np.zeros(3)
        self.command = ramp_command(self.command, requested, self.control_dt_s)
        body = robot.base_twist()
        measured = np.array([[body.linear_x_mps, body.linear_y_mps, body.angular_z_radps]])
        command, gate = walking_command(
            self.policy.prior, self.tracking, self.command[None, :], measured, recovering
        )
        obs = build_observation(
            command=command,
            gyro_radps=np.asarray(imu.angular_velocity_radps, dtype=float)[None, :],
            gravity_body=gravity[None, :],
            joint_position_rel_rad=(np.asarray(joints.position_rad, dtype=float) - self._standing)[None, :],
            joint_velocity_radps=np.asarray(joints.velocity_radps, dtype=float)[None, :],
            last_action=self.last_action[None, :],
            phase=np.array([self.phase]),
        )
        idle = (gate <= 0.0) & ~recovering
        action = self.stance.update(idle)[:, None] * self.policy.actor(obs)
        targets = self.policy.joint_targets(np.array([self.phase]), command, action, gate)[0]
        robot.command_joint_targets(targets)
        self.last_action = action[0]
        self.phase = (self.phase + self.control_dt_s * self.policy.config.trot.frequency_hz) % 1.0


def make_gait_controller(checkpoint: Path | str | None = None) -> Callable[[Robot, Twist], None]:
    """The callable the runner passes as ``services.gait`` in dynamic fidelity.

    Args:
        checkpoint: a checkpoint directory (``policy.npz`` + ``policy.json``); None loads the shipped one
            (``robots/gait_checkpoints``); the string ``"reference"`` gives the reference trot (no policy).
    """
    if checkpoint == "reference":
        return GaitController(GaitPolicy.reference())
    return GaitController(load_policy(checkpoint))
