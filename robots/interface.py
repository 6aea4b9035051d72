"""The ``Robot`` interface that every backend implements (MuJoCo now, ROS 2 on a real Go1 later).

Behaviours talk to the robot only through this interface. It is deliberately what a real Go1 with a
RealSense D435i offers over ROS 2: the latest RGB-D frame, odometry, joint states, IMU, a velocity
command (the robot's own controller walks) or joint position targets (our RL gait walks), a clock,
and safety state.

Time: the tree never reads the wall clock. ``now_s()`` is the backend's clock and ``advance(dt)``
moves it: the MuJoCo backend steps physics by ``dt`` (lockstep simulation); a ROS 2 backend waits
until ROS time has moved by ``dt``.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from typing import Literal, get_args

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import ImuReading, JointState, Observation, PixelGrid, Pose2D, SafetyState, Twist

Fidelity = Literal["kinematic", "dynamic"]
"""How a backend moves the robot: ``kinematic`` integrates the commanded twist on a planar base,
``dynamic`` steps the full legged body under a gait."""
FIDELITIES: tuple[Fidelity, ...] = get_args(Fidelity)


class Robot(abc.ABC):
    """A legged robot with a head RGB-D camera."""

    @abc.abstractmethod
    def now_s(self) -> float:
        """The backend's clock in seconds (simulated time in MuJoCo, ROS time on ROS 2)."""

    @abc.abstractmethod
    def advance(self, duration_s: float) -> None:
        """Let ``duration_s`` of backend time pass, applying the last command throughout."""

    @abc.abstractmethod
    def observe(self) -> Observation:
        """The latest RGB-D frame with its camera pose, base pose and stamp (rendered on demand in sim)."""

    def observe_depth(self, *, pixel_grids: Sequence[PixelGrid] | None = None) -> Observation:
        """The latest frame for the local planner, which needs depth only (12 Hz).

        Backends that can render depth alone override this to skip colour and segmentation; the
        returned Observation may then carry an empty ``rgb``. The default returns :meth:`observe`.

        Args:
            pixel_grids: the pixels the caller will read. A backend that measures depth per pixel may
                measure only these and leave the others NaN; None asks for the whole image. Cameras
                that deliver whole frames (the default here, a real RealSense) ignore it.
        """
        del pixel_grids  # a whole frame serves any set of pixels
        return self.observe()

    @abc.abstractmethod
    def base_pose(self) -> Pose2D:
        """The base pose in ``map`` from odometry (cheap: no rendering)."""

    @abc.abstractmethod
    def base_twist(self) -> Twist:
        """The measured base velocity in the body frame."""

    @abc.abstractmethod
    def joint_state(self) -> JointState:
        """Joint positions and velocities (zeros of length 12 for a kinematic base)."""

    @abc.abstractmethod
    def imu(self) -> ImuReading:
        """The trunk IMU."""

    @abc.abstractmethod
    def command_twist(self, twist: Twist) -> None:
        """Command a base velocity (used when the robot walks by itself, or in kinematic fidelity)."""

    @abc.abstractmethod
    def command_joint_targets(self, targets_rad: npt.NDArray[np.float64]) -> None:
        """Command 12 joint position targets for the actuators' PD (used by the RL gait)."""

    @abc.abstractmethod
    def stop(self) -> None:
        """Safe stop: zero twist, or hold the standing pose for joint control."""

    @abc.abstractmethod
    def safety(self) -> SafetyState:
        """Fall flag, contact/clearance events and the current minimum clearance."""

    @property
    @abc.abstractmethod
    def fidelity(self) -> Fidelity:
        """``kinematic`` (base follows the twist) or ``dynamic`` (legs, physics, gait)."""

    def close(self) -> None:  # noqa: B027 - optional hook
        """Release renderers, sockets and threads."""
