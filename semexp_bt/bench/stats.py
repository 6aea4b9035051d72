"""The numbers of a sweep's rows: metric summaries per cell, matched episodes, latency, throughput.

Only finished rows (``status == "ok"``) enter the metrics. Each summary is
:func:`semexp_bt.core.metrics.summarize`: SR, SPL, OASR, SA and GNSA with their 95% intervals (Wilson
for the rates, percentile bootstrap over episodes for SPL and GNSA). Comparisons between strategies
use matched episodes: the (scene, seed) pairs every compared strategy finished.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from semexp_bt.bench.rows import CONFIRMATION_REJECTED, STATUS_OK, to_episode_record
from semexp_bt.core import metrics

#: Pseudo-scene of the pooled column.
ALL_SCENES = "all"
#: Metrics of the report, in table order: key -> title.
METRICS: dict[str, str] = {
    "sr": "SR (success rate)",
    "spl": "SPL (success weighted by path length)",
    "oasr": "OASR (obstacle-avoidance success rate)",
    "sa": "SA (semantic accuracy)",
    "gnsa": "GNSA (global node selection accuracy)",
}


def ok_rows(rows: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """Rows of finished episodes (``status == "ok"``)."""
    return [r for r in rows if r.get("status") == STATUS_OK]


def summarize_rows(rows: Sequence[Mapping[str, Any]], *, bootstrap_seed: int = 0) -> dict[str, Any] | None:
    """:func:`semexp_bt.core.metrics.summarize` over the ok rows; None when there is none.

    Raises:
        ValueError: when the rows disagree on the success radius (one definition per comparison).
    """
    good = ok_rows(rows)
    if not good:
        return None
    radii = {float(r.get("success_radius_m", metrics.DEFAULT_SUCCESS_RADIUS_M)) for r in good}
    if len(radii) > 1:
        raise ValueError(f"rows mix success radii {sorted(radii)}; compare one r_s at a time")
    return metrics.summarize([to_episode_record(r) for r in good], success_radius_m=radii.pop(),
                             bootstrap_seed=bootstrap_seed)  # fmt: skip


def cell_summaries(rows: Sequence[Mapping[str, Any]]) -> dict[tuple[str, str], dict[str, Any]]:
    """``(scene, strategy)`` and ``(ALL_SCENES, strategy)`` -> summary, for cells with ok rows."""
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in ok_rows(rows):
        groups.setdefault((row["scene"], row["strategy"]), []).append(row)
        groups.setdefault((ALL_SCENES, row["strategy"]), []).append(row)
    out = {}
    for cell, members in groups.items():
        summary = summarize_rows(members)
        if summary is not None:
            out[cell] = summary
    return out


def succeeded(row: Mapping[str, Any]) -> bool:
    """Whether a finished episode's row is a success as SR counts it (:func:`semexp_bt.core.metrics.success`,
    at the row's own success radius)."""
    radius = float(row.get("success_radius_m", metrics.DEFAULT_SUCCESS_RADIUS_M))
    return metrics.success(to_episode_record(row), success_radius_m=radius)


def success_times(rows: Sequence[Mapping[str, Any]]) -> dict[tuple[str, str], dict[str, float]]:
    """``(scene, strategy)`` and ``(ALL_SCENES, strategy)`` -> the simulated mission time of the successful
    episodes (success as SR counts it, :func:`semexp_bt.core.metrics.success`): ``median_s`` and ``n``.
    Cells without a success are left out."""
    groups: dict[tuple[str, str], list[float]] = {}
    for row in ok_rows(rows):
        if row.get("sim_time_s") is None or not succeeded(row):
            continue
        for cell in ((row["scene"], row["strategy"]), (ALL_SCENES, row["strategy"])):
            groups.setdefault(cell, []).append(float(row["sim_time_s"]))
    return {cell: {"median_s": float(np.median(times)), "n": len(times)} for cell, times in groups.items()}


