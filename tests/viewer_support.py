"""Shared by the view's tests: a saved view read back (the world through Rerun's own reader, the tick record)."""

from __future__ import annotations

import json
from pathlib import Path


def timed_rows(world_path: Path) -> dict[str, list[int]]:
    """The ticks at which each entity was logged, by entity path (Rerun's reader)."""
    import rerun.chunk as rrc

    ticks: dict[str, list[int]] = {}
    for chunk in rrc.RrdReader(str(world_path)).store().stream():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        ticks.setdefault(chunk.entity_path.lstrip("/"), []).extend(batch.column("tick").to_pylist())
    return {entity: sorted(values) for entity, values in ticks.items()}


def written_at(tick_lines: list[str], key: str) -> list[int]:
    """The ticks at which the tick record says ``key`` was written."""
    out = []
    for line in tick_lines:
        record = json.loads(line)
        if any(w["key"] == key for w in record["writes"]):
            out.append(record["tick"])
    return out
