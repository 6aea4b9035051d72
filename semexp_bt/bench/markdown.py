"""Markdown tables of a sweep: metric cells with their 95% intervals, latency, episodes by status.

A metric cell reads ``55.0 [34, 74]``: the value in percent and its 95% interval; ``-`` where the
metric is undefined. Rows are strategies (by :data:`~semexp_bt.bench.protocol.STRATEGY_TITLES`),
columns scenes plus the pooled ``all``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from semexp_bt.bench.protocol import STRATEGY_TITLES
from semexp_bt.bench.stats import ALL_SCENES


def pct(value: float | None) -> str:
    """``0.553`` -> ``55.3``; None -> ``-``."""
    return (
        "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{100.0 * value:.1f}"
    )


def cell_text(summary: Mapping[str, Any] | None, metric: str) -> str:
    """``55.0 [34, 74]`` (percent, 95% interval); ``-`` when the metric is undefined."""
    if summary is None or summary.get(metric) is None:
        return "-"
    ci = summary.get(f"{metric}_ci95")
    interval = "" if ci is None else f" [{100 * ci[0]:.0f}, {100 * ci[1]:.0f}]"
    return f"{pct(summary[metric])}{interval}"


def metric_table(
    summaries: Mapping[tuple[str, str], Mapping[str, Any]],
    metric: str,
    *,
    scenes: Sequence[str],
    strategies: Sequence[str],
    paper: Mapping[str, Sequence[float]] | None = None,
) -> str:
    """Markdown: one row per strategy, one column per scene (+ pooled), cells ``value [lo, hi]``.

    With ``paper`` (strategy -> values per scene), each cell also shows the paper's number.
    """
    columns = list(scenes) + [ALL_SCENES]
    lines = ["| strategy | " + " | ".join(columns) + " | n |", "| --- " * (len(columns) + 2) + "|"]
    for strategy in strategies:
        cells = []
        for index, scene in enumerate(columns):
            text = cell_text(summaries.get((scene, strategy)), metric)
            if paper is not None and strategy in paper:
                values = paper[strategy]
                ref = float(np.mean(values)) if scene == ALL_SCENES else values[index]
                text += f" (paper {ref:.1f})"
            cells.append(text)
        pooled = summaries.get((ALL_SCENES, strategy))
        n = pooled["n_episodes"] if pooled else 0
        lines.append(f"| {STRATEGY_TITLES.get(strategy, strategy)} | " + " | ".join(cells) + f" | {n} |")
    return "\n".join(lines)


def success_time_table(
    times: Mapping[tuple[str, str], Mapping[str, float]], *, scenes: Sequence[str], strategies: Sequence[str]
) -> str:
    """Markdown of :func:`~semexp_bt.bench.stats.success_times`: one row per strategy, one column per scene
    (+ pooled), cells ``median s (n)``; ``-`` where no episode succeeded."""
    columns = list(scenes) + [ALL_SCENES]
    lines = ["| strategy | " + " | ".join(columns) + " |", "| --- " * (len(columns) + 1) + "|"]
    for strategy in strategies:
        cells = []
        for scene in columns:
            cell = times.get((scene, strategy))
            cells.append("-" if cell is None else f"{cell['median_s']:.1f} ({cell['n']:.0f})")
        lines.append(f"| {STRATEGY_TITLES.get(strategy, strategy)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def outcome_table(cells: Mapping[str, Mapping[str, Any]], *, strategies: Sequence[str]) -> str:
    """Markdown of :func:`~semexp_bt.bench.stats.outcomes_and_safety`: one row per strategy; the outcomes
    as ``name n`` by count, then the episodes with a contact and with a breach."""
    lines = [
        "| strategy | episodes | outcomes | with a contact | with a clearance breach | median least clearance (m) |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for strategy in strategies:
        cell = cells.get(strategy)
        if cell is None:
            continue
        outcomes = ", ".join(
            f"{name} {count}"
            for name, count in sorted(cell["outcomes"].items(), key=lambda kv: (-kv[1], kv[0]))
        )
        least = "-" if cell["least_clearance_m"] is None else f"{cell['least_clearance_m']:.3f}"
        lines.append(
            f"| {STRATEGY_TITLES.get(strategy, strategy)} | {cell['episodes']} | {outcomes} | "
            f"{cell['with_contact']} | {cell['with_breach']} | {least} |"
        )
    return "\n".join(lines)


def success_path_table(cells: Mapping[str, Mapping[str, Any]], *, strategies: Sequence[str]) -> str:
    """Markdown of :func:`~semexp_bt.bench.stats.success_paths`: one row per strategy with successes."""
    lines = [
        "| strategy | successes | path / L*, median (quartiles) | with a refused confirmation | "
        "their median path / L* | the others' |",
        "| --- | --- | --- | --- | --- | --- |",
    ]

    def ratio(value: float | None) -> str:
        return "-" if value is None else f"{value:.2f}"

    for strategy in strategies:
        cell = cells.get(strategy)
        if cell is None:
            continue
        median, low, high = cell["ratio"]
        lines.append(
            f"| {STRATEGY_TITLES.get(strategy, strategy)} | {cell['successes']} | {median:.2f} ({low:.2f}-{high:.2f})"
            f" | {cell['rejected']} | {ratio(cell['ratio_rejected'])} | {ratio(cell['ratio_clean'])} |"
        )
    return "\n".join(lines)


def refusal_cause_table(
    cells: Mapping[str, Mapping[str, Mapping[str, int]]], *, strategies: Sequence[str]
) -> str:
    """Markdown of :func:`~semexp_bt.bench.stats.refusal_causes`: one row per strategy and cause."""
    lines = [
        "| strategy | cause | refusals | episodes with one | of them successful |",
        "| --- | --- | --- | --- | --- |",
    ]
    for strategy in strategies:
        for cause, cell in sorted(cells.get(strategy, {}).items()):
            lines.append(
                f"| {STRATEGY_TITLES.get(strategy, strategy)} | {cause} | {cell['refusals']} | {cell['episodes']}"
                f" | {cell['successes']} |"
            )
    if len(lines) == 2:
        lines.append("| - | no refusal recorded (rows before session 27 do not record causes) | | | |")
    return "\n".join(lines)


def latency_markdown(
    table: Sequence[Mapping[str, Any]], *, paper: Mapping[str, tuple[str, str, str]] | None = None
) -> str:
    """Markdown of :func:`~semexp_bt.bench.stats.latency_table`.

    With ``paper`` (stage -> the paper's module, rate and latency), each row also shows the paper's
    figures, and the paper's stages we do not measure get a row of their own.
    """
    header = "| stage | calls/episode | rate (Hz, sim clock) | median (ms, wall) | p95 (ms, wall) |"
    if paper is not None:
        header += " paper module | paper rate | paper latency |"
    lines = [header, "|" + " --- |" * (header.count("|") - 1)]
    for row in table:
        line = (f"| {row['stage']} | {row['calls_per_episode']:.0f} | {row['rate_hz']:.2f} | "
                f"{row['median_ms']:.2f} | {row['p95_ms']:.2f} |")  # fmt: skip
        if paper is not None:
            module, rate, latency = paper.get(row["stage"], ("-", "-", "-"))
            line += f" {module} | {rate} | {latency} |"
        lines.append(line)
    if paper is not None:
        measured = {row["stage"] for row in table}
        for stage, (module, rate, latency) in paper.items():
            if stage not in measured:
                lines.append(
                    f"| {stage} | - | - | not measured (emulated) | - | {module} | {rate} | {latency} |"
                )
    return "\n".join(lines)


def status_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """Markdown: episodes per strategy by status."""
    counts: dict[str, dict[str, int]] = {}
    for row in rows:
        by_status = counts.setdefault(str(row.get("strategy")), {})
        by_status[str(row.get("status"))] = by_status.get(str(row.get("status")), 0) + 1
    statuses = sorted({s for c in counts.values() for s in c})
    lines = ["| strategy | " + " | ".join(statuses) + " |", "|" + " --- |" * (len(statuses) + 1)]
    for strategy in sorted(counts):
        lines.append(
            f"| {strategy} | " + " | ".join(str(counts[strategy].get(s, 0)) for s in statuses) + " |"
        )
    return "\n".join(lines)
