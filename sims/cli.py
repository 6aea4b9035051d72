"""``semexp-bt scene``: list the scene catalogue, or render one scene and an episode start.

``semexp-bt scene list`` prints name, title, area, goal object, instruction and object count.

``semexp-bt scene render SCENE --seed N --out DIR`` builds the scene with layout seed N, samples the
episode with the same seed (``--episode-seed`` to choose another) and writes into DIR:

- ``topdown.png``: obstacles, the inflated occupancy grid, the goal and its success region, distractors,
  occluders, the start pose, the geodesic path and a scale bar;
- ``episode.json``: the episode (start, goal object, L*, seeds) and the scene's size;
- ``rgb.png``, ``depth.png`` (colour-mapped, invalid pixels black) and ``segmentation.png`` (one colour per
  object id): the head camera at the start pose, rendered by the MuJoCo backend
  (``robots.mujoco_backend.MujocoRobot``, kinematic fidelity). ``--no-camera`` skips them.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import zlib
from pathlib import Path
from typing import Any, Literal

import numpy as np

from semexp_bt.scene import SceneSpec
from sims.catalogue import UnknownSceneError, build_scene, list_scenes, scene_summary
from sims.episodes import Episode, sample_episode
from sims.geodesic import GeodesicOracle

#: Exit status when the top-down files were written but the camera images could not be.
EXIT_CAMERA_UNAVAILABLE = 3
#: Pixels per metre of the top-down figure (capped for large scenes by the figure size).
_TOPDOWN_INCHES_PER_M = 0.55
_ROLE_EDGE: dict[str, tuple[str, float, Literal["-", "--"]]] = {
    "goal": ("#00c040", 3.0, "-"),
    "distractor": ("#ff8c00", 2.0, "--"),
    "occluder": ("#303030", 1.2, "-"),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the ``list`` and ``render`` sub-subcommands."""
    sub = parser.add_subparsers(dest="scene_command", metavar="{list,render}")
    sub.required = True
    sub.add_parser("list", help="print the scene catalogue")
    render = sub.add_parser("render", help="render a scene's top-down map, episode and head-camera images")
    render.add_argument("scene", help="scene name (see 'semexp-bt scene list')")
    render.add_argument("--seed", type=int, default=0, help="layout seed (default 0)")
    render.add_argument("--episode-seed", type=int, default=None, help="episode seed (default: --seed)")
    render.add_argument("--out", type=Path, required=True, help="output folder (created if missing)")
    render.add_argument("--no-camera", action="store_true", help="skip the MuJoCo head-camera images")


def run(args: argparse.Namespace) -> int:
    """Run ``scene list`` or ``scene render``."""
    if args.scene_command == "list":
        return _list()
    return _render(args)


