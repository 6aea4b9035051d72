"""Gait: realise ``cmd_twist`` on the robot at the tick rate (50 Hz), with a stale-command watchdog.

Semantics:

- RUNNING: always. Every tick it reads ``cmd_twist``; when the command is older than
  ``command_timeout_s`` (``cmd_stamp_s``: its writer stopped refreshing it), or was never written, it
  substitutes a zero twist, as a velocity watchdog on a real robot does. Without a gait policy
  (``services.gait`` is None: kinematic fidelity, or a robot that walks by itself) it passes the twist to
  the backend (``robot.command_twist``); with one it runs the policy, which turns the twist and
  proprioception into 12 joint targets.
- It never succeeds or fails: it lives in a parallel branch beside the planner.
- Halted: it stops the robot (``robot.stop()``, not a zero twist: with a gait policy the legs would freeze
  mid-stride).

Reads ``cmd_twist`` and ``cmd_stamp_s``; writes nothing.

Example:
    - type: Gait
      name: Gait50Hz
      params: {command_timeout_s: 0.3}
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.clock import has_elapsed
from semexp_bt.core.types import Twist


class Gait(SemExpBehaviour):
    READS = ("cmd_twist", "cmd_stamp_s")

    command_timeout_s: float = param(
        "float", doc="a cmd_twist older than this is replaced by zero, s", default=0.3, gt=0.0
    )

    def update(self) -> py_trees.common.Status:
        twist = self.read("cmd_twist", Twist.zero())
        stamp = self.read("cmd_stamp_s", -1e9)
        if has_elapsed(since_s=stamp, now_s=self.now_s(), duration_s=self.command_timeout_s):
            twist = Twist.zero()
        robot = self.services.robot
        if self.services.gait is None:
            robot.command_twist(twist)
        else:
            self.services.gait(robot, twist)
        self.feedback_message = f"v={twist.linear_x_mps:.2f} w={twist.angular_z_radps:.2f}"
        return py_trees.common.Status.RUNNING

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status == py_trees.common.Status.INVALID:
            # stop(), not a zero twist: with a gait policy the legs would freeze mid-stride.
            self.services.robot.stop()
