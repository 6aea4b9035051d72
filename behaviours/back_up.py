"""BackUp: step away from what the robot is stuck against, onto known free cells (Nav2's BackUp recovery).

Semantics:

- On start it picks, among five body-frame directions (back, back-left, back-right, left, right; never
  ahead, where the controller already failed; a legged robot side-steps), the one along which a straight
  step of ``distance_m`` keeps the oriented footprint on *observed* cells of the costmap (the camera does
  not look back; the footprint's own trail is known free) and clear of lethal cells by the controller's
  least clearance, preferring the largest clearance at the end. With no costmap it picks straight back.
- RUNNING: while stepping that way at ``speed_mps`` and the base has moved less than ``distance_m``.
- SUCCESS: once the base has moved ``distance_m``, or after ``timeout_s`` however far it got, so a
  recovery never hangs; it commands a zero twist first.
- FAILURE: no direction is admissible (a zero twist is commanded).
- Halted while RUNNING: it commands a zero twist.

Reads ``local_map``; writes ``cmd_twist`` and ``cmd_stamp_s``.

Example:
    - type: BackUp
      name: BackUp
      params: {distance_m: 0.3, speed_mps: 0.2}
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.clock import has_elapsed
from semexp_bt.core.types import Pose2D, Twist
from semexp_bt.nav.controller import SafetyRules, discs_known, footprint_clearance
from semexp_bt.nav.costmap import Costmap

#: Candidate escape headings in the body frame (radians from forward), straight back first.
ESCAPE_HEADINGS_RAD = tuple(math.radians(a) for a in (180, 135, -135, 90, -90))


def escape_heading(costmap: Costmap, pose: Pose2D, distance_m: float) -> float | None:
    """The body-frame heading of the best admissible straight step of ``distance_m`` (None: none is)."""
    rules = SafetyRules()
    steps = np.linspace(0.05, distance_m, max(2, int(math.ceil(distance_m / 0.05))))
    now = float(
        footprint_clearance(costmap, np.array([pose.x_m]), np.array([pose.y_m]), np.array([pose.yaw_rad]))[0]
    )
    best, best_room = None, -math.inf
    for heading in ESCAPE_HEADINGS_RAD:
        world = pose.yaw_rad + heading
        x = pose.x_m + steps * math.cos(world)
        y = pose.y_m + steps * math.sin(world)
        yaw = np.full_like(x, pose.yaw_rad)
        clearance = footprint_clearance(costmap, x, y, yaw)
        floor = min(rules.min_clearance_m, now)  # inside the margin already: at least never closer
        if not discs_known(costmap, x, y, yaw).all() or clearance.min() < floor - 1e-4:
            continue
        if clearance[-1] > best_room + 0.02:  # ties keep the earlier (straighter back) heading
            best, best_room = heading, float(clearance[-1])
    return best


class BackUp(SemExpBehaviour):
    READS = ("local_map",)
    WRITES = ("cmd_twist", "cmd_stamp_s")

    distance_m: float = param("float", doc="distance to step away, m", default=0.3, gt=0.0, le=2.0)
    speed_mps: float = param("float", doc="stepping speed, m/s", default=0.2, gt=0.0, le=0.3)
    timeout_s: float = param("float", doc="SUCCESS anyway after this long, s", default=4.0, gt=0.0)

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self._start = (0.0, 0.0, 0.0)
        self._heading: float | None = math.pi

    def initialise(self) -> None:
        pose = self.services.robot.base_pose()
        self._start = (self.now_s(), pose.x_m, pose.y_m)
        costmap = self.read("local_map")
        self._heading = math.pi if costmap is None else escape_heading(costmap, pose, self.distance_m)

    def update(self) -> py_trees.common.Status:
        if self._heading is None:
            self.command(Twist.zero())
            self.feedback_message = "no direction to step away onto known free cells"
            return py_trees.common.Status.FAILURE
        t0, x0, y0 = self._start
        pose = self.services.robot.base_pose()
        moved = math.hypot(pose.x_m - x0, pose.y_m - y0)
        if moved >= self.distance_m or has_elapsed(since_s=t0, now_s=self.now_s(), duration_s=self.timeout_s):
            self.command(Twist.zero())
            self.feedback_message = f"stepped {moved:.2f} m at {math.degrees(self._heading):.0f} deg"
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
