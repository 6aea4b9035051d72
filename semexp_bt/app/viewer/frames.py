"""What the tick thread hands the viewer: a :class:`WorldFrame` per tick that has something new to draw.

A frame is plain data: fresh copies or immutable values of the core types, numpy arrays, and the
navigation stack's last controller cycle. :class:`~semexp_bt.app.viewer.capture.FrameCapture` builds
them on the tick thread; the world logger (``world.py``) draws them in the view's world process
(``world_process.py``), which unpickles them. So this module and the types it names import only numpy
and the core types, never the tree's registry, the navigation stack's planners or the costmap: the world
process would otherwise import them (0.9 s of CPU, docs/viewer.md, session 35) beside the mission.

Example:
    >>> frame = WorldFrame(tick=1, stamp_s=0.02, pose=Pose2D(0.0, 0.0, 0.0))
    >>> frame.memory is None  # nothing else changed at that tick
    True
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from semexp_bt.core.evidence.result import ArbitrationResult
from semexp_bt.core.types import NodeState, Observation, Pose2D, SceneEvidence, Subgoal, Twist
from semexp_bt.nav.control_result import ControlResult


@dataclass(frozen=True)
class ModelAnswer:
    """What the models said about the last perceived frame (they answer a few seconds after it).

    Attributes:
        detections: the detector's boxes (None: the object-level source is missing).
        scene_evidence: the VLM's proposals (None: the scene-level source is missing).
    """

    detections: tuple[Any, ...] | None
    scene_evidence: SceneEvidence | None


@dataclass(frozen=True)
class MemoryFrame:
    """The topological memory after a change: its nodes (frozen copies) and edges."""

    nodes: tuple[NodeState, ...]
    edges: tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class MapLayer:
    """A snapshot of the planner's map, ready to draw.

    Attributes:
        cells: ``(H, W)`` int8 in ``nav_msgs/OccupancyGrid`` convention (-1 unknown, 0 free, 100 lethal,
            99 inscribed, 1-98 the inflation cost); row ``i`` is ``y = origin_y + i * res``, column ``j`` is
            ``x = origin_x + j * res`` (row-major from the lower-left corner, as ROS).
        origin_xy: world position (``map``) of the outer corner of cell ``(0, 0)``, m.
        resolution_m: cell side, m.
        version: changes whenever the map or the path does.
        path_xy: ``(N, 2)`` the global path planned on this map; None when there is none.
    """

    cells: npt.NDArray[np.int8]
    origin_xy: tuple[float, float]
    resolution_m: float
    version: int
    path_xy: npt.NDArray[np.float64] | None = None


@dataclass(frozen=True)
class WorldFrame:
    """What changed in the world at one tick. Fields left None did not change (or are not due).

    Attributes:
        tick: the tick number (1 for the first tick).
        stamp_s: the robot clock after the tick.
        pose: the base pose in ``map``.
        base_twist: the base velocity (body frame).
        command: the last commanded twist on the board (``cmd_twist``).
        observation: a new perceived RGB-D frame (with its camera pose and intrinsics).
        answer: the models' answer about the last perceived frame.
        arbitration: a new arbitration result.
        memory: the memory after a change.
        decision: a new decision step (the entry ``Decide`` wrote to the decision log: candidates with
            their Eq. 9 terms and utilities, the selected node, the reason).
        subgoal_changed: the subgoal on the board is a new one (``subgoal``, possibly None).
        subgoal: the subgoal on the board when ``subgoal_changed``.
        plan: a new controller cycle.
        map: the planner's map, when it changed and a redraw was due.
        events: mission events logged since the previous frame.
        outcome: the mission's outcome, on the last frame only.
    """

    tick: int
    stamp_s: float
    pose: Pose2D | None = None
    base_twist: Twist | None = None
    command: Twist | None = None
    observation: Observation | None = None
    answer: ModelAnswer | None = None
    arbitration: ArbitrationResult | None = None
    memory: MemoryFrame | None = None
    decision: Mapping[str, Any] | None = None
    subgoal_changed: bool = False
    subgoal: Subgoal | None = None
    plan: ControlResult | None = None
    map: MapLayer | None = None
    events: tuple[Mapping[str, Any], ...] = field(default_factory=tuple)
    outcome: str | None = None
