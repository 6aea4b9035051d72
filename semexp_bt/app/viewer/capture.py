"""The world view's capture: on the tick thread, a :class:`~semexp_bt.app.viewer.frames.WorldFrame` per tick
that has something new to draw.

:class:`FrameCapture` runs on the tick thread, after each tick, and must stay cheap: it compares a few
blackboard values by identity (a behaviour writes a new object when it has news), copies what the tree
mutates in place (the memory's nodes when a memory writer has just finished, the map at most once per
:data:`~semexp_bt.app.viewer.maps.MAP_PERIOD_S`), and reads the robot's pose at :data:`POSE_RATE_HZ`.
Everything in a frame is immutable or a fresh copy, so the viewer's worker thread may draw it while the
tree goes on.

It reads the board's storage directly (``py_trees.blackboard.Blackboard.storage``), not through a
blackboard client: a client read would add to the activity stream that the tick record is made from.

Example:
    >>> capture = FrameCapture.for_tree(run.tree.root)  # doctest: +SKIP
    >>> frame = capture.capture(run, visited={"UpdateMemory": "SUCCESS"})  # doctest: +SKIP
    >>> frame.memory is not None  # UpdateMemory has just finished: the memory's nodes are copied
    True
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import py_trees

from semexp_bt.app.viewer.frames import MemoryFrame, ModelAnswer, WorldFrame
from semexp_bt.app.viewer.maps import MAP_PERIOD_S, map_layer, map_version
from semexp_bt.core.evidence.result import ArbitrationResult
from semexp_bt.core.types import Observation, SceneEvidence, Subgoal, Twist
from semexp_bt.nav.control_result import ControlResult
from trees.registry import default_registry, key_uses

if TYPE_CHECKING:
    from semexp_bt.app.runner import MissionRun

#: The robot's pose, velocity and command reach the view this often (Hz of robot time): a tenth of the
#: tick rate is smooth to the eye and keeps the worker thread's share of the interpreter small.
POSE_RATE_HZ = 10.0
#: The behaviours that change the topological memory in place (the node types that declare ``memory`` written).
MEMORY_WRITERS = frozenset(key_uses(default_registry())["memory"].writers)
#: Statuses after which a memory writer has done its work for this tick.
_DONE = frozenset({"SUCCESS", "FAILURE"})


class FrameCapture:
    """Builds the :class:`WorldFrame` of each tick on the tick thread (see the module docstring).

    Args:
        memory_writers: names of the tree's nodes whose type changes the memory in place.
    """

    def __init__(self, *, memory_writers: frozenset[str] | set[str]) -> None:
        self.memory_writers = frozenset(memory_writers)
        self._seen: dict[str, Any] = {}
        self._decisions = 0
        self._events = 0
        self._pose_due_s = -1.0
        self._map_due_s = -1.0
        self._map_version: int | None = None

    @classmethod
    def for_tree(cls, root: py_trees.behaviour.Behaviour) -> FrameCapture:
        """A capture that knows which of ``root``'s nodes write the memory (by their type)."""
        writers = {node.name for node in root.iterate() if type(node).__name__ in MEMORY_WRITERS}
        return cls(memory_writers=writers)

    def _new(self, storage: Mapping[str, Any], key: str) -> tuple[bool, Any]:
        """Whether the board holds a different object under ``key`` than last time (a key not yet on the
        board counts as None), and the object."""
        value = storage.get(key)
        if value is self._seen.get(key):
            return False, value
        self._seen[key] = value
        return True, value

    def capture(
        self,
        run: MissionRun,
        *,
        visited: Mapping[str, str],
        force_pose: bool = False,
        outcome: str | None = None,
    ) -> WorldFrame | None:
        """The frame of the tick that just ran, or None when the tick changed nothing the view draws (most
        ticks: no frame is built for them).

        Args:
            run: the running mission.
            visited: the status of every node ticked this tick, by name (the tick record's ``nodes``).
            force_pose: read the pose even when it is not due (the first and the last frame).
            outcome: the mission's outcome (the last frame).
        """
        storage = py_trees.blackboard.Blackboard.storage
        services = run.services
        now = run.now_s()
        fields: dict[str, Any] = {} if outcome is None else {"outcome": outcome}
        if force_pose or now >= self._pose_due_s:
            self._pose_due_s = now + 1.0 / POSE_RATE_HZ - 1e-9
            robot = services.robot
            fields["pose"] = robot.base_pose()
            fields["base_twist"] = robot.base_twist()
            command = storage.get("/cmd_twist")
            fields["command"] = command if isinstance(command, Twist) else None
            new_plan, plan = self._new(storage, "/plan")
            if new_plan and isinstance(plan, ControlResult):
                fields["plan"] = plan
        new_observation, observation = self._new(storage, "/observation")
        if new_observation and isinstance(observation, Observation):
            fields["observation"] = observation
        new_detections, detections = self._new(storage, "/detections")
        new_evidence, evidence = self._new(storage, "/scene_evidence")
        if new_detections or new_evidence:
            fields["answer"] = ModelAnswer(
                detections=None if detections is None else tuple(detections),
                scene_evidence=evidence if isinstance(evidence, SceneEvidence) else None,
            )
        new_arbitration, arbitration = self._new(storage, "/arbitration")
        if new_arbitration and isinstance(arbitration, ArbitrationResult):
            fields["arbitration"] = arbitration
        if "/memory" not in self._seen or not _DONE.isdisjoint(map(visited.get, self.memory_writers)):
            memory = storage.get("/memory")
            if memory is not None:
                self._seen["/memory"] = memory
                fields["memory"] = MemoryFrame(
                    nodes=tuple(memory.nodes()),
                    edges=tuple((int(u), int(v)) for u, v in memory.graph.edges()),
                )
        if len(services.decision_log) > self._decisions:
            fields["decision"] = services.decision_log[-1]
            self._decisions = len(services.decision_log)
        new_subgoal, subgoal = self._new(storage, "/subgoal")
        if new_subgoal:
            fields["subgoal_changed"] = True
            fields["subgoal"] = subgoal if isinstance(subgoal, Subgoal) else None
        if now >= self._map_due_s:
            version = map_version(storage)
            if version is not None and version != self._map_version:
                layer = map_layer(storage)
                if layer is not None:
                    fields["map"] = layer
                    self._map_version = version
                    self._map_due_s = now + MAP_PERIOD_S - 1e-9
        if len(services.events) > self._events:
            fields["events"] = tuple(services.events[self._events :])
            self._events = len(services.events)
        return WorldFrame(tick=run.tick, stamp_s=now, **fields) if fields else None
