"""UpdateCostmap: add the head camera's latest depth frame, and the flank cameras' where the robot has
them (``Robot.observe_side_depth``), to the costmap (``local_map``).

Semantics (it never returns RUNNING):

- SUCCESS: after asking the robot for a depth frame at the costmap's pixels only
  (``Robot.observe_depth(pixel_grids=...)``: a simulated camera casts rays there instead of rendering),
  and for the flank cameras' frames where it has them (``Robot.observe_side_depth``; a robot without
  them returns none), and integrating them in one update
  (:meth:`semexp_bt.nav.costmap.Costmap.integrate`: marking, clearing, footprint clearing, inflation
  where it changed). The tree runs it behind a RateLimiter, 6 Hz by default.
- FAILURE: there is no costmap on the board.

Reads ``local_map`` and changes it in place (declared as a write of ``local_map``).

Why 6 Hz and not the controller's 12: the controller reads only the costmap, and at walking speed
(0.8 m/s) the robot moves 13 cm between two frames while the camera sees 6 m ahead; each frame costs a
depth read and about 2 ms of integration. Nav2's local costmap updates at 5 Hz by default.

Example:
    - type: RateLimiter
      name: Costmap6Hz
      params: {rate_hz: 6.0}
      children:
        - type: UpdateCostmap
          name: UpdateCostmap
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour


class UpdateCostmap(SemExpBehaviour):
    READS = ("local_map",)
    WRITES = ("local_map",)

    def update(self) -> py_trees.common.Status:
        costmap = self.read("local_map")
        if costmap is None:
            self.feedback_message = "no costmap on the board"
            return py_trees.common.Status.FAILURE
        robot = self.services.robot
        pixels = [costmap.sampled_pixels]
        head = robot.observe_depth(pixel_grids=pixels)
        beside = robot.observe_side_depth(pixel_grids=pixels)
        with self.timed("costmap_update"):
            stats = costmap.integrate(head, *beside)
        cameras = f"{1 + len(beside)} cameras" if beside else "the head camera"
        self.feedback_message = (
            f"{stats.rays} rays from {cameras}: {stats.marked_cells} marked, {stats.cleared_cells} cleared, "
            f"{stats.lethal_changed} lethal changed (revision {costmap.revision})"
        )
        return py_trees.common.Status.SUCCESS
