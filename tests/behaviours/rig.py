"""What every behaviour test needs to tick ONE behaviour alone: a fresh board, a robot, the mission services.

The fixtures that build it (``rig``, ``make_rig``) are in ``conftest.py``.

A test asks for the ``rig`` fixture (a robot at the origin facing +x, in an empty world, with perception
that sees nothing) or builds its own with ``make_rig(robot=..., script=...)``; then::

    behaviour = rig.build(Spin, angle_deg=90.0)
    statuses = rig.tick(behaviour, ticks=5)      # tick, drive cmd_twist, let 20 ms pass; five times
    rig.show(behaviour)                          # prints the tree (here one leaf) the test asserts on
    assert rig.written_by(behaviour) == ["cmd_twist", "cmd_stamp_s"]

A navigation behaviour's test fills the costmap first: ``rig.map_around()`` integrates the depth frames
of a full turn in place, ``rig.map_from(pose)`` the frame seen from another pose (where the robot has
been: its footprint's cells are cleared too), and ``subgoal_at(x, y)`` is an exploration subgoal.

The board is the runner's initial board (``semexp_bt.app.executive.prepare_board``), with the activity
stream on so that a test can assert which keys the behaviour wrote. The robot is
:class:`robots.null_robot.NullRobot` (a perfect unicycle, an analytic camera) with two things a test may
stage (:class:`FakeRobot`); perception is :class:`sims.scripted_perception.ScriptedPerception`, whose
answers come from what the camera sees (``tests.test_executive.seeing`` over its ``Post`` objects).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import py_trees

from behaviours.arbitrate import Arbitrate
from behaviours.services import SERVICES_KEY, MissionServices
from behaviours.spec import BuildContext
from robots.null_robot import NullRobot
from semexp_bt.core.types import Observation, Pose2D, SafetyState, Subgoal, Twist
from semexp_bt.perception.interface import PerceptionResult, ReadyJob
from sims.scripted_perception import ScriptedPerception
from tests.test_executive import Post, seeing

#: One tree tick of robot time (the mission runner's 50 Hz).
TICK_S = 0.02
#: The instruction every rig starts with.
INSTRUCTION = "find the fire extinguisher"

B = TypeVar("B", bound=py_trees.behaviour.Behaviour)
Answer = Callable[[Observation], PerceptionResult]


class FakeRobot(NullRobot):
    """A NullRobot whose safety state the test sets and whose base the test may block.

    Attributes:
        safety_state: what :meth:`safety` reports (no fall, no events by default).
        blocked: the base does not move whatever it is commanded (time still passes).
    """

    def __init__(self, *, blocked: bool = False, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.safety_state = SafetyState()
        self.blocked = blocked

    def safety(self) -> SafetyState:
        return self.safety_state

    def place(self, pose: Pose2D) -> None:
        """Put the base at ``pose`` at once (to stage where the robot has been)."""
        self._pose = pose

    def advance(self, duration_s: float) -> None:
        if not self.blocked:
            super().advance(duration_s)
            return
        commanded = self.base_twist()
        super().command_twist(Twist.zero())
        super().advance(duration_s)
        super().command_twist(commanded)


def robot_among(*posts: Post, pose: Pose2D | None = None, blocked: bool = False) -> FakeRobot:
    """A robot (at the origin facing +x unless ``pose`` says otherwise) in a world of ``posts``."""
    return FakeRobot(
        start_pose=pose or Pose2D(0.0, 0.0, 0.0),
        posts=tuple((p.object_id, p.x_m, p.y_m, p.radius_m, p.height_m) for p in posts),
        blocked=blocked,
    )


@dataclass
class Rig:
    """One behaviour's world: robot, services, the board, and helpers to build, tick and show it."""

    robot: FakeRobot
    services: MissionServices
    board: py_trees.blackboard.Client
    """A test client with write access to every schema key (to stage what other behaviours would write)."""

    @property
    def context(self) -> BuildContext:
        return BuildContext(
            clock=self.robot.now_s,
            robot=self.robot,
            config=self.services.config,
            services={SERVICES_KEY: self.services},
        )

    def build(self, cls: type[B], name: str | None = None, **params: Any) -> B:
        """The behaviour built as the tree loader builds it (parameters left out take their defaults)."""
        return cls(name=name or cls.__name__, context=self.context, **params)  # type: ignore[call-arg]

    def set(self, key: str, value: Any) -> None:
        self.board.set(key, value, overwrite=True)

    def get(self, key: str) -> Any:
        return self.board.get(key) if self.board.exists(key) else None

    def map_around(self, turns: int = 8) -> None:
        """Fill the costmap (``local_map``) from ``turns`` depth frames of a full turn in place; the robot
        ends as it started."""
        self.map_from(self.robot.base_pose(), turns=turns)

    def map_from(self, pose: Pose2D, *, turns: int = 1) -> None:
        """Add to the costmap the depth frames seen from ``pose`` (``turns`` headings of a full turn from
        its yaw); the robot ends where it was."""
        costmap = self.get("local_map")
        here = self.robot.base_pose()
        for k in range(turns):
            self.robot.place(Pose2D(pose.x_m, pose.y_m, pose.yaw_rad + k * math.tau / turns))
            costmap.integrate(self.robot.observe_depth(pixel_grids=[costmap.sampled_pixels]))
        self.robot.place(here)

    def stage_view(self, seen: list[Post], *, directions: bool = False, arbitrate: bool = True) -> None:
        """Write what Perceive (and, with ``arbitrate``, Arbitrate) would write for the robot's current view,
        perception reporting the ``seen`` posts (and two unexplored directions with ``directions``)."""
        observation = self.robot.observe()
        answer = seeing(seen, directions=directions)(observation)
        self.set("observation", observation)
        self.set("scene_evidence", answer.scene)
        self.set("detections", answer.detections)
        if arbitrate:
            self.tick(self.build(Arbitrate, name="StagedArbitrate"), drive=False)

    @property
    def perception(self) -> ScriptedPerception:
        """The scripted perception (its ``requests`` record what was asked)."""
        perception = self.services.perception
        assert isinstance(perception, ScriptedPerception)
        return perception

    def record_jobs(self) -> list[ReadyJob]:
        """From now on keep every perception job submitted (so a test can see that a halt cancels it)."""
        perception = self.perception
        jobs: list[ReadyJob] = []
        submit = perception.submit

        def recording_submit(**request: Any) -> ReadyJob:
            jobs.append(submit(**request))
            return jobs[-1]

        perception.submit = recording_submit  # type: ignore[method-assign]
        return jobs

    def tick(
        self, behaviour: py_trees.behaviour.Behaviour, ticks: int = 1, *, drive: bool = True
    ) -> list[py_trees.common.Status]:
        """Tick ``ticks`` times, letting one tick of robot time pass after each; the statuses in order.

        With ``drive`` the rig stands in for the gait: the robot executes the ``cmd_twist`` on the board.
        """
        statuses = []
        for _ in range(ticks):
            behaviour.tick_once()
            statuses.append(behaviour.status)
            if drive and self.board.exists("cmd_twist"):
                self.robot.command_twist(self.board.get("cmd_twist"))
            self.robot.advance(TICK_S)
        return statuses

    def tick_until_done(
        self, behaviour: py_trees.behaviour.Behaviour, *, limit_s: float = 60.0
    ) -> list[py_trees.common.Status]:
        """Tick until the behaviour leaves RUNNING (or ``limit_s`` of robot time passed); the statuses."""
        statuses: list[py_trees.common.Status] = []
        deadline = self.robot.now_s() + limit_s
        while self.robot.now_s() < deadline:
            statuses += self.tick(behaviour)
            if statuses[-1] != py_trees.common.Status.RUNNING:
                break
        return statuses

    def halt(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        """Halt the behaviour as a parent does when another branch takes over (``stop(INVALID)``), then
        print it."""
        behaviour.stop(py_trees.common.Status.INVALID)
        self.show(behaviour)

    def show(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        """Print the tree the test asserts on, with each node's status and feedback."""
        print(py_trees.display.unicode_tree(behaviour, show_status=True))

    def written_by(self, behaviour: py_trees.behaviour.Behaviour) -> list[str]:
        """The keys ``behaviour`` wrote since the board was prepared, in order of first write."""
        stream = py_trees.blackboard.Blackboard.activity_stream
        assert stream is not None
        names = {client.name for client in behaviour.blackboards}
        written = [
            item.key.lstrip("/")
            for item in stream.data
            if item.client_name in names and item.activity_type in ("WRITE", "INITIALISED")
        ]
        return list(dict.fromkeys(written))


def subgoal_at(x_m: float, y_m: float, node_id: int = 7) -> Subgoal:
    """An exploration subgoal on the floor at (x_m, y_m)."""
    return Subgoal(node_id=node_id, position_m=(x_m, y_m, 0.0), label="unexplored area", utility=1.0)


def compact(statuses: list[py_trees.common.Status]) -> list[str]:
    """A status sequence with repeats collapsed: ``[R, R, R, S]`` -> ``["RUNNING", "SUCCESS"]``."""
    out: list[str] = []
    for status in statuses:
        if not out or out[-1] != status.name:
            out.append(status.name)
    return out
