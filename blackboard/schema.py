"""The blackboard schema: every key the mission tree uses, its type, and who writes it.

This module is the one place where blackboard keys are named. Behaviours register keys through
:func:`register_keys`, which refuses a key that is not in :data:`SCHEMA`, and write through
:func:`checked_write`, which refuses a value of the wrong type. The topological memory lives on the
board under ``memory``.

Isolation: py_trees keeps one process-wide blackboard. :func:`fresh_board` clears it and its activity
stream before a mission, so two missions run one after another in one process share no state (they
cannot run concurrently in one process; the benchmark harness uses one process per worker).

Example:
    >>> from blackboard.schema import SCHEMA
    >>> SCHEMA["memory"].writers
    ('runner', 'SeedMasterNode', 'UpdateMemory', 'ConfirmTarget', 'LowerSubgoalPotential')
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, is_dataclass
from typing import Any

import numpy as np
import py_trees

from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.types import Detection, Observation, Pose2D, SafetyState, SceneEvidence, Subgoal, Twist
from semexp_bt.nav.costmap import Costmap
from semexp_bt.nav.global_planner import GlobalPlan


@dataclass(frozen=True)
class KeySpec:
    """One blackboard key.

    Attributes:
        key: the key (absolute, without the leading '/').
        types: accepted value types; ``type(None)`` in it means the key may hold None.
        writers: the behaviours (or ``runner``) that write it.
        doc: what it holds.
    """

    key: str
    types: tuple[type, ...]
    writers: tuple[str, ...]
    doc: str


_NONE = type(None)


def _spec(key: str, types: tuple[type, ...], writers: tuple[str, ...], doc: str) -> tuple[str, KeySpec]:
    return key, KeySpec(key=key, types=types, writers=writers, doc=doc)


SCHEMA: dict[str, KeySpec] = dict(
    [
        _spec(
            "instruction", (str,), ("runner", "NextInstruction"), "the current natural-language instruction"
        ),
        _spec(
            "target_label",
            (str,),
            ("runner", "NextInstruction"),
            "object phrase extracted from the instruction",
        ),
        _spec(
            "instructions_left", (list,), ("runner", "NextInstruction"), "instructions still to search for"
        ),
        _spec("start_pose", (Pose2D,), ("runner",), "the robot's pose when the mission started"),
        _spec(
            "memory",
            (TopologicalMemory,),
            ("runner", "SeedMasterNode", "UpdateMemory", "ConfirmTarget", "LowerSubgoalPotential"),
            "the controlled-growth semantic topological memory",
        ),
        _spec(
            "observation",
            (Observation, _NONE),
            ("Perceive", "ConfirmTarget"),
            "the last RGB-D frame perceived",
        ),
        _spec(
            "scene_evidence", (SceneEvidence, _NONE), ("Perceive", "ConfirmTarget"), "the VLM's last reply"
        ),
        _spec(
            "detections",
            (tuple, _NONE),
            ("Perceive", "ConfirmTarget"),
            "the detector's last detections (None: the object-level source is missing)",
        ),
        _spec(
            "arbitration",
            (object,),
            ("Arbitrate", "ConfirmTarget"),
            "the last ArbitrationResult (every candidate with its score) or None",
        ),
        _spec("target", (object,), ("Arbitrate", "ConfirmTarget"), "the last arbitrated Target or None"),
        _spec(
            "local_map",
            (Costmap, _NONE),
            ("runner", "Perceive", "UpdateCostmap", "ClearCostmapAroundRobot"),
            "the costmap built from depth and odometry (semexp_bt.nav.costmap.Costmap, odometry frame): "
            "paths are planned on it, frontiers come from it",
        ),
        _spec(
            "global_plan",
            (GlobalPlan, _NONE),
            ("ComputePathToSubgoal",),
            "the last global plan to the subgoal (semexp_bt.nav.global_planner.GlobalPlan) or None",
        ),
        _spec(
            "nav_failure",
            (str, _NONE),
            ("ComputePathToSubgoal", "FollowPath", "StuckGuard"),
            "why navigation to the subgoal last failed (no_path, start_blocked, blocked, stuck) or None",
        ),
        _spec(
            "subgoal",
            (Subgoal, _NONE),
            ("Decide", "SetSubgoalToStart", "LowerSubgoalPotential"),
            "the subgoal being executed",
        ),
        _spec("decision", (object,), ("Decide",), "the last DecisionResult or None"),
        _spec(
            "cmd_twist",
            (Twist,),
            ("FollowPath", "RotateInPlace", "Spin", "BackUp", "Wait", "StopRobot"),
            "the base velocity command the gait executes",
        ),
        _spec(
            "cmd_stamp_s",
            (float,),
            ("FollowPath", "RotateInPlace", "Spin", "BackUp", "Wait", "StopRobot"),
            "backend time of the last cmd_twist write; the gait's watchdog stops a stale command",
        ),
        _spec("plan", (object,), ("FollowPath",), "the controller's last ControlResult or None"),
        _spec("found_objects", (list,), ("ConfirmTarget",), "confirmed targets: label, position, stamp"),
        _spec(
            "mission_outcome",
            (str,),
            ("runner", "StopRobot", "MissionBudgetGuard", "FallGuard", "StuckGuard"),
            "running | success | budget_exceeded | fallen | stuck | failed",
        ),
        _spec(
            "safety", (SafetyState, _NONE), ("ClearanceGuard", "FallGuard"), "the backend's last safety state"
        ),
    ]
)


class SchemaError(KeyError):
    """A behaviour used a key that the schema does not define, or wrote a value of the wrong type."""


def register_keys(
    client: py_trees.blackboard.Client,
    *,
    read: Iterable[str] = (),
    write: Iterable[str] = (),
    remap: Mapping[str, str] | None = None,
) -> None:
    """Register schema keys on a behaviour's blackboard client, applying the mission file's remapping.

    Args:
        client: the behaviour's client (``self.attach_blackboard_client()``).
        read: keys the behaviour reads.
        write: keys the behaviour writes (write implies read).
        remap: logical key -> board key, from the mission file's ``remap:``; the target key must be a
            schema key too, so a remap cannot smuggle an undocumented key onto the board.

    Raises:
        SchemaError: for a key or remap target the schema does not define.
    """
    remap = dict(remap or {})
    for logical in remap:
        if logical not in set(read) | set(write):
            raise SchemaError(f"remap names key '{logical}' that this behaviour does not use")
    for access, keys in ((py_trees.common.Access.READ, read), (py_trees.common.Access.WRITE, write)):
        for key in keys:
            target = remap.get(key, key)
            if key not in SCHEMA or target not in SCHEMA:
                raise SchemaError(f"blackboard key '{target}' is not in blackboard.schema.SCHEMA")
            client.register_key(key=key, access=access, remap_to="/" + target)


def checked_write(client: py_trees.blackboard.Client, key: str, value: Any) -> None:
    """Write ``value`` under ``key`` after checking it against the schema's types."""
    spec = SCHEMA[key]
    if object not in spec.types and not isinstance(value, spec.types):
        raise SchemaError(
            f"blackboard key '{key}' expects {[t.__name__ for t in spec.types]}, got {type(value).__name__}"
        )
    client.set(key, value, overwrite=True)


