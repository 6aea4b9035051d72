"""ClearCostmapAroundRobot: forget what the costmap holds around the robot (Nav2's recovery of that name).

Semantics (it never returns RUNNING):

- SUCCESS: after resetting to unknown every cell between ``keep_radius_m`` and ``radius_m`` of the
  robot, so that the frames that follow rebuild that ring from what the camera sees now (a phantom
  obstacle left by a bad frame or by odometry drift goes; a real one is marked again as soon as it is in
  view); a ``costmap_cleared`` event counts the cells.
- FAILURE: there is no costmap on the board.

Reads ``local_map`` and changes it in place (declared as a write of ``local_map``). Unlike Nav2's, it keeps
the cells right around the robot (``keep_radius_m``, past the footprint's circumscribed radius): the
camera does not see them again before the robot moves, and the spin and the back-up that follow must not
sweep a corner of the body into an obstacle the map has just been told to forget.

Example:
    - type: ClearCostmapAroundRobot
      name: ClearCostmap
      params: {radius_m: 3.0}
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param


class ClearCostmapAroundRobot(SemExpBehaviour):
    READS = ("local_map",)
    WRITES = ("local_map",)

    radius_m: float = param(
        "float", doc="forget cells within this distance of the robot, m", default=3.0, gt=0.0
    )
    keep_radius_m: float = param("float", doc="except those within this distance, m", default=0.8, ge=0.0)

    def update(self) -> py_trees.common.Status:
        costmap = self.read("local_map")
        if costmap is None:
            self.feedback_message = "no costmap on the board"
            return py_trees.common.Status.FAILURE
        pose = self.services.robot.base_pose()
        cleared = costmap.clear_around(
            (pose.x_m, pose.y_m), radius_m=self.radius_m, keep_radius_m=self.keep_radius_m
        )
        self.services.log_event("costmap_cleared", cells=cleared)
        self.feedback_message = f"forgot {cleared} cells"
        return py_trees.common.Status.SUCCESS
