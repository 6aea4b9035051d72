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
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
import numpy.typing as npt

from semexp_bt.core.types import ImuReading, JointState, Observation, PixelGrid, Pose2D, SafetyState, Twist

Fidelity = Literal["kinematic", "dynamic"]
"""How a backend moves the robot: ``kinematic`` integrates the commanded twist on a planar base,
``dynamic`` steps the full legged body under a gait."""
FIDELITIES: tuple[Fidelity, ...] = get_args(Fidelity)


@dataclass(frozen=True)
class SensorStamps:
    """When each sensor last delivered data, on the backend clock (what a sensor-health guard reads).

    A ROS 2 backend fills these from the header stamps of the newest message on each topic; a stamp
    that stops advancing is a sensor that went silent.

    Attributes:
        camera_s: stamp of the newest RGB-D frame.
        odometry_s: stamp of the newest odometry (base pose and twist).
        imu_s: stamp of the newest IMU reading.
    """

    camera_s: float
    odometry_s: float
    imu_s: float


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

    def observe_side_depth(self, *, pixel_grids: Sequence[PixelGrid] | None = None) -> list[Observation]:
        """Depth frames of the cameras beside the body (``robots.side_depth``), for the costmap only.

        The default is none: a robot without them (or a backend that does not stream them) leaves the
        floor beside its body to what the head camera saw earlier, and the controller's sweep rule
        treats the rest as unknown. Each frame's ``rgb`` is empty; the frames come in
        :data:`robots.mount.FLANK_SIDES` order.
        """
        del pixel_grids
        return []

    def sensor_stamps(self) -> SensorStamps:
        """When the camera, odometry and IMU last delivered data (cheap: no rendering, no reading).

        The default says every sensor is as new as the clock: right for a backend that reads its sensors
        when asked (the MuJoCo backend renders the camera on demand). A backend with streaming sensors
        should override it with the stamps of the newest messages; ``robots/ros2_backend.py`` does not yet,
        so on ROS 2 the SensorHealthGuard sees a silent camera only through its frames' own stamps (while
        the robot moves) and a silent odometry or IMU topic not at all.
        """
        now = self.now_s()
        return SensorStamps(camera_s=now, odometry_s=now, imu_s=now)

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
