"""BackUp: step away from what the robot is stuck against, the first step of a Nav2-style recovery.

Semantics:

- On start it picks, among seven body-frame directions (back, back-left, back-right, left, right,
  front-left, front-right; never straight ahead, where the planner already failed), the one with the most
  free room on the occupancy map: the mapped distance to the nearest obstacle at ``distance_m`` along
  each direction. With no map, or nothing mapped as occupied, it picks straight back.
- RUNNING: while commanding that direction at ``speed_mps`` and the base has moved less than
  ``distance_m``.
- SUCCESS: once the base has moved ``distance_m``, or after ``timeout_s`` however far it got, so
  recovery never hangs on a robot boxed in on every side; it commands a zero twist first. It never fails.
- Halted while RUNNING: it commands a zero twist.

Reads ``local_map``; writes ``cmd_twist`` and ``cmd_stamp_s``. A legged robot can step sideways, so side
steps are allowed; the map remembers walls the camera no longer sees, so the step is not blind.

Example:
    - type: BackUp
      name: BackUp
      params: {distance_m: 0.3, speed_mps: 0.2}
"""

from __future__ import annotations

import math
from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.types import Pose2D, Twist

#: Candidate escape headings in the body frame (radians from forward), straight ahead excluded.
ESCAPE_HEADINGS_RAD = tuple(math.radians(a) for a in (180, 135, -135, 90, -90, 45, -45))


class BackUp(SemExpBehaviour):
    READS = ("local_map",)
    WRITES = ("cmd_twist", "cmd_stamp_s")

    distance_m: float = param("float", doc="distance to step away, m", default=0.3, gt=0.0, le=2.0)
    speed_mps: float = param("float", doc="stepping speed, m/s", default=0.2, gt=0.0, le=0.5)
    timeout_s: float = param("float", doc="SUCCESS anyway after this long, s", default=4.0, gt=0.0)

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self._start = (0.0, 0.0, 0.0)
        self._heading = math.pi

    def initialise(self) -> None:
        pose = self.services.robot.base_pose()
        self._start = (self.now_s(), pose.x_m, pose.y_m)
        self._heading = self._escape_heading(pose)

    def _escape_heading(self, pose: Pose2D) -> float:
        """The body-frame heading with the most mapped room (straight back when there is no map)."""
        local_map = self.read("local_map")
        if local_map is None:
            return math.pi
        occupied = local_map.occupied()
        if not occupied.any():
            return math.pi
        best, best_room = math.pi, -1.0
        for heading in ESCAPE_HEADINGS_RAD:
            world = pose.yaw_rad + heading
            probe = [
                pose.x_m + self.distance_m * math.cos(world),
                pose.y_m + self.distance_m * math.sin(world),
            ]
            room = local_map.clearance_at(probe)
            if room > best_room + 1e-6:
                best, best_room = heading, room
        return best

    def update(self) -> py_trees.common.Status:
        t0, x0, y0 = self._start
        pose = self.services.robot.base_pose()
        moved = math.hypot(pose.x_m - x0, pose.y_m - y0)
        if moved >= self.distance_m or self.now_s() - t0 > self.timeout_s:
            self.command(Twist.zero())
            self.feedback_message = f"backed up {moved:.2f} m"
            return py_trees.common.Status.SUCCESS
        self.command(
            Twist(
                linear_x_mps=self.speed_mps * math.cos(self._heading),
                linear_y_mps=self.speed_mps * math.sin(self._heading),
            )
        )
        return py_trees.common.Status.RUNNING

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status == py_trees.common.Status.INVALID:
            self.command(Twist.zero())