def success_paths(rows: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """Strategy -> how long the successful episodes' paths were against the geodesic optimum, the part of
    SPL that is lost on the way: ``successes``, ``ratio`` (median, first and third quartile of path / L*),
    ``rejected`` (successes with at least one refused confirmation) and the median ratio of the successes
    with and without one (``ratio_rejected``, ``ratio_clean``; None without such episodes). Success is
    SR's (:func:`semexp_bt.core.metrics.success`); episodes without an L* are left out."""
    ratios: dict[str, list[tuple[float, bool]]] = {}
    for row in ok_rows(rows):
        geodesic = row.get("geodesic_length_m")
        if not geodesic or not succeeded(row):
            continue
        ratio = float(row["path_length_m"]) / float(geodesic)
        rejected = (row.get("event_counts") or {}).get(CONFIRMATION_REJECTED, 0) > 0
        ratios.setdefault(row["strategy"], []).append((ratio, rejected))

    def median(values: list[float]) -> float | None:
        return float(np.median(values)) if values else None

    out: dict[str, dict[str, Any]] = {}
    for strategy, pairs in ratios.items():
        every = [r for r, _ in pairs]
        out[strategy] = {
            "successes": len(pairs),
            "ratio": tuple(float(q) for q in np.percentile(every, [50, 25, 75])),
            "rejected": sum(rejected for _, rejected in pairs),
            "ratio_rejected": median([r for r, rejected in pairs if rejected]),
            "ratio_clean": median([r for r, rejected in pairs if not rejected]),
        }
    return out


def refusal_causes(rows: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, dict[str, int]]]:
    """Strategy -> cause -> how often a confirmation was refused for it: ``refusals`` (events),
    ``episodes`` (with at least one) and ``successes`` (of those episodes, the successful ones; success
    is SR's). Rows without ``refusal_causes`` (written before session 27) are left out."""
    out: dict[str, dict[str, dict[str, int]]] = {}
    for row in ok_rows(rows):
        causes = row.get("refusal_causes")
        if not causes:
            continue
        success = succeeded(row)
        for cause, count in causes.items():
            cell = out.setdefault(row["strategy"], {}).setdefault(
                cause, {"refusals": 0, "episodes": 0, "successes": 0}
            )
            cell["refusals"] += int(count)
            cell["episodes"] += 1
            cell["successes"] += int(success)
    return out