def fresh_board(*, activity_stream: bool = False) -> None:
    """Clear the process-wide blackboard (and its activity stream) before a mission."""
    py_trees.blackboard.Blackboard.clear()
    py_trees.blackboard.Blackboard.disable_activity_stream()
    if activity_stream:
        py_trees.blackboard.Blackboard.enable_activity_stream(maximum_size=10_000)


def summarize(value: Any) -> Any:
    """A short JSON-serialisable summary of a board value (for records and the display)."""
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, TopologicalMemory):
        return {"nodes": len(value), "edges": value.graph.number_of_edges()}
    if isinstance(value, Observation):
        return {"stamp_s": round(value.stamp_s, 3), "shape": list(value.depth_m.shape)}
    if isinstance(value, Detection):
        return {"label": value.label, "confidence": round(value.confidence, 3)}
    if isinstance(value, (list, tuple)):
        return [summarize(v) for v in value[:20]]
    if isinstance(value, np.ndarray):
        return value.round(3).tolist() if value.size <= 16 else f"array{list(value.shape)}"
    if is_dataclass(value) and not isinstance(value, type):
        out: dict[str, Any] = {}
        for k, v in asdict(value).items():
            if isinstance(v, np.ndarray) and v.size > 16:
                continue
            if isinstance(v, (list, tuple)) and len(v) > 20:
                v = f"<{len(v)} items>"
            out[k] = summarize(v)
        return out
    return repr(value)[:200]


def snapshot_board() -> dict[str, Any]:
    """Every schema key currently on the board, summarised."""
    storage = py_trees.blackboard.Blackboard.storage
    return {key: summarize(storage["/" + key]) for key in SCHEMA if "/" + key in storage}
