"""Gait: realise ``cmd_twist`` on the robot at the tick rate (50 Hz), with a stale-command watchdog.

Semantics: always RUNNING. Every tick it reads ``cmd_twist``; when the command is older than
``command_timeout_s`` (its writer stopped refreshing it) it substitutes a zero twist, as a velocity
watchdog on a real robot does. In kinematic fidelity (or on a robot that walks by itself) it passes
the twist to the backend; when a gait policy is configured it runs the policy, which turns the twist
and proprioception into 12 joint targets. It never succeeds: it lives in a parallel branch beside the
planner and is stopped when the branch ends.

Example:
    - type: Gait
      name: Gait50Hz
      params: {command_timeout_s: 0.3}
"""

from __future__ import annotations

from collections.abc import Mapping

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import BuildContext, ParamSpec
from semexp_bt.core.types import Twist


class Gait(SemExpBehaviour):
    READS = ("cmd_twist", "cmd_stamp_s")
    PARAMS = {
        "command_timeout_s": ParamSpec(
            "float", doc="a cmd_twist older than this is replaced by zero, s", default=0.3, gt=0.0
        ),
    }

    def __init__(
        self,
        name: str,
        *,
        command_timeout_s: float = 0.3,
        context: BuildContext,
        remap: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(name, context=context, remap=remap)
        self.command_timeout_s = command_timeout_s

    def update(self) -> py_trees.common.Status:
        twist = self.read("cmd_twist", Twist.zero())
        stamp = self.read("cmd_stamp_s", -1e9)
        if self.now_s() - stamp > self.command_timeout_s:
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
