"""Building a mission's executive: a fresh blackboard and the py_trees tree over the services.

Shared by the mission runner (``semexp_bt.app.runner``), the tree-overhead benchmark and the tests, so that
every way of running a mission prepares the board the same way.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import py_trees

from behaviours.services import SERVICES_KEY, MissionServices
from behaviours.spec import BuildContext
from blackboard.schema import fresh_board
from robots.go1 import go1_footprint
from semexp_bt.core.instruction import instruction_target
from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.types import Pose2D
from semexp_bt.nav.costmap import Costmap, CostmapConfig
from trees.loader import MissionDocument, load_mission
from trees.registry import NodeRegistry, default_registry

#: The keys the runner writes before the first tick (``runner`` among their writers in docs/node_reference.md).
RUNNER_KEYS = (
    "instruction",
    "target_label",
    "instructions_left",
    "start_pose",
    "memory",
    "mission_outcome",
    "found_objects",
    "subgoal",
    "local_map",
)


def prepare_board(
    *,
    instructions: list[str],
    start_pose: Pose2D,
    memory: TopologicalMemory,
    activity_stream: bool = False,
    costmap: Costmap | None = None,
) -> py_trees.blackboard.Client:
    """Clear the process-wide blackboard and write the mission's initial state.

    Args:
        instructions: the instructions in search order (at least one).
        start_pose: where the robot starts.
        memory: a fresh topological memory (it lives on the board under ``memory``).
        activity_stream: record blackboard activity (for the display and the tick record).
        costmap: the costmap the mission maps into (``local_map``); default: an empty one around the start
            with the Go1's footprint.

    Returns:
        The runner's blackboard client (write access to :data:`RUNNER_KEYS`).
    """
    if not instructions:
        raise ValueError("a mission needs at least one instruction")
    fresh_board(activity_stream=activity_stream)
    board = py_trees.blackboard.Client(name="runner")
    for key in RUNNER_KEYS:
        board.register_key(key=key, access=py_trees.common.Access.WRITE, remap_to="/" + key)
    board.instruction = instructions[0]
    board.target_label = instruction_target(instructions[0])
    board.instructions_left = list(instructions[1:])
    board.start_pose = start_pose
    board.memory = memory
    board.mission_outcome = "running"
    board.found_objects = []
    board.subgoal = None
    if costmap is None:
        costmap = Costmap(
            CostmapConfig(), footprint=go1_footprint(), origin_xy=(start_pose.x_m, start_pose.y_m)
        )
    # The robot is set down with room to turn: its turning circle counts as observed free (the controllers
    # turn only through observed space, and the camera never sees the floor that close).
    costmap.assume_free_around(
        (start_pose.x_m, start_pose.y_m),
        radius_m=costmap.footprint.circumscribed_radius_m + costmap.resolution_m,
    )
    board.local_map = costmap
    return board


class MissionTree(py_trees.trees.BehaviourTree):
    """py_trees' ``BehaviourTree`` without one idle walk of the whole tree per tick.

    ``BehaviourTree.tick`` walks every node after the tick for the visitors that want the whole tree
    (``full=True``), even when none is attached: over the 45 nodes of ``object_search.yaml`` at 50 Hz that
    walk took 3.4 s of an 86 s cProfile run of a 600 s episode (docs/harness.md, session 7). This tree
    ticks exactly as the base class does (handlers, visitors, count), and skips only that walk when no
    full visitor is attached.
    """

    def tick(
        self,
        pre_tick_handler: Callable[[py_trees.trees.BehaviourTree], None] | None = None,
        post_tick_handler: Callable[[py_trees.trees.BehaviourTree], None] | None = None,
    ) -> None:
        if any(visitor.full for visitor in self.visitors):
            super().tick(pre_tick_handler=pre_tick_handler, post_tick_handler=post_tick_handler)
            return
        for handler in ((pre_tick_handler,) if pre_tick_handler else ()) + tuple(self.pre_tick_handlers):
            handler(self)
        for visitor in self.visitors:
            visitor.initialise()
        for node in self.root.tick():
            for visitor in self.visitors:
                node.visit(visitor)
        for visitor in self.visitors:
            visitor.finalise()
        for handler in tuple(self.post_tick_handlers) + ((post_tick_handler,) if post_tick_handler else ()):
            handler(self)
        self.count += 1


def build_tree(
    mission: MissionDocument | Path, *, services: MissionServices, registry: NodeRegistry | None = None
) -> MissionTree:
    """Build the mission's py_trees tree (parsing the file first when given a path), every behaviour with
    ``services`` and ``services.config``, the configuration already resolved for this mission
    (``semexp_bt.app.configuration``)."""
    context = BuildContext(
        clock=services.robot.now_s,
        robot=services.robot,
        config=services.config,
        services={SERVICES_KEY: services},
    )
    built = load_mission(
        mission, registry=registry if registry is not None else default_registry(), context=context
    )
    return MissionTree(root=built.root)
