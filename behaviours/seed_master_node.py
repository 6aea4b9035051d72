"""SeedMasterNode: put the master node v_m at the robot's current position.

Semantics (it never returns RUNNING):

- SUCCESS: after adding the master node to ``memory`` at the robot's position. The master node is the
  initial viewpoint of the paper's Sec. III-D and is never pruned.
- It belongs at the very start of a mission and is ticked once: on a memory that already has a master,
  or a node within delta_d of the robot, the memory raises ``InvalidInputError``.

Reads and writes ``memory``.

Example:
    - type: SeedMasterNode
      name: Master
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour


class SeedMasterNode(SemExpBehaviour):
    READS = ("memory",)
    WRITES = ("memory",)

    def update(self) -> py_trees.common.Status:
        pose = self.services.robot.base_pose()
        memory = self.read("memory")
        node_id = memory.add_master(position_m=(pose.x_m, pose.y_m, 0.0), stamp_s=self.now_s())
        self.feedback_message = f"master node {node_id} at ({pose.x_m:.2f}, {pose.y_m:.2f})"
        return py_trees.common.Status.SUCCESS