def outcomes_and_safety(rows: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """Strategy -> how its finished episodes ended and what they touched: ``episodes``, ``outcomes`` (the
    mission outcome -> count, e.g. ``success``, ``budget_exceeded``, ``fallen``), ``with_contact`` and
    ``with_breach`` (episodes with at least one collision / clearance-breach event) and
    ``least_clearance_m`` (the median over episodes of their least clearance, where recorded)."""
    out: dict[str, dict[str, Any]] = {}
    clearances: dict[str, list[float]] = {}
    for row in ok_rows(rows):
        strategy = row["strategy"]
        cell = out.setdefault(strategy, {"episodes": 0, "outcomes": {}, "with_contact": 0, "with_breach": 0})
        cell["episodes"] += 1
        outcome = str(row.get("outcome", "?"))
        cell["outcomes"][outcome] = cell["outcomes"].get(outcome, 0) + 1
        cell["with_contact"] += int((row.get("collisions") or 0) > 0)
        cell["with_breach"] += int((row.get("clearance_breaches") or 0) > 0)
        if row.get("min_clearance_m") is not None:
            clearances.setdefault(strategy, []).append(float(row["min_clearance_m"]))
    for strategy, cell in out.items():
        least = clearances.get(strategy)
        cell["least_clearance_m"] = float(np.median(least)) if least else None
    return out


def matched_rows(
    rows: Sequence[Mapping[str, Any]], *, strategies: Sequence[str], scenes: Sequence[str]
) -> list[Mapping[str, Any]]:
    """Ok rows of ``strategies`` in ``scenes`` restricted to the (scene, seed) pairs all of them finished."""
    good = [r for r in ok_rows(rows) if r["strategy"] in strategies and r["scene"] in scenes]
    pairs: dict[tuple[str, int], set[str]] = {}
    for r in good:
        pairs.setdefault((r["scene"], int(r["seed"])), set()).add(r["strategy"])
    complete = {pair for pair, have in pairs.items() if have >= set(strategies)}
    return [r for r in good if (r["scene"], int(r["seed"])) in complete]


def latency_table(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per-stage latency and rate over ok rows (Table V).

    For each stage in the records' ``timings``: calls per episode (median), rate on the simulated clock
    (all calls / all simulated seconds), wall latency (median of the episodes' medians, median of their
    p95). The ``tick`` row is the whole tree tick (``tick_wall_ms``, p99 in place of p95).
    """
    good = [r for r in ok_rows(rows) if r.get("sim_time_s")]
    sim_total = sum(float(r["sim_time_s"]) for r in good)
    stages: dict[str, list[Mapping[str, Any]]] = {}
    for r in good:
        for stage, t in (r.get("timings") or {}).items():
            stages.setdefault(stage, []).append(t)
    table = []
    for stage in sorted(stages):
        entries = stages[stage]
        calls = sum(int(t["count"]) for t in entries)
        table.append({
            "stage": stage,
            "episodes": len(entries),
            "calls_per_episode": float(np.median([t["count"] for t in entries])),
            "rate_hz": calls / sim_total if sim_total else math.nan,
            "median_ms": float(np.median([t["median_ms"] for t in entries])),
            "p95_ms": float(np.median([t["p95_ms"] for t in entries])),
        })  # fmt: skip
    ticks = [r for r in good if r.get("tick_wall_ms") and r.get("ticks")]
    if ticks:
        table.append({
            "stage": "tick",
            "episodes": len(ticks),
            "calls_per_episode": float(np.median([r["ticks"] for r in ticks])),
            "rate_hz": sum(int(r["ticks"]) for r in ticks) / sum(float(r["sim_time_s"]) for r in ticks),
            "median_ms": float(np.median([r["tick_wall_ms"]["median"] for r in ticks])),
            "p95_ms": float(np.median([r["tick_wall_ms"].get("p99", math.nan) for r in ticks])),
        })  # fmt: skip
    return table


def intervals_disjoint(a: Sequence[float] | None, b: Sequence[float] | None) -> bool:
    """Whether interval ``a`` lies entirely above interval ``b`` (the only case we claim a gain)."""
    return a is not None and b is not None and a[0] > b[1]


def false_successes(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """Keys of finished episodes that declared success but did not end within r_s of the goal (the robot
    confirmed something else: a distractor, or the goal from too far)."""
    out = []
    for r in ok_rows(rows):
        radius = float(r.get("success_radius_m", metrics.DEFAULT_SUCCESS_RADIUS_M))
        record = to_episode_record(r)
        if record.success_declared and not metrics.success(record, success_radius_m=radius):
            out.append(str(r["key"]))
    return out


def wall_per_sim_second(rows: Sequence[Mapping[str, Any]]) -> float | None:
    """Total wall time over total simulated time of the finished episodes, or None without either."""
    good = [r for r in ok_rows(rows) if r.get("wall_time_s") is not None and r.get("sim_time_s")]
    sim = sum(float(r["sim_time_s"]) for r in good)
    return sum(float(r["wall_time_s"]) for r in good) / sim if sim > 0.0 else None


def throughput_by_fidelity(rows: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, float]]:
    """Per fidelity: finished episodes, episodes per hour per core, and wall time per simulated second.

    A worker runs one episode at a time on one core, so episodes per hour per core is the episode count
    over the episodes' own harness wall times (model loading and process start included), which does
    not depend on how many workers ran them.
    """
    finished = ok_rows(rows)
    out: dict[str, dict[str, float]] = {}
    for fidelity in sorted({str(r.get("fidelity")) for r in finished}):
        group = [r for r in finished if str(r.get("fidelity")) == fidelity]
        busy_s = sum(float(r.get("harness_wall_s") or r.get("wall_time_s") or 0.0) for r in group)
        ratio = wall_per_sim_second(group)
        out[fidelity] = {
            "episodes": float(len(group)),
            "episodes_per_hour_per_core": 3600.0 * len(group) / busy_s if busy_s > 0.0 else float("nan"),
            "wall_s_per_sim_s": float("nan") if ratio is None else ratio,
        }
    return out
