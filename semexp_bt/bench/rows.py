"""What a sweep's row holds: the runner's record, flattened, with the episode's key and status.

One row per episode, flat-ish: the runner's record without the per-decision candidate lists, the
per-event entries and the bulky snapshots (decisions keep ``selected_node_id`` and ``oracle_node_id``,
which is what GNSA needs; events are counted; found objects keep their labels), plus ``key``,
``config_hash``, ``relevance``, ``status`` (``ok``, ``error``, ``timeout``), ``error`` and
``harness_wall_s``; ``refusal_causes`` counts the refused confirmations by cause and ``refusals`` lists
them (:data:`REFUSAL_KEYS`); ``confirmations`` lists the declared ones (:data:`CONFIRMATION_KEYS`).
:func:`to_episode_record` is the one conversion from a row (or a record) to the metrics'
:class:`~semexp_bt.core.metrics.EpisodeRecord`. Where rows are stored: ``bench.store``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from semexp_bt.bench.sweep import EpisodeTask, HarnessError
from semexp_bt.core.metrics import EpisodeRecord

STATUS_OK = "ok"
STATUS_ERROR = "error"
STATUS_TIMEOUT = "timeout"

#: The event a refused confirmation leaves in an episode record (``ConfirmTarget``); rows count them by
#: the event's ``cause`` under ``refusal_causes`` (rows written before session 27 lack it).
CONFIRMATION_REJECTED = "confirmation_rejected"
#: What a row keeps of each refused confirmation, under ``refusals``: enough to tell, against the scene's
#: ground truth, a refused goal from a refused distractor (``position_m`` and ``robot_xy`` since session 33).
REFUSAL_KEYS = ("stamp_s", "cause", "reason", "position_m", "robot_xy", "first_vote_m")
#: The event a declared confirmation leaves, and what a row keeps of each under ``confirmations``
#: (``first_vote_m``, how far away the first vote lay, since session 34).
TARGET_CONFIRMED = "target_confirmed"
CONFIRMATION_KEYS = ("stamp_s", "position_m", "first_vote_m")
#: Record keys dropped from rows (bulky; the trajectory file keeps what plots need).
_DROPPED_KEYS = ("trajectory_xy", "memory_snapshot", "events", "decisions", "found_objects")
#: Record keys a row carries to the parent under ``EXTRAS_KEY`` for the trajectory file, not the row.
TRAJECTORY_KEYS = ("trajectory_xy", "memory_snapshot")
#: The row entry that holds what goes to the trajectory file; the parent removes it before writing.
EXTRAS_KEY = "_extras"


def flatten_record(record: Mapping[str, Any]) -> dict[str, Any]:
    """The runner's record as a JSONL row: decisions reduced, events counted, bulky parts dropped."""
    row = {k: v for k, v in record.items() if k not in _DROPPED_KEYS}
    row["decisions"] = [
        {
            "stamp_s": d.get("stamp_s"),
            "selected_node_id": d.get("selected_node_id"),
            "oracle_node_id": d.get("oracle_node_id"),
            "n_candidates": len(d.get("candidates", ())),
            "reason": d.get("reason"),
        }
        for d in record.get("decisions", ())
    ]
    counts: dict[str, int] = {}
    causes: dict[str, int] = {}
    refusals: list[dict[str, Any]] = []
    confirmations: list[dict[str, Any]] = []
    for event in record.get("events", ()):
        kind = str(event.get("kind", "?"))
        counts[kind] = counts.get(kind, 0) + 1
        if kind == CONFIRMATION_REJECTED:
            cause = str(event.get("cause") or "unknown")
            causes[cause] = causes.get(cause, 0) + 1
            refusals.append(_picked(event, REFUSAL_KEYS))
        elif kind == TARGET_CONFIRMED:
            confirmations.append(_picked(event, CONFIRMATION_KEYS))
    row["event_counts"] = counts
    row["refusal_causes"] = causes
    row["refusals"] = refusals
    row["confirmations"] = confirmations
    row["found_labels"] = [f.get("label") for f in record.get("found_objects", ())]
    return row


