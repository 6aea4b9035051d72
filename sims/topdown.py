"""The scene's top-down map: obstacles, the inflated occupancy grid, the goal and its success region,
distractors, occluders, the start pose, the geodesic path and a scale bar (matplotlib, imported lazily).

``semexp-bt scene render`` writes it as ``topdown.png``; the sweep report draws trajectories over it.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from semexp_bt.core.scene import SceneSpec
from sims.episodes import Episode
from sims.geodesic import GeodesicOracle

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Pixels per metre of the top-down figure (capped for large scenes by the figure size).
_TOPDOWN_INCHES_PER_M = 0.55
_ROLE_EDGE: dict[str, tuple[str, float, Literal["-", "--"]]] = {
    "goal": ("#00c040", 3.0, "-"),
    "distractor": ("#ff8c00", 2.0, "--"),
    "occluder": ("#303030", 1.2, "-"),
}


def topdown_figure(scene: SceneSpec, episode: Episode, oracle: GeodesicOracle, path: np.ndarray) -> Figure:
    """The top-down map of ``scene`` with ``episode``'s start and geodesic path, as an open figure
    (its first axes is the map) for callers that draw over it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.patches as mpatches
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    x_min, y_min, x_max, y_max = scene.bounds_m
    width, depth = x_max - x_min, y_max - y_min
    fig, ax = plt.subplots(
        figsize=(max(6.0, width * _TOPDOWN_INCHES_PER_M) + 2.5, max(5.0, depth * _TOPDOWN_INCHES_PER_M))
    )
    occupancy = oracle.occupancy
    shade = np.where(occupancy.occupied, 0.55, np.where(occupancy.blocked, 0.82, 1.0))
    extent = (x_min, x_min + occupancy.geometry.cols * occupancy.geometry.resolution_m,
              y_min, y_min + occupancy.geometry.rows * occupancy.geometry.resolution_m)  # fmt: skip
    ax.imshow(shade, origin="lower", extent=extent, cmap="gray", vmin=0.0, vmax=1.0, interpolation="nearest")
    goal_zone = oracle.object_goal_mask(scene.goal_object_id, success_radius_m=episode.success_radius_m)
    if goal_zone.any():
        ax.contourf(
            goal_zone.astype(float),
            levels=[0.5, 1.5],
            colors=["#7be39a"],
            alpha=0.45,
            extent=extent,
            origin="lower",
        )
    for obj in scene.objects:
        if obj.role == "wall":
            continue
        edge, line_width, style = _ROLE_EDGE.get(obj.role, ("#606060", 0.6, "-"))
        x, y, _ = obj.position_m
        if obj.shape == "cylinder":
            patch: mpatches.Patch = mpatches.Circle((x, y), obj.size_m[0])
        else:
            hx, hy = obj.size_m[0], obj.size_m[1]
            corner = (x - hx * math.cos(obj.yaw_rad) + hy * math.sin(obj.yaw_rad),
                      y - hx * math.sin(obj.yaw_rad) - hy * math.cos(obj.yaw_rad))  # fmt: skip
            patch = mpatches.Rectangle(corner, 2 * hx, 2 * hy, angle=math.degrees(obj.yaw_rad))
        patch.set_facecolor(obj.rgba[:3])
        patch.set_alpha(0.35 if not obj.is_obstacle else 0.95)
        patch.set_edgecolor(edge)
        patch.set_linewidth(line_width)
        patch.set_linestyle(style)
        if obj.role == "occluder":
            patch.set_hatch("//")
        ax.add_patch(patch)
        if obj.role in ("goal", "distractor"):
            ax.annotate(obj.label, (x, y), xytext=(4, 4), textcoords="offset points", fontsize=7, color=edge)
    if len(path):
        ax.plot(path[:, 0], path[:, 1], "-", color="#1f5fff", linewidth=2.0)
    start = episode.start
    arrow_m = 0.5
    ax.add_patch(
        mpatches.Circle((start.x_m, start.y_m), occupancy.robot_radius_m, fill=False, color="#1f5fff")
    )
    ax.arrow(start.x_m, start.y_m, arrow_m * math.cos(start.yaw_rad), arrow_m * math.sin(start.yaw_rad),
             width=0.06, head_width=0.22, head_length=0.18, color="#1f5fff", length_includes_head=True)  # fmt: skip
    ax.add_artist(
        AnchoredSizeBar(ax.transData, 1.0, "1 m", loc="lower left", pad=0.4, frameon=True, size_vertical=0.05)
    )
    ax.set_xlim(x_min - 0.2, x_max + 0.2)
    ax.set_ylim(y_min - 0.2, y_max + 0.2)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(
        f"{scene.title} (seed {scene.seed}, episode {episode.seed}): '{scene.instruction}', "
        f"L* = {episode.geodesic_length_m:.2f} m",
        fontsize=9,
    )
    handles = [
        mpatches.Patch(facecolor="white", edgecolor=_ROLE_EDGE["goal"][0], linewidth=2, label="goal"),
        mpatches.Patch(
            facecolor="#7be39a", alpha=0.45, label=f"success region (r_s = {episode.success_radius_m} m)"
        ),
        mpatches.Patch(
            facecolor="white", edgecolor=_ROLE_EDGE["distractor"][0], linestyle="--", label="distractor"
        ),
        mpatches.Patch(facecolor="white", edgecolor="#303030", hatch="//", label="occluder"),
        mpatches.Patch(facecolor="#d1d1d1", label=f"inflated by {occupancy.robot_radius_m} m"),
        Line2D([], [], color="#1f5fff", linewidth=2, label="start pose and geodesic path"),
    ]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    fig.tight_layout()
    return fig


def render_topdown(
    scene: SceneSpec, episode: Episode, oracle: GeodesicOracle, path: np.ndarray, out_file: Path
) -> None:
    """Draw the top-down map of ``scene`` with ``episode``'s start and geodesic path into ``out_file``."""
    import matplotlib.pyplot as plt

    fig = topdown_figure(scene, episode, oracle, path)
    fig.savefig(out_file, dpi=110)
    plt.close(fig)
