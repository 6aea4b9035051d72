"""Reports of a sweep: markdown tables with 95% intervals, matplotlib plots, and the paper's tables.

``write_report(DIR)`` reads ``DIR/episodes.jsonl`` and writes ``DIR/report.md`` and ``DIR/plots/``:

- SR, SPL, OASR, SA and GNSA per scene x strategy (and pooled over scenes), each with its 95% interval
  (Wilson for the rates, percentile bootstrap over episodes for SPL and GNSA; ``semexp_bt.core.metrics``);
- bars per scene with 95% intervals (``bars_<metric>.png``), SPL distributions (``spl_distribution.png``),
  trajectories with the topological memory over the top-down map (``trajectory_*.png``) for the
  episodes whose trajectory the sweep kept;
- per-stage latency and rate from the records' timings, and the failed episodes with their error.

``write_paper_results(rows, path, ...)`` writes the paper's Tables I-V with the paper's numbers beside
ours (``docs/results.md``). Comparisons between strategies use matched episodes: the (scene, seed)
pairs every compared strategy finished. An improvement is claimed only where the 95% intervals do not
overlap.

Only successful rows (``status == "ok"``) enter the metrics; failures are counted and listed.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from semexp_bt.bench.harness import (
    EPISODES_FILE,
    REAL_SCENES,
    SIM_SCENES,
    STATUS_OK,
    SWEEP_META_FILE,
    TABLE_I_STRATEGIES,
    TABLE_II_STRATEGIES,
    TABLE_III_REFERENCES,
    TABLE_IV_STRATEGIES,
    load_rows,
    to_episode_record,
)
from semexp_bt.core import metrics

REPORT_FILE = "report.md"
PLOTS_DIR = "plots"
#: Pseudo-scene of the pooled column.
ALL_SCENES = "all"
#: Metrics of the report, in table order: key -> (title, is a rate with a Wilson interval).
METRICS: dict[str, str] = {
    "sr": "SR (success rate)",
    "spl": "SPL (success weighted by path length)",
    "oasr": "OASR (obstacle-avoidance success rate)",
    "sa": "SA (semantic accuracy)",
    "gnsa": "GNSA (global node selection accuracy)",
}
#: Most trajectory plots per report (they cost a geodesic oracle each).
MAX_TRAJECTORY_PLOTS = 6

# The paper's numbers (Sec. IV, Tables I-IV), in percent, by our scene and strategy names.
PAPER_TABLE_I: dict[str, tuple[float, ...]] = {  # SA per sim scene, SIM_SCENES order
    "vlm_only": (80.2, 81.6, 84.0, 80.6, 79.5),
    "detector_only": (81.7, 83.3, 85.6, 82.9, 80.8),
    "yolo_world": (83.1, 84.4, 85.9, 83.5, 82.2),
    "naive_fusion": (84.7, 86.1, 88.2, 83.8, 83.5),
    "ours": (88.9, 91.0, 92.3, 89.6, 88.7),
}
PAPER_TABLE_II: dict[str, tuple[float, ...]] = {  # GNSA per sim scene
    "bayesian": (76.5, 78.4, 79.7, 78.8, 75.9),
    "llm_relevance": (79.4, 81.6, 82.9, 81.8, 80.2),
    "vlfm": (81.1, 83.3, 84.7, 83.5, 80.8),
    "hovsg": (82.5, 83.8, 85.2, 84.4, 82.6),
    "ours": (84.6, 86.1, 87.3, 86.6, 84.2),
}
PAPER_TABLE_III: dict[str, tuple[str, float, float, float]] = {  # goal object, OASR, SR, SPL
    "garden_sim": ("green bin", 79.3, 55, 33.6),
    "sidewalk": ("traffic sign", 80.9, 60, 40.5),
    "road": ("bus station", 84.2, 75, 46.3),
    "warehouse_a": ("loading cart", 82.7, 65, 42.2),
    "warehouse_b": ("extinguisher", 79.5, 50, 29.7),
    "office": ("extinguisher", 75.8, 50, 33.5),
    "showroom": ("quadruped robot", 77.2, 55, 35.4),
    "laboratory": ("black chair", 75.6, 45, 33.2),
    "living_room": ("bucket shelf", 71.9, 40, 26.8),
    "garden_real": ("carton box", 73.1, 45, 28.9),
}
PAPER_TABLE_IV: dict[str, tuple[float, float]] = {  # SR, SPL
    "ablation_baseline": (35, 23.5),
    "ablation_arbitration": (45, 30.8),
    "ours": (55, 34.2),
}
#: Table V of the paper: our stage name -> (paper module, paper rate, paper latency).
PAPER_TABLE_V: dict[str, tuple[str, str, str]] = {
    "perception (VLM)": ("Qwen-VL reasoning", "on demand", "~2.5 s"),
    "perception (detector)": ("GroundingDINO", "on demand", "~1.2 s"),
    "arbitration": ("Evidence arbitration", "on demand", "~15 ms"),
    "memory_update": ("Topology update", "on demand", "-"),
    "decision": ("Utility decision", "on demand", "~2.0 s"),
    "planner": ("Trajectory tracking", "12 Hz", "real-time"),
    "tick": ("Motion policy", "50 Hz", "real-time"),
}
STRATEGY_TITLES = {
    "vlm_only": "VLM only (Qwen2.5-VL)",
    "detector_only": "Detector only (GroundingDINO)",
    "yolo_world": "YOLO-World profile",
    "naive_fusion": "Naive fusion (Qwen+GDINO)",
    "bayesian": "Bayesian probability",
    "llm_relevance": "LLM relevance (GPT-4 stand-in)",
    "vlfm": "VLFM-style value frontier",
    "hovsg": "HOV-SG-style hierarchical",
    "nearest_frontier": "Nearest frontier (geometry)",
    "oracle": "Oracle (privileged goal)",
    "ablation_baseline": "Baseline",
    "ablation_arbitration": "+ Evidence arbitration",
    "ours": "Ours",
}


# --------------------------------------------------------------------------------------------------
# Numbers
# --------------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------------
# Markdown
# --------------------------------------------------------------------------------------------------


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


def latency_markdown(table: Sequence[Mapping[str, Any]], *, with_paper: bool = False) -> str:
    """Markdown of :func:`latency_table`."""
    header = "| stage | calls/episode | rate (Hz, sim clock) | median (ms, wall) | p95 (ms, wall) |"
    if with_paper:
        header += " paper module | paper rate | paper latency |"
    lines = [header, "|" + " --- |" * (header.count("|") - 1)]
    for row in table:
        line = (f"| {row['stage']} | {row['calls_per_episode']:.0f} | {row['rate_hz']:.2f} | "
                f"{row['median_ms']:.2f} | {row['p95_ms']:.2f} |")  # fmt: skip
        if with_paper:
            module, rate, latency = PAPER_TABLE_V.get(row["stage"], ("-", "-", "-"))
            line += f" {module} | {rate} | {latency} |"
        lines.append(line)
    if with_paper:
        measured = {row["stage"] for row in table}
        for stage, (module, rate, latency) in PAPER_TABLE_V.items():
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


def _ordered(values: Sequence[str], preferred: Sequence[str]) -> list[str]:
    head = [v for v in dict.fromkeys(preferred) if v in values]
    return head + sorted(v for v in values if v not in head)


def _read_meta(out_dir: Path) -> dict[str, Any]:
    path = out_dir / SWEEP_META_FILE
    return json.loads(path.read_text()) if path.is_file() else {}


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
    meta = _read_meta(out_dir)
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
    path = out_dir / REPORT_FILE
    path.write_text("\n".join(parts) + "\n")
    return path


# --------------------------------------------------------------------------------------------------
# Plots
# --------------------------------------------------------------------------------------------------


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_metric_bars(
    summaries: Mapping[tuple[str, str], Mapping[str, Any]],
    metric: str,
    *,
    scenes: Sequence[str],
    strategies: Sequence[str],
    path: Path,
) -> Path | None:
    """Grouped bars per scene (one per strategy) with 95% interval whiskers; None with nothing to draw."""
    if not any(summaries.get((s, k), {}).get(metric) is not None for s in scenes for k in strategies):
        return None
    plt = _pyplot()
    width = 0.8 / max(len(strategies), 1)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.2 * len(scenes) + 2.0), 3.6))
    x = np.arange(len(scenes))
    for i, strategy in enumerate(strategies):
        values, low, high = [], [], []
        for scene in scenes:
            s = summaries.get((scene, strategy), {})
            v, ci = s.get(metric), s.get(f"{metric}_ci95")
            values.append(100 * v if v is not None else np.nan)
            low.append(100 * (v - ci[0]) if v is not None and ci else 0.0)
            high.append(100 * (ci[1] - v) if v is not None and ci else 0.0)
        ax.bar(x + (i - (len(strategies) - 1) / 2) * width, values, width, yerr=[low, high], capsize=2,
               label=STRATEGY_TITLES.get(strategy, strategy))  # fmt: skip
    ax.set_xticks(x, scenes, rotation=20)
    ax.set_ylim(0, 105)
    ax.set_ylabel(f"{metric.upper()} (%)")
    ax.set_title(f"{METRICS.get(metric, metric)} per scene, 95% intervals", fontsize=9)
    ax.legend(fontsize=7, ncols=2, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_spl_distribution(
    rows: Sequence[Mapping[str, Any]], *, strategies: Sequence[str], path: Path
) -> Path | None:
    """Per strategy: the episodes' SPL terms (box plot and jittered points; failures sit at 0)."""
    data = []
    for strategy in strategies:
        records = [to_episode_record(r) for r in ok_rows(rows) if r["strategy"] == strategy]
        data.append([metrics.spl_value(rec) for rec in records])
    if not any(data):
        return None
    plt = _pyplot()
    rng = np.random.default_rng(0)
    fig, ax = plt.subplots(figsize=(max(5.0, 1.1 * len(strategies) + 1.5), 3.4))
    ax.boxplot([d or [np.nan] for d in data], showfliers=False)
    for i, d in enumerate(data, start=1):
        ax.scatter(i + rng.uniform(-0.15, 0.15, len(d)), d, s=8, alpha=0.6)
    ax.set_xticks(range(1, len(strategies) + 1), strategies, rotation=20)
    ax.set_ylim(-0.05, 1.05)
    ax.set_ylabel("SPL per episode")
    ax.set_title("SPL distribution (all scenes; failures score 0)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_trajectory(payload: Mapping[str, Any], *, path: Path) -> Path:
    """The episode's base path and final topological memory over the scene's top-down map.

    The map is ``sims.topdown.topdown_figure`` (obstacles, inflated grid, goal region, start and geodesic
    path); the path and the memory are drawn over it.
    """
    from sims.catalogue import build_scene
    from sims.episodes import sample_episode
    from sims.geodesic import GeodesicOracle
    from sims.topdown import topdown_figure

    plt = _pyplot()
    seed = int(payload["seed"])
    scene = build_scene(str(payload["scene"]), seed=seed)
    oracle = GeodesicOracle(scene)
    episode = sample_episode(scene, seed=seed, oracle=oracle)
    geodesic = oracle.path_to_object((episode.start.x_m, episode.start.y_m), scene.goal_object_id,
                                     success_radius_m=episode.success_radius_m)  # fmt: skip
    fig = topdown_figure(scene, episode, oracle, geodesic)
    ax = fig.axes[0]
    memory = payload.get("memory_snapshot") or {}
    positions = {n["id"]: n["position"] for n in memory.get("nodes", ())}
    for a, b, *_ in memory.get("edges", ()):
        if a in positions and b in positions:
            ax.plot([positions[a][0], positions[b][0]], [positions[a][1], positions[b][1]], "-",
                    color="#8a2be2", linewidth=0.7, alpha=0.6, zorder=4)  # fmt: skip
    nodes = memory.get("nodes", ())
    if nodes:
        xy = np.array([n["position"][:2] for n in nodes], dtype=float)
        conf = np.array([n["confidence"] for n in nodes], dtype=float)
        points = ax.scatter(xy[:, 0], xy[:, 1], c=conf, cmap="plasma", vmin=0, vmax=1, s=28, edgecolors="k",
                            linewidths=0.4, zorder=5)  # fmt: skip
        fig.colorbar(
            points, ax=ax, orientation="horizontal", fraction=0.04, pad=0.12, label="node confidence C_f"
        )
        for n in nodes:
            if n.get("is_master"):
                ax.scatter([n["position"][0]], [n["position"][1]], marker="*", s=140, c="gold", edgecolors="k",
                           zorder=6)  # fmt: skip
    track = np.asarray(payload.get("trajectory_xy") or [], dtype=float)
    if track.size:
        ax.plot(track[:, 0], track[:, 1], "-", color="#d62728", linewidth=1.6, zorder=5)
        ax.scatter([track[-1, 0]], [track[-1, 1]], marker="X", s=70, c="#d62728", zorder=6)
    ax.set_title(f"{payload['scene']} seed {seed}, {payload.get('strategy')}: {payload.get('outcome')}"
                 f" (red: robot path, purple: memory graph, colour: C_f, star: master node)", fontsize=8)  # fmt: skip
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def write_plots(
    out_dir: Path,
    rows: Sequence[Mapping[str, Any]],
    *,
    summaries: Mapping[tuple[str, str], Mapping[str, Any]],
    scenes: Sequence[str],
    strategies: Sequence[str],
) -> list[Path]:
    """Bars for SR, SPL, SA, GNSA; the SPL distribution; a few trajectories. Returns the files written."""
    folder = out_dir / PLOTS_DIR
    folder.mkdir(exist_ok=True)
    figures: list[Path | None] = [
        plot_metric_bars(summaries, m, scenes=scenes, strategies=strategies, path=folder / f"bars_{m}.png")
        for m in ("sr", "spl", "sa", "gnsa")
    ]
    figures.append(plot_spl_distribution(rows, strategies=strategies, path=folder / "spl_distribution.png"))
    with_tracks = [r for r in ok_rows(rows) if r.get("trajectory_file")]
    with_tracks.sort(key=lambda r: (r["strategy"] != "ours", r["scene"], r["seed"]))
    for row in with_tracks[:MAX_TRAJECTORY_PLOTS]:
        source = out_dir / row["trajectory_file"]
        if source.is_file():
            payload = json.loads(source.read_text())
            figures.append(
                plot_trajectory(payload, path=folder / f"trajectory_{Path(row['trajectory_file']).stem}.png")
            )
    return [f for f in figures if f is not None]


# --------------------------------------------------------------------------------------------------
# The paper's tables (docs/results.md)
# --------------------------------------------------------------------------------------------------

#: Where our simulated world differs from the paper's, stated in every results file.
DIFFERENCES = """\
- **Perception is emulated.** The paper ran Qwen2.5-VL (cloud API) and GroundingDINO (RTX 4090). Here the
  perception emulator (`sims/perception_emulator.py`) turns what the MuJoCo camera really sees into
  detector-like and VLM-like evidence with a configured noise model, calibrated against the paper's
  single-source rows of Table I. Table I therefore measures our arbitration against *emulated* sources;
  it says nothing about real Qwen or GroundingDINO.
- **GPT-4 is replaced** by the offline relevance scorer (MiniLM sentence embeddings, or the lexical scorer
  where stated) for the "LLM relevance" row of Table II.
- **VLFM and HOV-SG are re-implemented decision rules** (`semexp_bt/decision_baselines.py`,
  `semexp_bt/strategies.py`), not the published systems: VLFM-style = value without travel cost;
  HOV-SG-style = best region by mean relevance, then best node, regions being 3 m grid cells.
- **Our scenes are not the paper's.** The paper used Isaac Sim (CARLA Town, Warehouse) and five real rooms;
  ours are MuJoCo scenes built from the paper's descriptions (`sims/scenes/`), including simulated analogues
  of the five real environments. "Real" rows of Table III are simulated here.
- **Kinematic fidelity** (when the header says so) moves the base by the commanded twist; the RL gait and
  its tracking errors are not in the loop. Collisions and clearance are still checked.
- **Latency** of the models is simulated on the sim clock (VLM ~2.5 s, detector ~1.2 s); Table V's wall
  latencies are those of our own code on the machine named above, not of the models.
- **Trial counts** of Tables I, II and IV are ours (the paper gives none); Table III's is in the header's
  protocol line (the paper's, and the command's default, is 20 per scene).
  Comparisons use matched episodes (the same scene and seed for every strategy compared).
"""


def _claims(
    summaries: Mapping[tuple[str, str], Mapping[str, Any]], metric: str, strategies: Sequence[str]
) -> str:
    """One sentence per baseline: is ``ours`` higher with non-overlapping pooled 95% intervals?"""
    ours = summaries.get((ALL_SCENES, "ours"))
    if ours is None or ours.get(metric) is None:
        return "No pooled result for ours: no claim."
    sentences = []
    for strategy in strategies:
        if strategy == "ours":
            continue
        other = summaries.get((ALL_SCENES, strategy))
        if other is None or other.get(metric) is None:
            continue
        if intervals_disjoint(ours.get(f"{metric}_ci95"), other.get(f"{metric}_ci95")):
            verdict = "ours is higher (95% intervals do not overlap)"
        elif intervals_disjoint(other.get(f"{metric}_ci95"), ours.get(f"{metric}_ci95")):
            verdict = "ours is LOWER (95% intervals do not overlap)"
        else:
            verdict = "intervals overlap: no difference claimed"
        sentences.append(f"ours {pct(ours[metric])} vs {strategy} {pct(other[metric])}: {verdict}.")
    return " ".join(sentences) or "No baseline result: no claim."


def write_paper_results(
    rows: Sequence[Mapping[str, Any]],
    path: Path,
    *,
    header: Mapping[str, Any],
    figures_dir: Path | None = None,
) -> Path:
    """Write the paper's Tables I-V with the paper's numbers beside ours.

    Args:
        rows: the protocol's rows (``load_rows``).
        path: the markdown file (``docs/results.md``).
        header: facts about the run, printed first (machine, command, wall time, episodes/h/core, ...).
        figures_dir: where to put the tables' bar plots (linked relative to ``path``); None: no plots.

    Returns:
        ``path``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    parts = ["# Results: the paper's tables on our simulated world", "",
             "Generated by `semexp-bt bench paper`; do not edit by hand.", ""]  # fmt: skip
    parts += [f"- **{k}**: {v}" for k, v in header.items()]
    parts += ["", "## How this differs from the paper", "", DIFFERENCES]
    figures: list[Path] = []

    def bars(summ: Mapping[tuple[str, str], Mapping[str, Any]], metric: str, scenes: Sequence[str],
             strategies: Sequence[str], name: str) -> None:  # fmt: skip
        if figures_dir is None:
            return
        figures_dir.mkdir(parents=True, exist_ok=True)
        made = plot_metric_bars(summ, metric, scenes=scenes, strategies=strategies, path=figures_dir / name)
        if made is not None:
            link = os.path.relpath(made, path.parent)
            parts.extend(["", f"![{name}]({Path(link).as_posix()})"])
            figures.append(made)

    for title, metric, strategies, paper in (
        ("Table I: semantic accuracy (SA, %) per evidence strategy", "sa", TABLE_I_STRATEGIES, PAPER_TABLE_I),
        ("Table II: global node selection accuracy (GNSA, %) per decision strategy", "gnsa", TABLE_II_STRATEGIES,
         PAPER_TABLE_II),
    ):  # fmt: skip
        subset = matched_rows(rows, strategies=strategies, scenes=SIM_SCENES)
        summ = cell_summaries(subset)
        n_pairs = len({(r["scene"], r["seed"]) for r in subset})
        parts += ["", f"## {title}", "",
                  f"Matched episodes: {n_pairs} (scene, seed) pairs run by every strategy. Cells: ours [95% interval]"
                  " (paper).", "", metric_table(summ, metric, scenes=SIM_SCENES, strategies=strategies, paper=paper),
                  "", _claims(summ, metric, strategies)]  # fmt: skip
        bars(summ, metric, SIM_SCENES, strategies, f"table_{metric}.png")

    everywhere = SIM_SCENES + REAL_SCENES
    ours = cell_summaries([r for r in rows if r.get("strategy") == "ours" and r.get("scene") in everywhere])
    parts += ["", "## Table III: object search, ours, per scene (OASR, SR, SPL in %)", "",
              "| scene | goal | n | OASR | SR | SPL | paper OASR | paper SR | paper SPL |",
              "|" + " --- |" * 9]  # fmt: skip
    for scene in everywhere:
        s = ours.get((scene, "ours"))
        goal, p_oasr, p_sr, p_spl = PAPER_TABLE_III[scene]
        n = s["n_episodes"] if s else 0
        parts.append(f"| {scene} | {goal} | {n} | {cell_text(s, 'oasr')} | {cell_text(s, 'sr')} | {cell_text(s, 'spl')}"
                     f" | {p_oasr} | {p_sr} | {p_spl} |")  # fmt: skip
    refs = ("ours",) + TABLE_III_REFERENCES
    ref_rows = matched_rows(rows, strategies=refs, scenes=everywhere)
    ref_summ = cell_summaries(ref_rows)
    parts += ["", "Reference strategies on matched episodes (all ten scenes pooled):", "",
              "| strategy | n | OASR | SR | SPL |", "|" + " --- |" * 5]  # fmt: skip
    for strategy in refs:
        s = ref_summ.get((ALL_SCENES, strategy))
        parts.append(f"| {STRATEGY_TITLES.get(strategy, strategy)} | {s['n_episodes'] if s else 0} | "
                     f"{cell_text(s, 'oasr')} | {cell_text(s, 'sr')} | {cell_text(s, 'spl')} |")  # fmt: skip
    parts += [
        "",
        "The oracle reads the true goal position (privileged): an upper bound for this tree, not a method.",
    ]
    bars(ours, "sr", everywhere, ("ours",), "table_iii_sr.png")

    ablation = matched_rows(rows, strategies=TABLE_IV_STRATEGIES, scenes=SIM_SCENES)
    ab_summ = cell_summaries(ablation)
    parts += ["", "## Table IV: ablation (five sim scenes pooled, SR and SPL in %)", "",
              f"Matched episodes: {len({(r['scene'], r['seed']) for r in ablation})} (scene, seed) pairs.", "",
              "| method | arbitration | utility decision | n | SR | SPL | paper SR | paper SPL |", "|" + " --- |" * 8]  # fmt: skip
    for strategy, arb, util in (("ablation_baseline", "no", "no"), ("ablation_arbitration", "yes", "no"),
                                ("ours", "yes", "yes")):  # fmt: skip
        s = ab_summ.get((ALL_SCENES, strategy))
        p_sr, p_spl = PAPER_TABLE_IV[strategy]
        parts.append(f"| {STRATEGY_TITLES[strategy]} | {arb} | {util} | {s['n_episodes'] if s else 0} | "
                     f"{cell_text(s, 'sr')} | {cell_text(s, 'spl')} | {p_sr} | {p_spl} |")  # fmt: skip
    parts += ["", _claims(ab_summ, "sr", TABLE_IV_STRATEGIES)]

    latency = latency_table([r for r in rows if r.get("strategy") == "ours"])
    parts += ["", "## Table V: per-module latency and rate (ours)", "",
              "Rates are calls per simulated second; latencies are wall-clock on this machine. The perception"
              " models' latency is emulated on the sim clock (VLM ~2.5 s, detector ~1.2 s), so it is not measured.",
              "", latency_markdown(latency, with_paper=True) if latency else "(no timings recorded)"]  # fmt: skip
    path.write_text("\n".join(parts) + "\n")
    return path
