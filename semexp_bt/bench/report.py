"""A sweep's report: ``write_report(DIR)`` reads ``DIR/episodes.jsonl`` and writes ``DIR/report.md``.

The report holds the episodes by status; SR, SPL, OASR, SA and GNSA per scene x strategy (and pooled
over scenes), each with its 95% interval (``bench.stats``, ``bench.markdown``); the median mission time
of the successful episodes; the episodes that
declared success away from the goal; the throughput per fidelity; per-stage latency and rate; the
plots (``bench.plots``); and the failed episodes with their error. Only finished rows
(``status == "ok"``) enter the metrics. The file is written whole or not at all.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from semexp_bt.bench.markdown import (
    latency_markdown,
    metric_table,
    outcome_table,
    refusal_cause_table,
    status_table,
    success_path_table,
    success_time_table,
)
from semexp_bt.bench.plots import write_plots
from semexp_bt.bench.protocol import REAL_SCENES, SIM_SCENES, TABLE_I_STRATEGIES, TABLE_II_STRATEGIES
from semexp_bt.bench.rows import STATUS_OK
from semexp_bt.bench.stats import (
    METRICS,
    cell_summaries,
    false_successes,
    latency_table,
    ok_rows,
    outcomes_and_safety,
    refusal_causes,
    success_paths,
    success_times,
    throughput_by_fidelity,
    wall_per_sim_second,
)
from semexp_bt.bench.store import EPISODES_FILE, load_rows, read_sweep_meta
from semexp_bt.core.durable import write_atomic

REPORT_FILE = "report.md"


def _ordered(values: Sequence[str], preferred: Sequence[str]) -> list[str]:
    head = [v for v in dict.fromkeys(preferred) if v in values]
    return head + sorted(v for v in values if v not in head)


def write_report(
    out_dir: Path, *, rows: Sequence[Mapping[str, Any]] | None = None, plots: bool = True
) -> Path:
    """Write ``out_dir/report.md`` (and ``out_dir/plots/`` when ``plots``) from the sweep's rows.

    Returns:
        The report's path.

    Raises:
        FileNotFoundError: when ``out_dir`` holds no ``episodes.jsonl`` and no rows are given.
    """
    out_dir = Path(out_dir)
    if rows is None:
        if not (out_dir / EPISODES_FILE).is_file():
            raise FileNotFoundError(
                f"{out_dir / EPISODES_FILE} does not exist: run 'semexp-bt bench missions' first"
            )
        rows = load_rows(out_dir)
    meta = read_sweep_meta(out_dir)
    scenes = _ordered(sorted({r["scene"] for r in rows}), SIM_SCENES + REAL_SCENES)
    strategies = _ordered(sorted({r["strategy"] for r in rows}), TABLE_I_STRATEGIES + TABLE_II_STRATEGIES)
    summaries = cell_summaries(rows)
    parts = [
        f"# Sweep report: {out_dir.name}",
        "",
        f"{len(rows)} episodes ({len(ok_rows(rows))} ok); fidelity {sorted({str(r.get('fidelity')) for r in rows})};"
        f" relevance {sorted({str(r.get('relevance')) for r in rows})}; code {meta.get('git_revision', '?')}.",
        "Cells: value in % and its 95% interval (Wilson for SR, OASR, SA; bootstrap over episodes for SPL and"
        " GNSA); `all` pools the scenes. Definitions: docs/metrics.md.",
        "",
        "## Episodes by status",
        "",
        status_table(rows),
    ]
    for metric, title in METRICS.items():
        parts += [
            "",
            f"## {title}",
            "",
            metric_table(summaries, metric, scenes=scenes, strategies=strategies),
        ]
    parts += [
        "",
        "## Mission time of successful episodes",
        "",
        "Simulated seconds from the start to the declared success, median over the successful episodes"
        " (their count in brackets).",
        "",
        success_time_table(success_times(rows), scenes=scenes, strategies=strategies),
        "",
        "## Paths of successful episodes",
        "",
        "Path length over the geodesic optimum L* (SPL counts a success at L* / max(path, L*)), and how the"
        " successes that had a confirmation refused on the way compare with the others.",
        "",
        success_path_table(success_paths(rows), strategies=strategies),
        "",
        "## Refused confirmations by cause",
        "",
        "Why `ConfirmTarget` refused (the `cause` of its `confirmation_rejected` events): too few further"
        " views voted, the votes' mean lay beyond the declaration distance, no vote had a detector box, or the"
        " names heard at the spot disagreed.",
        "",
        refusal_cause_table(refusal_causes(rows), strategies=strategies),
    ]
    parts += [
        "",
        "## Outcomes and safety",
        "",
        "How the finished episodes ended (a fall ends as `fallen`), and how many touched an obstacle or came"
        " closer than the clearance threshold at least once.",
        "",
        outcome_table(outcomes_and_safety(rows), strategies=strategies),
    ]
    wrong = false_successes(rows)
    parts += [
        "",
        "## Success declared away from the goal",
        "",
        f"{len(wrong)} of {len(ok_rows(rows))} episodes.",
    ]
    parts += [f"- `{key}`" for key in wrong]
    ratio = wall_per_sim_second(rows)
    if ratio is not None:
        parts += ["", f"Wall time per simulated second: {ratio:.3f} s (all finished episodes)."]
        parts += ["", "## Throughput", "", "| fidelity | episodes | episodes per hour per core | "
                  "wall s per simulated s |", "| --- | --- | --- | --- |"]  # fmt: skip
        for fidelity, figures in throughput_by_fidelity(rows).items():
            parts.append(f"| {fidelity} | {figures['episodes']:.0f} | {figures['episodes_per_hour_per_core']:.0f} | "
                         f"{figures['wall_s_per_sim_s']:.3f} |")  # fmt: skip
    latency = latency_table(rows)
    if latency:
        parts += ["", "## Per-stage latency and rate", "", latency_markdown(latency)]
    if plots:
        plot_files = write_plots(out_dir, rows, summaries=summaries, scenes=scenes, strategies=strategies)
        parts += ["", "## Plots", ""] + [
            f"![{f.stem}]({f.relative_to(out_dir).as_posix()})" for f in plot_files
        ]
    failures = [r for r in rows if r.get("status") != STATUS_OK]
    if failures:
        parts += ["", "## Failed episodes", ""]
        for r in failures[:50]:
            last = (str(r.get("error") or "").strip().splitlines() or ["?"])[-1]
            parts.append(f"- `{r['key']}`: {r['status']}: {last}")
    return write_atomic(out_dir / REPORT_FILE, "\n".join(parts) + "\n")
