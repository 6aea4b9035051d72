"""The blackboard schema: every key the mission tree uses, its type and what it holds.

This module is the one place where blackboard keys are named. Behaviours register keys through
:func:`register_keys`, which refuses a key that is not in :data:`SCHEMA`, and write through
:func:`checked_write`, which refuses a value of the wrong type. The topological memory lives on the
board under ``memory``.

Who reads and writes a key is not written here: each behaviour declares its ``READS`` and ``WRITES``
(:func:`key_access` turns them into one access per key), and ``trees.registry.key_uses`` collects them,
with the runner's initial writes, into the key table of ``docs/node_reference.md``.

Isolation: py_trees keeps one process-wide blackboard. :func:`fresh_board` clears it and its activity
stream before a mission, so two missions run one after another in one process share no state (they
cannot run concurrently in one process; the benchmark harness uses one process per worker).

Example:
    >>> from blackboard.schema import SCHEMA, key_access
    >>> SCHEMA["memory"].types
    (<class 'semexp_bt.core.memory.TopologicalMemory'>,)
    >>> key_access(reads=("subgoal", "memory"), writes=("memory",))
    {'subgoal': 'read', 'memory': 'read_write'}
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, fields, is_dataclass
from enum import Enum
from typing import Any, Literal

import numpy as np
import py_trees

from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.types import Detection, Observation, Pose2D, SafetyState, SceneEvidence, Subgoal, Twist
from semexp_bt.nav.costmap import Costmap
from semexp_bt.nav.global_planner import GlobalPlan

#: How a behaviour may use a key: ``read``, ``write``, or both.
KeyAccess = Literal["read", "write", "read_write"]


@dataclass(frozen=True)
class KeySpec:
    """One blackboard key.

    Attributes:
        key: the key (absolute, without the leading '/').
        types: accepted value types; ``type(None)`` in it means the key may hold None, ``object`` any value.
        doc: what it holds.
    """

    key: str
    types: tuple[type, ...]
    doc: str


_NONE = type(None)

SCHEMA: dict[str, KeySpec] = {
    spec.key: spec
    for spec in (
        KeySpec("instruction", (str,), "the current natural-language instruction"),
        KeySpec("target_label", (str,), "object phrase extracted from the instruction"),
        KeySpec("instructions_left", (list,), "instructions still to search for"),
        KeySpec("start_pose", (Pose2D,), "the robot's pose when the mission started"),
        KeySpec("memory", (TopologicalMemory,), "the controlled-growth semantic topological memory"),
        KeySpec("observation", (Observation, _NONE), "the last RGB-D frame perceived"),
        KeySpec("scene_evidence", (SceneEvidence, _NONE), "the VLM's last reply"),
        KeySpec(
            "detections",
            (tuple, _NONE),
            "the detector's last detections (None: the object-level source is missing)",
        ),
        KeySpec(
            "arbitration", (object,), "the last ArbitrationResult (every candidate with its score) or None"
        ),
        KeySpec("target", (object,), "the last arbitrated Target or None"),
        KeySpec(
            "local_map",
            (Costmap, _NONE),
            "the costmap built from depth and odometry (semexp_bt.nav.costmap.Costmap, odometry frame): "
            "paths are planned on it, frontiers come from it",
        ),
        KeySpec(
            "global_plan",
            (GlobalPlan, _NONE),
            "the last global plan to the subgoal (semexp_bt.nav.global_planner.GlobalPlan) or None",
        ),
        KeySpec(
            "nav_failure",
            (str, _NONE),
            "why navigation to the subgoal last failed (no_path, start_blocked, blocked, stuck) or was handed "
            "back (superseded: the instructed object came into view), or None",
        ),
        KeySpec("subgoal", (Subgoal, _NONE), "the subgoal being executed"),
        KeySpec("decision", (object,), "the last DecisionResult or None"),
        KeySpec("cmd_twist", (Twist,), "the base velocity command the gait executes"),
        KeySpec(
            "cmd_stamp_s",
            (float,),
            "backend time of the last cmd_twist write; the gait's watchdog stops a stale command",
        ),
        KeySpec("plan", (object,), "the controller's last ControlResult or None"),
        KeySpec("found_objects", (list,), "confirmed targets: label, position, stamp"),
        KeySpec(
            "mission_outcome",
            (str,),
            "running | success | budget_exceeded | fallen | stuck | failed | sensor_lost: <sensor> | "
            "sensor_fault: <sensor>",
        ),
        KeySpec("safety", (SafetyState, _NONE), "the backend's last safety state"),
    )
}


class SchemaError(KeyError):
    """A behaviour used a key that the schema does not define, or wrote a value of the wrong type."""


def key_access(*, reads: Iterable[str], writes: Iterable[str]) -> dict[str, KeyAccess]:
    """The access of every key a behaviour declares: ``read_write`` for a key it reads and writes, else
    ``write`` or ``read``; in declaration order, reads first.

    The one rule behind both the keys a behaviour registers (:func:`register_keys`) and the keys its
    node reference lists (``behaviours.base.SemExpBehaviour.BLACKBOARD_KEYS``).

    Raises:
        SchemaError: for a key the schema does not define.
    """
    reads, writes = tuple(reads), tuple(writes)
    access: dict[str, KeyAccess] = {}
    for key in dict.fromkeys((*reads, *writes)):
        if key not in SCHEMA:
            raise SchemaError(f"blackboard key '{key}' is not in blackboard.schema.SCHEMA")
        access[key] = "read_write" if key in reads and key in writes else "write" if key in writes else "read"
    return access


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
    access = key_access(reads=read, writes=write)
    remap = dict(remap or {})
    for logical, target in remap.items():
        if logical not in access:
            raise SchemaError(f"remap names key '{logical}' that this behaviour does not use")
        if target not in SCHEMA:
            raise SchemaError(f"blackboard key '{target}' is not in blackboard.schema.SCHEMA")
    for key, mode in access.items():
        board_key = "/" + remap.get(key, key)
        if mode != "write":
            client.register_key(key=key, access=py_trees.common.Access.READ, remap_to=board_key)
        if mode != "read":
            client.register_key(key=key, access=py_trees.common.Access.WRITE, remap_to=board_key)


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
        return [summarize(v) for v in value[:_LISTED_ITEMS]]
    if isinstance(value, np.ndarray):
        return value.round(3).tolist() if value.size <= 16 else f"array{list(value.shape)}"
    if is_dataclass(value) and not isinstance(value, type):
        out: dict[str, Any] = {}
        for k, v in _summary_fields(value).items():
            if isinstance(v, np.ndarray) and v.size > 16:
                continue
            if isinstance(v, (list, tuple)) and len(v) > _LISTED_ITEMS:
                v = f"<{len(v)} items>"
            out[k] = summarize(v)
        return out
    return repr(value)[:200]


#: Values that ``dataclasses.asdict`` deep-copies into an equal value of the same type (exact types: a
#: subclass may copy differently).
_ATOMIC_TYPES = frozenset({type(None), bool, int, float, str})
#: A list or tuple longer than this is summarised by its length alone (see :func:`summarize`).
_LISTED_ITEMS = 20


def _summary_fields(value: Any, *, nested: bool = False) -> dict[str, Any]:
    """A dataclass's fields as :func:`summarize` reads them: what ``dataclasses.asdict(value)`` returns, in
    all that the summary looks at, without its deep copy.

    Python 3.11's ``asdict`` deep-copies every float and array one Python call at a time: 10 µs for the
    ``Twist`` written at every tick and 45 µs for a ``ControlResult``, whose trajectory it copies only for
    the summary to skip it. Here a field is taken as it is when ``asdict`` would copy it into an equal
    value (an atom, an array, an enum member, a list, tuple or dict of atoms), and so is a list or tuple that
    the summary replaces by its length; a nested dataclass becomes the dict ``asdict`` makes of it (the
    summary prints it whole, so ``nested`` asks for one equal to ``asdict``'s); anything else falls back to
    ``asdict`` itself.
    """
    out: dict[str, Any] = {}
    for spec in fields(value):
        field_value = getattr(value, spec.name)
        if is_dataclass(field_value) and not isinstance(field_value, type):
            field_value = _summary_fields(field_value, nested=True)
        elif (nested or not _listed_by_length(field_value)) and not _copied_as_equal(field_value):
            return asdict(value)
        out[spec.name] = field_value
    return out


def _copied_as_equal(value: Any) -> bool:
    """Whether ``asdict`` copies ``value`` into an equal value of the same type."""
    kind = type(value)
    if kind in _ATOMIC_TYPES or isinstance(value, Enum):  # an enum member deep-copies to itself
        return True
    if kind is np.ndarray:
        return not value.dtype.hasobject
    if kind is list or kind is tuple:
        return all(type(item) in _ATOMIC_TYPES for item in value)
    if kind is dict:
        return all(type(k) in _ATOMIC_TYPES and type(v) in _ATOMIC_TYPES for k, v in value.items())
    return False


def _listed_by_length(value: Any) -> bool:
    """Whether a dataclass's field is a list or tuple that :func:`summarize` replaces by its length."""
    return type(value) in (list, tuple) and len(value) > _LISTED_ITEMS
