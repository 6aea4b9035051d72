"""Compare two sweeps episode by episode: are the results the same, and how did the wall time change?

A change meant to make episodes faster without changing them (a vectorised map update, a cheaper render
pass) is checked by running the same grid before and after it and comparing the rows by key
(``scene/seed/strategy/fidelity/config_hash``). Everything in a row is compared except the fields that
measure the machine rather than the episode (:data:`WALL_CLOCK_FIELDS`). The wall time of the matched
episodes, before and after, gives the change's effect on whole episodes under the same grid.

Example::

    semexp-bt bench missions --scenes office,road --seeds 0-1 --out runs/before   # on the old commit
    semexp-bt bench missions --scenes office,road --seeds 0-1 --out runs/after    # on the new commit
    semexp-bt bench compare runs/before runs/after

The exit status is 0 when every matched episode is identical, 1 when some differ (each is listed with
the fields that differ; an episode that finished in one sweep and failed in the other differs in
``status``), 2 when the two folders share no episode.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: Row fields that measure the machine, not the episode: stage and tick wall times, the episode's, its
#: mission loop's and the harness's wall time, and the mission file's path (the key's config hash already
#: covers its content).
WALL_CLOCK_FIELDS = frozenset(
    {"timings", "tick_wall_ms", "tick_cpu_ms", "wall_time_s", "mission_wall_s", "harness_wall_s", "mission"}
)


@dataclass(frozen=True)
class SweepComparison:
    """Two sweeps' rows matched by key.

    Attributes:
        matched: keys both sweeps have, finished (status ``ok``) in at least one of them.
        differing: key -> names of the fields that differ, for matched keys whose rows differ; an
            episode that finished in one sweep and failed (``error``, ``timeout``) in the other differs
            in ``status``.
        only_before: finished keys only the first sweep has.
        only_after: finished keys only the second sweep has.
        wall_before_s: harness wall time of the episodes finished in both, in the first sweep.
        wall_after_s: the same in the second sweep.
        sim_before_s: simulated time of the episodes finished in both, in the first sweep.
        sim_after_s: the same in the second sweep.
    """

    matched: int
    differing: dict[str, list[str]] = field(default_factory=dict)
    only_before: int = 0
    only_after: int = 0
    wall_before_s: float = 0.0
    wall_after_s: float = 0.0
    sim_before_s: float = 0.0
    sim_after_s: float = 0.0

    @property
    def identical(self) -> int:
        """Matched episodes whose rows agree on every field but the wall-clock ones."""
        return self.matched - len(self.differing)

    def to_dict(self) -> dict[str, Any]:
        ratio = self.wall_after_s / self.wall_before_s if self.wall_before_s > 0 else None
        return {
            "matched": self.matched,
            "identical": self.identical,
            "differing": self.differing,
            "only_before": self.only_before,
            "only_after": self.only_after,
            "wall_before_s": round(self.wall_before_s, 3),
            "wall_after_s": round(self.wall_after_s, 3),
            "wall_ratio": None if ratio is None else round(ratio, 4),
            "sim_before_s": round(self.sim_before_s, 3),
            "sim_after_s": round(self.sim_after_s, 3),
        }


def _by_key(rows: Sequence[Mapping[str, Any]]) -> dict[str, Mapping[str, Any]]:
    return {row["key"]: row for row in rows if "key" in row}


def _finished(row: Mapping[str, Any]) -> bool:
    return row.get("status") == "ok"


def _canonical(value: Any) -> str:
    # JSON text compares NaN equal to NaN (both read back as new float objects, and nan != nan).
    return json.dumps(value, sort_keys=True)


def _differing_fields(before: Mapping[str, Any], after: Mapping[str, Any]) -> list[str]:
    names = (set(before) | set(after)) - WALL_CLOCK_FIELDS
    return sorted(name for name in names if _canonical(before.get(name)) != _canonical(after.get(name)))


def compare_sweeps(
    before: Sequence[Mapping[str, Any]], after: Sequence[Mapping[str, Any]]
) -> SweepComparison:
    """Match two sweeps' rows by key and compare those finished in either, field by field.

    Args:
        before: rows of the first sweep (``bench.store.load_rows``).
        after: rows of the second sweep.
    """
    first, second = _by_key(before), _by_key(after)
    matched = [k for k in first if k in second and (_finished(first[k]) or _finished(second[k]))]
    both_finished = {k for k in matched if _finished(first[k]) and _finished(second[k])}
    differing = {}
    for key in matched:
        fields = _differing_fields(first[key], second[key]) if key in both_finished else ["status"]
        if fields:
            differing[key] = fields

    def total(rows: Mapping[str, Mapping[str, Any]], name: str) -> float:
        return sum(float(rows[key].get(name) or 0.0) for key in both_finished)

    return SweepComparison(
        matched=len(matched),
        differing=differing,
        only_before=sum(1 for k, row in first.items() if _finished(row) and k not in second),
        only_after=sum(1 for k, row in second.items() if _finished(row) and k not in first),
        wall_before_s=total(first, "harness_wall_s"),
        wall_after_s=total(second, "harness_wall_s"),
        sim_before_s=total(first, "sim_time_s"),
        sim_after_s=total(second, "sim_time_s"),
    )


def format_comparison(comparison: SweepComparison, *, before: Path, after: Path) -> str:
    """A short text summary: matched, identical, differing (with fields), wall time before and after."""
    c = comparison
    lines = [
        f"{c.matched} episodes in both {before} and {after} "
        f"({c.only_before} only in the first, {c.only_after} only in the second)",
        f"identical apart from wall-clock fields: {c.identical} of {c.matched}",
    ]
    for key, fields in c.differing.items():
        lines.append(f"  differs: {key}: {', '.join(fields)}")
    if c.wall_before_s > 0 and c.sim_before_s > 0 and c.sim_after_s > 0:
        change = 100.0 * (c.wall_after_s / c.wall_before_s - 1.0)
        lines.append(
            f"wall time of the episodes finished in both: {c.wall_before_s:.1f} s -> {c.wall_after_s:.1f} s "
            f"({change:+.0f} %); per simulated second {c.wall_before_s / c.sim_before_s:.3f} s -> "
            f"{c.wall_after_s / c.sim_after_s:.3f} s"
        )
    return "\n".join(lines)
