"""CPU time of one controller cycle (DWB search and regulated pure pursuit) on a known map, no simulator.

A known 8 m x 8 m room split by a wall with a 1.2 m door (the unit tests' map); the robot on 30 poses
along its approach to the door, a plan through it. Prints the median thread CPU time per ``compute``.

    .venv/bin/python scripts/controller_cycle_cost.py
"""

from __future__ import annotations

import time

import numpy as np

from robots.go1 import go1_footprint
from semexp_bt.core.types import Pose2D, Twist
from semexp_bt.nav.costmap import Costmap, CostmapConfig
from semexp_bt.nav.dwb import DwbController
from semexp_bt.nav.global_planner import GlobalPlanner
from semexp_bt.nav.pure_pursuit import RegulatedPurePursuit


def door_room() -> Costmap:
    """The room: walls round an 8 m square, a wall at x = 0 with a 1.2 m door at y = 0."""
    occupied = np.zeros((160, 160), dtype=bool)
    occupied[[0, -1], :] = True
    occupied[:, [0, -1]] = True
    occupied[:, 79:81] = True
    occupied[68:92, 79:81] = False
    costmap = Costmap(CostmapConfig(), footprint=go1_footprint(), origin_xy=(0.0, 0.0))
    costmap.set_known(occupied, lower_left_xy=(-4.0, -4.0), resolution_m=0.05)
    return costmap


def main() -> None:
    costmap = door_room()
    plan = GlobalPlanner().plan(costmap, start_xy=(-2.0, 2.5), goal_xy=(2.0, 2.5))
    for controller in (DwbController(), RegulatedPurePursuit()):
        times = []
        for i in range(30):
            pose = Pose2D(-2.0 + 0.02 * i, 2.5 - 0.05 * i, -1.0)
            start = time.thread_time()
            controller.compute(plan=plan, costmap=costmap, pose=pose, velocity=Twist(), stamp_s=0.0)
            times.append(time.thread_time() - start)
        print(f"{controller.name}: median {1000.0 * float(np.median(times)):.2f} ms CPU per cycle")


if __name__ == "__main__":
    main()