def _list() -> int:
    header = ("name", "title", "area m^2", "goal object", "instruction", "objects")
    rows = [header]
    for name in list_scenes():
        s = scene_summary(name)
        rows.append((s.name, s.title, f"{s.area_m2:.0f}", s.goal_label, s.instruction, str(s.object_count)))
    widths = [max(len(row[i]) for row in rows) for i in range(len(header))]
    for index, row in enumerate(rows):
        print("  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)).rstrip())
        if index == 0:
            print("  ".join("-" * width for width in widths))
    return 0


def _render(args: argparse.Namespace) -> int:
    try:
        scene = build_scene(args.scene, seed=args.seed)
    except UnknownSceneError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    episode_seed = args.seed if args.episode_seed is None else args.episode_seed
    oracle = GeodesicOracle(scene)
    episode = sample_episode(scene, seed=episode_seed, oracle=oracle)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    path = oracle.path_to_object(
        (episode.start.x_m, episode.start.y_m),
        scene.goal_object_id,
        success_radius_m=episode.success_radius_m,
    )
    render_topdown(scene, episode, oracle, path, out / "topdown.png")
    (out / "episode.json").write_text(json.dumps(episode_record(scene, episode, path), indent=2) + "\n")
    print(f"wrote {out / 'topdown.png'} and {out / 'episode.json'} (L* = {episode.geodesic_length_m:.2f} m)")
    if args.no_camera:
        return 0
    return _render_camera(scene, episode, out)


def episode_record(scene: SceneSpec, episode: Episode, path: np.ndarray) -> dict[str, Any]:
    """What ``episode.json`` holds."""
    goal = scene.goal
    x_min, y_min, x_max, y_max = scene.bounds_m
    return {
        "episode": episode.to_dict(),
        "goal_object": {
            "object_id": goal.object_id,
            "name": goal.name,
            "label": goal.label,
            "category": goal.category,
            "position_m": list(goal.position_m),
        },
        "scene": {
            "name": scene.name,
            "title": scene.title,
            "seed": scene.seed,
            "bounds_m": list(scene.bounds_m),
            "size_m": [x_max - x_min, y_max - y_min],
            "area_m2": (x_max - x_min) * (y_max - y_min),
            "object_count": len(scene.objects),
        },
        "geodesic_path_m": np.round(path, 3).tolist(),
    }


def render_topdown(
    scene: SceneSpec, episode: Episode, oracle: GeodesicOracle, path: np.ndarray, out_file: Path
) -> None:
    """Draw the top-down map of ``scene`` with ``episode``'s start and geodesic path into ``out_file``."""
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
    fig.savefig(out_file, dpi=110)
    plt.close(fig)


def segmentation_colours(segmentation: np.ndarray) -> np.ndarray:
    """``(H, W, 3)`` uint8: a fixed colour per object id (from its CRC32), black for the background."""
    ids = np.unique(segmentation)
    image = np.zeros((*segmentation.shape, 3), dtype=np.uint8)
    for object_id in ids:
        if object_id < 0:
            continue
        code = zlib.crc32(int(object_id).to_bytes(4, "little", signed=True))
        colour = np.array([code & 0xFF, (code >> 8) & 0xFF, (code >> 16) & 0xFF], dtype=np.uint8) | 0x30
        image[segmentation == object_id] = colour
    return image


def depth_colours(depth_m: np.ndarray) -> np.ndarray:
    """``(H, W, 3)`` uint8 RGB: near is warm, far is cool (turbo), invalid (0, NaN, inf) black."""
    import cv2

    valid = np.isfinite(depth_m) & (depth_m > 0)
    scaled = np.zeros(depth_m.shape, dtype=np.uint8)
    if valid.any():
        far = float(np.percentile(depth_m[valid], 99))
        scaled[valid] = np.clip(255.0 * (1.0 - depth_m[valid] / max(far, 1e-6)), 0, 255).astype(np.uint8)
    coloured = cv2.cvtColor(cv2.applyColorMap(scaled, cv2.COLORMAP_TURBO), cv2.COLOR_BGR2RGB)
    coloured[~valid] = 0
    return coloured


def _render_camera(scene: SceneSpec, episode: Episode, out: Path) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    try:
        from robots.mujoco_backend import MujocoRobot
    except ImportError as exc:
        print(
            f"error: the head-camera images need robots.mujoco_backend.MujocoRobot, which could not be imported "
            f"({exc}); topdown.png and episode.json were written, rerun with --no-camera to skip the camera",
            file=sys.stderr,
        )
        return EXIT_CAMERA_UNAVAILABLE
    import cv2

    robot = MujocoRobot(scene=scene, fidelity="kinematic", start_pose=episode.start, seed=episode.seed)
    try:
        observation = robot.observe()
    finally:
        robot.close()
    cv2.imwrite(str(out / "rgb.png"), cv2.cvtColor(observation.rgb, cv2.COLOR_RGB2BGR))
    cv2.imwrite(str(out / "depth.png"), cv2.cvtColor(depth_colours(observation.depth_m), cv2.COLOR_RGB2BGR))
    if observation.segmentation is not None:
        segmentation = segmentation_colours(observation.segmentation)
        cv2.imwrite(str(out / "segmentation.png"), cv2.cvtColor(segmentation, cv2.COLOR_RGB2BGR))
    print(f"wrote {out / 'rgb.png'}, {out / 'depth.png'} and {out / 'segmentation.png'}")
    return 0
