"""Measure the MuJoCo backend: physics steps per second, render time per frame, idle real-time factor.

Usage (the figures in docs/simulation.md come from this command):

    MUJOCO_GL=egl .venv/bin/python scripts/measure_sim.py --json runs/measure_sim.json

The scene is a seeded 8 m x 6 m room (4 walls, 20 boxes and cylinders), built here so that the benchmark
does not depend on the scene catalogue. Each figure is the median of ``--repeats`` runs; render times also give
the best run (``*_best_ms``), the least disturbed by other processes on a shared machine.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from robots.camera import CameraConfig
from robots.mujoco_backend import MujocoRobot
from semexp_bt.core.scene import SceneObject, SceneSpec, Shape
from semexp_bt.core.types import PixelGrid, Pose2D, Twist
from semexp_bt.nav.costmap import CostmapConfig

ROOM_HALF_X_M = 4.0
ROOM_HALF_Y_M = 3.0
NUM_OBJECTS = 20


def benchmark_scene(seed: int) -> SceneSpec:
    """A walled room with ``NUM_OBJECTS`` random boxes and cylinders away from the start pose."""
    rng = np.random.default_rng(seed)
    walls = [
        ((0.0, ROOM_HALF_Y_M + 0.05), (ROOM_HALF_X_M + 0.1, 0.05)),
        ((0.0, -ROOM_HALF_Y_M - 0.05), (ROOM_HALF_X_M + 0.1, 0.05)),
        ((ROOM_HALF_X_M + 0.05, 0.0), (0.05, ROOM_HALF_Y_M)),
        ((-ROOM_HALF_X_M - 0.05, 0.0), (0.05, ROOM_HALF_Y_M)),
    ]
    objects = [
        SceneObject(
            object_id=i,
            name=f"wall_{i}",
            label="wall",
            category="wall",
            shape="box",
            position_m=(x, y, 1.25),
            size_m=(hx, hy, 1.25),
            role="wall",
            rgba=(0.85, 0.85, 0.8, 1.0),
        )
        for i, ((x, y), (hx, hy)) in enumerate(walls)
    ]
    while len(objects) < len(walls) + NUM_OBJECTS:
        x, y = (
            rng.uniform(-ROOM_HALF_X_M + 0.5, ROOM_HALF_X_M - 0.5),
            rng.uniform(-ROOM_HALF_Y_M + 0.5, ROOM_HALF_Y_M - 0.5),
        )
        if abs(x) < 1.0 and abs(y) < 1.0:
            continue
        object_id = len(objects)
        shape: Shape = "box" if rng.random() < 0.6 else "cylinder"
        size = rng.uniform(0.1, 0.5, 3)
        if shape == "cylinder":
            size[1] = size[0]
        objects.append(
            SceneObject(
                object_id=object_id,
                name=f"thing_{object_id}",
                label="thing",
                category="thing",
                shape=shape,
                position_m=(x, y, size[2]),
                size_m=tuple(size),
                yaw_rad=rng.uniform(-np.pi, np.pi),
                rgba=(*rng.uniform(0.1, 0.9, 3), 1.0),
            )
        )
    return SceneSpec(
        name="bench_room",
        title="Benchmark room",
        seed=seed,
        bounds_m=(-ROOM_HALF_X_M, -ROOM_HALF_Y_M, ROOM_HALF_X_M, ROOM_HALF_Y_M),
        objects=tuple(objects),
        goal_object_id=len(walls),
        instruction="find the thing",
    )


def median_of(repeats: int, measure: Callable[[], float]) -> float:
    return statistics.median(measure() for _ in range(repeats))


def median_and_best(repeats: int, measure: Callable[[], float]) -> tuple[float, float]:
    """Median and smallest of ``repeats`` runs: on a shared machine the smallest is the least disturbed."""
    runs = [measure() for _ in range(repeats)]
    return statistics.median(runs), min(runs)


def physics_figures(scene: SceneSpec, fidelity: str, seconds: float, repeats: int) -> dict[str, float]:
    robot = MujocoRobot(scene=scene, fidelity=fidelity, start_pose=Pose2D(0.0, 0.0, 0.0), seed=0)  # type: ignore[arg-type]
    figures: dict[str, float] = {}

    def idle_rtf() -> float:
        start = time.perf_counter()
        robot.advance(seconds)
        return seconds / (time.perf_counter() - start)

    figures["idle_real_time_factor"] = median_of(repeats, idle_rtf)
    robot.command_twist(Twist(0.3, 0.0, 0.4))  # circles without reaching a wall
    figures["moving_real_time_factor"] = median_of(repeats, idle_rtf)
    if fidelity == "dynamic":
        model, data = robot.model, robot.data
        steps = int(seconds / robot.physics_dt_s)

        def raw_steps() -> float:
            start = time.perf_counter()
            for _ in range(steps):
                mujoco.mj_step(model, data)
            return steps / (time.perf_counter() - start)

        figures["mj_step_per_s"] = median_of(repeats, raw_steps)
        figures["physics_dt_s"] = robot.physics_dt_s
    else:
        figures["kinematic_step_per_s"] = figures["moving_real_time_factor"] / robot.control_dt_s
        figures["kinematic_step_dt_s"] = robot.control_dt_s
    robot.close()
    return figures


def catalogue_figures(seconds: float, frames: int) -> dict[str, dict[str, float]]:
    """Per catalogue scene: idle real-time factor in both fidelities (robot at its episode start, seed 0)
    and the time of one full ``observe()`` (RGB + depth + segmentation) there."""
    from sims.catalogue import build_scene, list_scenes
    from sims.episodes import sample_episode

    out: dict[str, dict[str, float]] = {}
    for name in list_scenes():
        scene = build_scene(name, seed=0)
        start = sample_episode(scene, seed=0).start
        row: dict[str, float] = {"objects": float(len(scene.objects))}
        for fidelity in ("kinematic", "dynamic"):
            robot = MujocoRobot(scene=scene, fidelity=fidelity, start_pose=start, seed=0)
            t0 = time.perf_counter()
            robot.advance(seconds)
            row[f"{fidelity}_idle_rtf"] = seconds / (time.perf_counter() - t0)
            if fidelity == "kinematic":
                robot.observe()  # the renderer's first frame pays its set-up
                t0 = time.perf_counter()
                for _ in range(frames):
                    robot.observe()
                row["observe_ms"] = (time.perf_counter() - t0) / frames * 1e3
            robot.close()
        out[name] = row
    return out


def render_figures(
    scene: SceneSpec, camera: CameraConfig, frames: int, repeats: int
) -> dict[str, float | str]:
    robot = MujocoRobot(
        scene=scene, fidelity="kinematic", start_pose=Pose2D(0.0, 0.0, 0.3), seed=0, camera=camera
    )
    robot.observe()  # creates the GL context
    rgbd = robot.camera
    assert rgbd is not None
    figures: dict[str, float | str] = {"size": f"{camera.width_px}x{camera.height_px}"}
    try:
        from OpenGL import GL

        figures["gl_renderer"] = GL.glGetString(GL.GL_RENDERER).decode()
    except Exception as err:
        figures["gl_renderer"] = f"unknown ({type(err).__name__})"
    tasks: dict[str, Callable[[], object]] = {
        "rgb_ms": lambda: rgbd.render_rgb(robot.data),
        "depth_ms": lambda: rgbd.render_depth(robot.data),
        "segmentation_ms": lambda: rgbd.render_segmentation(robot.data),
        "observe_ms": robot.observe,
        "observe_depth_ms": robot.observe_depth,
    }
    grids = [PixelGrid.centred(CostmapConfig().pixel_stride)]  # the costmap's pixels (UpdateCostmap's)
    tasks["observe_depth_rays_ms"] = lambda: robot.observe_depth(pixel_grids=grids)
    figures["ray_count"] = int(np.isfinite(robot.observe_depth(pixel_grids=grids).depth_m).sum())
    for name, task in tasks.items():

        def per_frame(task: Callable[[], object] = task) -> float:
            start = time.perf_counter()
            for _ in range(frames):
                task()
            return 1e3 * (time.perf_counter() - start) / frames

        figures[name], figures[name.replace("_ms", "_best_ms")] = median_and_best(repeats, per_frame)
    robot.close()
    return figures


def markdown_table(result: dict) -> str:
    """The figures as the Markdown table of docs/simulation.md."""
    kinematic, dynamic = result["physics"]["kinematic"], result["physics"]["dynamic"]
    lines = [
        "| figure | kinematic | dynamic |",
        "| --- | --- | --- |",
        f"| steps per second | {kinematic['kinematic_step_per_s']:,.0f} (20 ms kinematic steps, with safety checks) "
        f"| {dynamic['mj_step_per_s']:,.0f} (`mj_step`, 2 ms) |",
        f"| real-time factor, idle robot, no rendering | {kinematic['idle_real_time_factor']:.0f} "
        f"| {dynamic['idle_real_time_factor']:.0f} |",
        f"| real-time factor, base turning and driving | {kinematic['moving_real_time_factor']:.0f} "
        f"| {dynamic['moving_real_time_factor']:.0f} (stands: no gait yet) |",
        "",
        "| render, ms per frame | " + " | ".join(r["size"] for r in result["render"].values()) + " |",
        "| --- | " + " | ".join("---" for _ in result["render"]) + " |",
    ]
    rows = {
        "RGB": "rgb",
        "depth": "depth",
        "segmentation": "segmentation",
        "`observe()` (RGB + depth + segmentation)": "observe",
        "`observe_depth()`": "observe_depth",
        "`observe_depth(pixel_grids=...)`: rays at the planner's and the map's pixels only (LocalPlan's)": "observe_depth_rays",
    }
    for label, key in rows.items():
        # Files written before a row existed show "-" in it.
        cells = [
            f"{r[key + '_ms']:.1f} ({r[key + '_best_ms']:.1f})" if key + "_ms" in r else "-"
            for r in result["render"].values()
        ]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    machine = result["machine"]
    lines.append("")
    lines.append(
        f"Load average (1 min) {machine['load_average_1m_at_start']:.1f} at the start, "
        f"{machine['load_average_1m_at_end']:.1f} at the end; renderer: {result['render']['default']['gl_renderer']}."
    )
    if "catalogue" in result:
        lines += [
            "",
            "| scene | objects | idle RTF kinematic | idle RTF dynamic | observe() ms |",
            "| --- | ---: | ---: | ---: | ---: |",
        ]
        for name, row in result["catalogue"].items():
            lines.append(
                f"| {name} | {row['objects']:.0f} | {row['kinematic_idle_rtf']:.0f} | "
                f"{row['dynamic_idle_rtf']:.1f} | {row['observe_ms']:.1f} |"
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="write the figures here as JSON")
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per physics run")
    parser.add_argument("--frames", type=int, default=50, help="frames per render run")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--markdown", type=Path, help="print the table of docs/simulation.md for this JSON file and exit"
    )
    parser.add_argument(
        "--catalogue", action="store_true", help="also measure every catalogue scene (idle RTF, observe time)"
    )
    args = parser.parse_args(argv)
    if args.markdown:
        print(markdown_table(json.loads(args.markdown.read_text())))
        return 0

    scene = benchmark_scene(args.seed)
    result = {
        "machine": {
            "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            "cpu_count": os.cpu_count(),
            "python": platform.python_version(),
            "mujoco": mujoco.__version__,
            "MUJOCO_GL": os.environ.get("MUJOCO_GL", ""),
            # Other processes on a shared machine slow every figure: record how busy it was.
            "load_average_1m_at_start": os.getloadavg()[0],
        },
        "scene": {"name": scene.name, "objects": len(scene.objects), "seed": args.seed},
        "physics": {
            f: physics_figures(scene, f, args.seconds, args.repeats) for f in ("kinematic", "dynamic")
        },
        "render": {
            "default": render_figures(scene, CameraConfig(), args.frames, args.repeats),
            "native": render_figures(scene, CameraConfig(downscale=1), args.frames, args.repeats),
            # A quarter of the native width: what a planner depth at lower resolution would cost.
            "quarter": render_figures(scene, CameraConfig(downscale=4), args.frames, args.repeats),
        },
    }
    if args.catalogue:
        result["catalogue"] = catalogue_figures(args.seconds, args.frames)
    result["machine"]["load_average_1m_at_end"] = os.getloadavg()[0]
    text = json.dumps(result, indent=2)
    print(text)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