def _picked(event: Mapping[str, Any], keys: tuple[str, ...]) -> dict[str, Any]:
    """The entries of ``event`` under ``keys`` that it has (older records lack the later keys)."""
    return {key: event[key] for key in keys if key in event}


def finished_row(record: Mapping[str, Any]) -> dict[str, Any]:
    """The row of an episode that ran to its end: status ``ok``, the flattened record, and (under
    :data:`EXTRAS_KEY`) the trajectory, memory snapshot and goal when the record has them."""
    row = {"status": STATUS_OK, **flatten_record(record)}
    for bulky in TRAJECTORY_KEYS:
        if bulky in record:
            row.setdefault(EXTRAS_KEY, {})[bulky] = record[bulky]
    if record.get("goal") is not None and EXTRAS_KEY in row:
        row[EXTRAS_KEY]["goal"] = record["goal"]
    return row


def failure_row(task: EpisodeTask, status: str, message: str, wall_s: float) -> dict[str, Any]:
    """The row of an episode that did not finish (``error`` or ``timeout``), without its key fields."""
    return {"status": status, "error": message, "harness_wall_s": round(wall_s, 3),
            "scene": task.key.scene, "seed": task.key.seed, "strategy": task.key.strategy,
            "fidelity": task.key.fidelity}  # fmt: skip


def keyed_row(row: dict[str, Any], task: EpisodeTask) -> dict[str, Any]:
    """``row`` with the task's ``key``, ``config_hash`` and ``relevance`` first."""
    return {"key": task.key.id, "config_hash": task.key.config_hash, "relevance": task.relevance, **row}


def to_episode_record(row: Mapping[str, Any]) -> EpisodeRecord:
    """The runner's record (or a row of it) as a :class:`~semexp_bt.core.metrics.EpisodeRecord`.

    The metrics follow the paper's definitions on the final base position: ``goal_position_m`` is put
    at the record's ``distance_to_goal_m`` (distance from the final position to the goal object's
    footprint) along the line to the goal's centre, so ``||P - G||`` is exactly that distance.
    Decision steps without an oracle node (no reachable candidate) are not GNSA steps; a step with
    candidates but no selected node counts as a miss (``selected_node_id = -1``).

    Raises:
        HarnessError: naming the missing key.
    """
    try:
        final = row["final_pose"]
        final_xy = (float(final["x_m"]), float(final["y_m"]))
        centre = row["goal"]["position_m"]
        distance = float(row["distance_to_goal_m"])
        dx, dy = float(centre[0]) - final_xy[0], float(centre[1]) - final_xy[1]
        norm = math.hypot(dx, dy)
        goal_xy = (
            final_xy
            if norm < 1e-12
            else (final_xy[0] + dx / norm * distance, final_xy[1] + dy / norm * distance)
        )
        steps = [
            {"selected_node_id": -1 if d["selected_node_id"] is None else int(d["selected_node_id"]),
             "oracle_node_id": int(d["oracle_node_id"])}
            for d in row.get("decisions", ())
            if d.get("oracle_node_id") is not None
        ]  # fmt: skip
        return EpisodeRecord(
            scene=str(row["scene"]),
            seed=int(row["seed"]),
            strategy=str(row["strategy"]),
            success_declared=bool(row["success_declared"]),
            final_position_m=final_xy,
            goal_position_m=goal_xy,
            goal_category=str(row["goal_category"]),
            reached_category=row.get("reached_category"),
            path_length_m=float(row["path_length_m"]),
            geodesic_length_m=float(row["geodesic_length_m"]),
            collision=bool(row["collision"]),
            decisions=steps,  # type: ignore[arg-type]
            reached_named=row.get("reached_named"),
        )
    except KeyError as exc:
        where = f"{row.get('scene')}/{row.get('seed')}/{row.get('strategy')}"
        raise HarnessError(f"episode row {where}: missing key {exc.args[0]!r}") from None
