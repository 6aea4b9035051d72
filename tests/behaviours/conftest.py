"""Fixtures for the behaviour tests: a fresh board, a robot and the mission services per test (see rig.py)."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import py_trees
import pytest

from blackboard.schema import SCHEMA
from semexp_bt.app.executive import prepare_board
from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.types import Pose2D
from sims.scripted_perception import ScriptedPerception
from tests.behaviours.rig import INSTRUCTION, Answer, FakeRobot, Rig
from tests.test_executive import make_services, seeing


@pytest.fixture
def make_rig() -> Iterator[Callable[..., Rig]]:
    """Build a rig: ``make_rig(robot=FakeRobot(...), script=[answer, ...], latency_s=1.0)``."""

    def build(
        *,
        robot: FakeRobot | None = None,
        script: list[Answer] | None = None,
        latency_s: float = 1.0,
        instructions: tuple[str, ...] = (INSTRUCTION,),
    ) -> Rig:
        robot = robot or FakeRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
        services = make_services(robot, seeing([]))
        services.perception = ScriptedPerception(
            script or [seeing([], directions=False)], latency_s=latency_s
        )
        prepare_board(
            instructions=list(instructions),
            start_pose=robot.base_pose(),
            memory=TopologicalMemory(services.config.memory),
            activity_stream=True,
        )
        board = py_trees.blackboard.Client(name="test")
        for key in SCHEMA:
            board.register_key(key=key, access=py_trees.common.Access.WRITE, remap_to="/" + key)
        return Rig(robot=robot, services=services, board=board)

    yield build
    py_trees.blackboard.Blackboard.clear()
    py_trees.blackboard.Blackboard.disable_activity_stream()


@pytest.fixture
def rig(make_rig: Callable[..., Rig]) -> Rig:
    """A robot at the origin facing +x in an empty world; perception sees nothing."""
    return make_rig()
