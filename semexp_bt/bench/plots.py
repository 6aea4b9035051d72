"""A sweep's plots (matplotlib, Agg), each file written whole (``semexp_bt.core.durable``).

- ``bars_<metric>.png``: bars per scene, one per strategy, with 95% interval whiskers;
- ``spl_distribution.png``: each strategy's per-episode SPL terms;
- ``trajectory_<key>.png``: the base path and the final topological memory over the scene's top-down
  map, for up to :data:`MAX_TRAJECTORY_PLOTS` episodes whose trajectory the sweep kept.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from semexp_bt.bench.protocol import STRATEGY_TITLES
from semexp_bt.bench.rows import to_episode_record
from semexp_bt.bench.stats import METRICS, ok_rows
from semexp_bt.core import metrics
from semexp_bt.core.durable import atomic_target

PLOTS_DIR = "plots"
#: Most trajectory plots per report (they cost a geodesic oracle each).
MAX_TRAJECTORY_PLOTS = 6


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
    with atomic_target(path) as temporary:
        fig.savefig(temporary, dpi=110)
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
    with atomic_target(path) as temporary:
        fig.savefig(temporary, dpi=110)
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
    with atomic_target(path) as temporary:
        fig.savefig(temporary, dpi=110, bbox_inches="tight")
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
