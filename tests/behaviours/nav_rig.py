"""A board, a NullRobot and the mission services for ticking ONE navigation behaviour alone.

``NavRig.build(Cls, **params)`` builds the behaviour as the tree loader does; ``tick`` ticks it, lets
20 ms of robot time pass and executes ``cmd_twist`` on the unicycle; ``show`` prints the one-node tree
the test asserts on (as py_trees' own tests do).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np
import py_trees

from behaviours.services import SERVICES_KEY, MissionServices
from behaviours.spec import BuildContext
from blackboard.schema import SCHEMA
from robots.null_robot import NullRobot
from semexp_bt.app.executive import prepare_board
from semexp_bt.core.config import SemExpConfig
from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.relevance import CachedRelevance, LexicalRelevance
from semexp_bt.core.types import Pose2D, SceneEvidence, Subgoal
from semexp_bt.nav.pure_pursuit import RegulatedPurePursuit
from semexp_bt.perception.interface import PerceptionResult
from sims.scripted_perception import ScriptedPerception

TICK_S = 0.02
B = TypeVar("B", bound=py_trees.behaviour.Behaviour)


@dataclass
class NavRig:
    robot: NullRobot
    services: MissionServices
    board: py_trees.blackboard.Client

    def build(self, cls: type[B], **params: Any) -> B:
        context = BuildContext(clock=self.robot.now_s, robot=self.robot, config=self.services.config,
                               services={SERVICES_KEY: self.services})  # fmt: skip
        return cls(name=cls.__name__, context=context, **params)  # type: ignore[call-arg]

    def set(self, key: str, value: Any) -> None:
        self.board.set(key, value, overwrite=True)

    def get(self, key: str) -> Any:
        return self.board.get(key) if self.board.exists(key) else None

    def tick(self, behaviour: py_trees.behaviour.Behaviour, ticks: int = 1) -> list[py_trees.common.Status]:
        statuses = []
        for _ in range(ticks):
            behaviour.tick_once()
            statuses.append(behaviour.status)
            if self.board.exists("cmd_twist"):
                self.robot.command_twist(self.board.get("cmd_twist"))
            self.robot.advance(TICK_S)
        return statuses

    def tick_until_done(
        self, behaviour: py_trees.behaviour.Behaviour, limit_s: float = 60.0
    ) -> list[py_trees.common.Status]:
        statuses: list[py_trees.common.Status] = []
        while self.robot.now_s() < limit_s:
            statuses += self.tick(behaviour)
            if statuses[-1] != py_trees.common.Status.RUNNING:
                break
        return statuses

    def map_around(self, turns: int = 8) -> None:
        """Fill the costmap from a full turn in place (the robot ends where it started)."""
        costmap = self.get("local_map")
        start = self.robot.base_pose()
        for k in range(turns):
            self.robot._pose = Pose2D(start.x_m, start.y_m, start.yaw_rad + k * math.tau / turns)  # noqa: SLF001
            costmap.integrate(self.robot.observe_depth(pixel_grids=[costmap.sampled_pixels]))
        self.robot._pose = start  # noqa: SLF001

    @staticmethod
    def show(behaviour: py_trees.behaviour.Behaviour) -> None:
        print(py_trees.display.unicode_tree(behaviour, show_status=True))


def make_rig(*, start: Pose2D = Pose2D(0.0, 0.0, 0.0), posts: tuple = ()) -> NavRig:  # noqa: B008
    robot = NullRobot(start_pose=start, posts=posts)
    services = MissionServices(
        robot=robot,
        perception=ScriptedPerception(
            [PerceptionResult(scene=SceneEvidence((), 0.0), detections=(), observation_stamp_s=0.0)]
        ),
        relevance=CachedRelevance(LexicalRelevance()),
        config=SemExpConfig(),
        planner=RegulatedPurePursuit(),
        rng=np.random.default_rng(0),
    )
    prepare_board(instructions=["find the fire extinguisher"], start_pose=start, memory=TopologicalMemory())
    board = py_trees.blackboard.Client(name="nav_test")
    for key in SCHEMA:
        board.register_key(key=key, access=py_trees.common.Access.WRITE, remap_to="/" + key)
    return NavRig(robot, services, board)


def subgoal_at(x: float, y: float, node_id: int = 7) -> Subgoal:
    return Subgoal(node_id=node_id, position_m=(x, y, 0.0), label="unexplored area", utility=1.0)
