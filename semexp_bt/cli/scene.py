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
import os
import sys
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from semexp_bt.cli.arguments import output_folder, scene_name, seed
from semexp_bt.core.scene import SceneSpec
from sims.catalogue import UnknownSceneError, build_scene, list_scenes, scene_summary
from sims.episodes import Episode, sample_episode
from sims.geodesic import GeodesicOracle
from sims.topdown import render_topdown

#: Exit status when the top-down files were written but the camera images could not be.
EXIT_CAMERA_UNAVAILABLE = 3


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the ``list`` and ``render`` sub-subcommands."""
    sub = parser.add_subparsers(dest="scene_command", metavar="{list,render}")
    sub.required = True
    sub.add_parser("list", help="print the scene catalogue")
    render = sub.add_parser("render", help="render a scene's top-down map, episode and head-camera images")
    render.add_argument("scene", type=scene_name, help="scene name (see 'semexp-bt scene list')")
    render.add_argument("--seed", type=seed, default=0, help="layout seed (default 0)")
    render.add_argument("--episode-seed", type=seed, default=None, help="episode seed (default: --seed)")
    render.add_argument("--out", type=output_folder, required=True, help="output folder (created if missing)")
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
