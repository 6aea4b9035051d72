"""Calibration of the perception emulator against the paper's single-source baselines (Table I).

The paper reports the semantic accuracy (SA) of each perception source used alone: Qwen2.5-VL 81.2 %,
GroundingDINO 82.9 %, YOLO-World 83.8 % (means over its five scenes). SA is a whole-mission metric; the
per-view proxy measured here needs no executive:

    over many views in which the goal or a distractor is visible, *single-source SA* is the share of
    views where that source's top instruction-aligned report lies on an object of the goal category,
    among the views where the source reported anything aligned at all.

The top aligned report is the highest-confidence detection (detectors, whose label is always the
prompt) or the first object proposal whose label is the target (VLM). "Lies on" is judged from the
segmentation, as a user looking at the image would: the object whose visible mask a detection's box overlaps most, or
the most frequent object within 3 % of the image width of a VLM point. The share of views with an aligned
report (``coverage``) is reported beside it: a silent source is not a wrong one, the robot keeps
exploring.

Views come from real MuJoCo renders (``sims.catalogue.build_scene`` + ``robots.mujoco_backend``) when
those modules exist, or from a small synthetic renderer (:func:`synthetic_view`) that paints boxes on a
floor with correct occlusion, for development and tests. The calibration harness may read object
positions to *choose viewpoints*; the emulator itself never does.

CLI: ``python -m sims.perception_calibration --views 300 --seed 0 [--synthetic] [--scenes a,b|all]``
(``add_arguments``/``run`` follow the ``semexp-bt`` subcommand convention).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from semexp_bt.core.geometry import wrap_angle
from semexp_bt.core.relevance import NAMES_OBJECT_RELEVANCE, phrase_similarity
from semexp_bt.core.scene import SceneObject, SceneSpec
from semexp_bt.core.types import BACKGROUND_OBJECT_ID, CameraIntrinsics, Observation, Pose2D
from sims.naming import named_objects
from sims.perception_emulator import PerceptionNoiseConfig, emulate, load_noise_model

#: Table I of the paper, mean over its five scenes (%).
PAPER_SINGLE_SOURCE_SA: dict[str, float] = {"vlm": 81.18, "detector": 82.86, "detector_yolo_world": 83.82}

SOURCES: tuple[str, ...] = ("vlm", "detector", "detector_yolo_world")

#: Calibration viewpoints keep the robot's base centre this far (m) from walls and obstacles.
ROBOT_CLEARANCE_M = 0.4

#: A VLM point within this fraction of the image width of an object counts as pointing at it.
DEFAULT_HIT_RADIUS_FRAC = 0.03


def _target_label(scene: SceneSpec) -> str:
    try:
        from semexp_bt.core.instruction import instruction_target
    except ImportError:  # relevance.py is written in parallel; the goal's label is the same phrase
        return scene.goal.label
    return instruction_target(scene.instruction)


def _iou(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> float:
    iw = min(a[2], b[2]) - max(a[0], b[0])
    ih = min(a[3], b[3]) - max(a[1], b[1])
    if iw < 0 or ih < 0:
        return 0.0
    # Pixel-centre boxes: a box spanning columns u0..u1 covers u1 - u0 + 1 pixels.
    inter = (iw + 1) * (ih + 1)
    area = lambda r: (r[2] - r[0] + 1) * (r[3] - r[1] + 1)  # noqa: E731
    return inter / (area(a) + area(b) - inter)


def object_under_box(
    seg: np.ndarray, box: tuple[float, float, float, float], *, ignore: Sequence[int] = ()
) -> int:
    """The object a box outlines: among the objects with pixels inside ``box``, the one whose visible
    mask's bounding box overlaps ``box`` most (IoU); background and ``ignore`` ids (walls) left out.

    Overlap, not pixel majority, so that a box around a partly occluded object is not credited to the
    occluder in front of it.
    """
    u0, v0, u1, v1 = box
    h, w = seg.shape
    rows = slice(max(0, int(math.floor(v0))), min(h, int(math.ceil(v1)) + 1))
    cols = slice(max(0, int(math.floor(u0))), min(w, int(math.ceil(u1)) + 1))
    patch = seg[rows, cols]
    candidates = np.unique(patch[~np.isin(patch, [BACKGROUND_OBJECT_ID, *ignore])])
    best, best_iou = BACKGROUND_OBJECT_ID, 0.0
    for oid in candidates.tolist():
        r, c = np.nonzero(seg == oid)
        iou = _iou(box, (float(c.min()), float(r.min()), float(c.max()), float(r.max())))
        if iou > best_iou:
            best, best_iou = int(oid), iou
    return best


def object_near_point(
    seg: np.ndarray, point: tuple[float, float], radius_px: int, *, ignore: Sequence[int] = ()
) -> int:
    """The object at ``point``, or else the nearest one within ``radius_px`` (background and ``ignore``
    ids left out; background when there is none)."""
    h, w = seg.shape
    u, v = min(w - 1, max(0, int(round(point[0])))), min(h - 1, max(0, int(round(point[1]))))
    v0, v1, u0, u1 = (
        max(0, v - radius_px),
        min(h, v + radius_px + 1),
        max(0, u - radius_px),
        min(w, u + radius_px + 1),
    )
    patch = seg[v0:v1, u0:u1]
    rows, cols = np.nonzero(~np.isin(patch, [BACKGROUND_OBJECT_ID, *ignore]))
    if rows.size == 0:
        return BACKGROUND_OBJECT_ID
    d2 = (rows + v0 - v) ** 2 + (cols + u0 - u) ** 2
    best = int(np.argmin(d2))
    if d2[best] > radius_px * radius_px:
        return BACKGROUND_OBJECT_ID
    return int(patch[rows[best], cols[best]])


@dataclass
class SourceTally:
    """Counts for one source."""

    views: int = 0
    reported: int = 0
    correct: int = 0

    @property
    def accuracy(self) -> float:
        """Single-source SA proxy: correct / views with an aligned report (nan when none)."""
        return self.correct / self.reported if self.reported else math.nan

    @property
    def coverage(self) -> float:
        return self.reported / self.views if self.views else math.nan


@dataclass
class CalibrationReport:
    """Per-source and per-scene tallies."""

    tallies: dict[str, SourceTally] = field(default_factory=lambda: {s: SourceTally() for s in SOURCES})
    per_scene: dict[str, dict[str, SourceTally]] = field(default_factory=dict)
    view_kind: str = "synthetic"

    def add(self, scene_name: str, source: str, *, reported: bool, correct: bool) -> None:
        for tally in (
            self.tallies[source],
            self.per_scene.setdefault(scene_name, {s: SourceTally() for s in SOURCES})[source],
        ):
            tally.views += 1
            tally.reported += int(reported)
            tally.correct += int(correct)

    def table(self) -> str:
        """A Markdown table of SA proxy and coverage per source, with the paper's figure."""
        lines = [
            "| source | views | SA proxy (%) | coverage (%) | paper SA (%) |",
            "| --- | --- | --- | --- | --- |",
        ]
        for s in SOURCES:
            t = self.tallies[s]
            lines.append(
                f"| {s} | {t.views} | {100 * t.accuracy:.1f} | {100 * t.coverage:.1f} | {PAPER_SINGLE_SOURCE_SA[s]:.1f} |"
            )
        return "\n".join(lines)


def score_view(
    observation: Observation,
    scene: SceneSpec,
    *,
    rng: np.random.Generator,
    noise: PerceptionNoiseConfig,
    report: CalibrationReport,
    hit_radius_frac: float = DEFAULT_HIT_RADIUS_FRAC,
) -> None:
    """Emulate every source on one view and add its outcome to ``report``."""
    seg = np.asarray(observation.segmentation)
    target = _target_label(scene)
    named = {o.object_id for o in named_objects(scene, scene.instruction)}
    walls = [o.object_id for o in scene.objects if o.role == "wall"]

    def is_goal_category(oid: int) -> bool:
        return oid in named

    for profile in ("detector", "detector_yolo_world"):
        out = emulate(observation, scene, target_label=target, rng=rng, noise=noise, detector_profile=profile)
        if out.detections:
            top = max(out.detections, key=lambda d: d.confidence)
            report.add(
                scene.name,
                profile,
                reported=True,
                correct=is_goal_category(object_under_box(seg, top.box_xyxy_px, ignore=walls)),
            )
        else:
            report.add(scene.name, profile, reported=False, correct=False)
        if profile == "detector":
            aligned = [
                p
                for p in out.scene_evidence.proposals
                if p.kind == "object" and phrase_similarity(p.label, target) >= NAMES_OBJECT_RELEVANCE
            ]
            if aligned:
                radius_px = max(1, round(hit_radius_frac * seg.shape[1]))
                hit = object_near_point(seg, aligned[0].point_px, radius_px, ignore=walls)
                report.add(scene.name, "vlm", reported=True, correct=is_goal_category(hit))
            else:
                report.add(scene.name, "vlm", reported=False, correct=False)


def shows(observation: Observation, object_id: int, *, min_pixels: int) -> bool:
    """Whether ``object_id`` has at least ``min_pixels`` visible pixels."""
    return int(np.count_nonzero(np.asarray(observation.segmentation) == object_id)) >= min_pixels


# --------------------------------------------------------------------------------------------------
# Synthetic views (development and tests): axis-aligned billboards standing on a floor
# --------------------------------------------------------------------------------------------------

SYNTHETIC_INTRINSICS = CameraIntrinsics.from_fov(width_px=160, height_px=120, vertical_fov_deg=42.0)
SYNTHETIC_CAMERA_HEIGHT_M = 0.45


def synthetic_scene() -> SceneSpec:
    """A small scene with a goal, two distractors, clutter and a back wall (positions unused)."""

    def obj(
        oid: int,
        name: str,
        label: str,
        category: str,
        role: str,
        size: tuple[float, float, float],
        shape: str = "box",
    ) -> SceneObject:
        return SceneObject(
            object_id=oid,
            name=name,
            label=label,
            category=category,
            shape=shape,  # type: ignore[arg-type]
            position_m=(0.0, 0.0, size[2]),
            size_m=size,
            role=role,  # type: ignore[arg-type]
        )

    return SceneSpec(
        name="synthetic",
        title="Synthetic billboards",
        seed=0,
        bounds_m=(-5.0, -5.0, 5.0, 5.0),
        objects=(
            obj(
                0,
                "extinguisher_0",
                "fire extinguisher",
                "extinguisher",
                "goal",
                (0.08, 0.08, 0.3),
                "cylinder",
            ),
            obj(1, "trash_0", "red trash can", "trash can", "distractor", (0.18, 0.18, 0.35), "cylinder"),
            obj(2, "hydrant_0", "fire hydrant", "hydrant", "distractor", (0.15, 0.15, 0.4), "cylinder"),
            obj(3, "box_0", "cardboard box", "box", "clutter", (0.3, 0.3, 0.3)),
            obj(4, "cabinet_0", "cabinet", "cabinet", "obstacle", (0.4, 0.3, 0.9)),
            obj(5, "wall_0", "wall", "wall", "wall", (5.0, 0.1, 1.5)),
        ),
        goal_object_id=0,
        instruction="find the fire extinguisher",
    )


@dataclass(frozen=True)
class Billboard:
    """A synthetic object: its id, lateral offset x (m, right positive) and depth z (m) in the camera frame."""

    object_id: int
    x_m: float
    z_m: float


def synthetic_view(
    scene: SceneSpec,
    billboards: Sequence[Billboard],
    *,
    intrinsics: CameraIntrinsics = SYNTHETIC_INTRINSICS,
    camera_height_m: float = SYNTHETIC_CAMERA_HEIGHT_M,
    wall_depth_m: float | None = 8.0,
    stamp_s: float = 0.0,
) -> Observation:
    """Render billboards standing on a floor seen by a level camera (painter's algorithm: far first).

    Each billboard is the object's side silhouette (width from its nominal size, height 2*hz) at depth
    ``z_m``; nearer ones overwrite farther ones, so occlusion is exact. The floor is background with its
    true depth; above the horizon a wall (the scene's first ``role == "wall"`` object) at
    ``wall_depth_m`` or no return (depth 0) when ``wall_depth_m`` is None.
    """
    k = intrinsics
    h, w = k.height_px, k.width_px
    rows = np.arange(h, dtype=np.float64)[:, None] * np.ones((1, w))
    depth = np.zeros((h, w), dtype=np.float64)
    seg = np.full((h, w), BACKGROUND_OBJECT_ID, dtype=np.int32)
    below = rows > k.cy_px + 1e-9
    depth[below] = camera_height_m * k.fy_px / (rows[below] - k.cy_px)
    walls = [o for o in scene.objects if o.role == "wall"]
    if wall_depth_m is not None:
        beyond = ~below | (depth > wall_depth_m)
        depth[beyond] = wall_depth_m
        if walls:
            # The wall stands on the floor: it covers the rows whose floor would lie beyond it.
            seg[beyond] = walls[0].object_id
    for bb in sorted(billboards, key=lambda b: -b.z_m):
        obj = scene.object_by_id(bb.object_id)
        sx, sy, sz = obj.size_m
        half_w = sx if obj.shape == "cylinder" else 2.0 * (sx + sy) / math.pi
        u0 = k.cx_px + k.fx_px * (bb.x_m - half_w) / bb.z_m
        u1 = k.cx_px + k.fx_px * (bb.x_m + half_w) / bb.z_m
        v_top = k.cy_px + k.fy_px * (camera_height_m - 2.0 * sz) / bb.z_m
        v_bot = k.cy_px + k.fy_px * camera_height_m / bb.z_m
        c0, c1 = max(0, math.ceil(u0)), min(w - 1, math.floor(u1))
        r0, r1 = max(0, math.ceil(v_top)), min(h - 1, math.floor(v_bot))
        if c0 > c1 or r0 > r1:
            continue
        seg[r0 : r1 + 1, c0 : c1 + 1] = bb.object_id
        depth[r0 : r1 + 1, c0 : c1 + 1] = bb.z_m
    return Observation(
        rgb=np.zeros((h, w, 3), dtype=np.uint8),
        depth_m=depth.astype(np.float32),
        intrinsics=k,
        # Optical frame (x right, y down, z forward) to map (x forward, y left, z up), camera level.
        camera_to_world=np.array(
            [
                [0.0, 0.0, 1.0, 0.0],
                [-1.0, 0.0, 0.0, 0.0],
                [0.0, -1.0, 0.0, camera_height_m],
                [0.0, 0.0, 0.0, 1.0],
            ]
        ),
        base_pose=Pose2D(0.0, 0.0, 0.0),
        stamp_s=stamp_s,
        segmentation=seg,
    )


def random_synthetic_views(rng: np.random.Generator, count: int) -> Iterator[tuple[SceneSpec, Observation]]:
    """``count`` random synthetic views, half showing the goal, half a distractor (others may show too)."""
    scene = synthetic_scene()
    non_wall = [o.object_id for o in scene.objects if o.role != "wall"]
    subjects = [scene.goal_object_id] + [o.object_id for o in scene.objects if o.role == "distractor"]
    k = SYNTHETIC_INTRINSICS
    made = 0
    while made < count:
        n = int(rng.integers(1, 5))
        # Half the views are aimed at the goal, half at one of its distractors.
        if rng.random() < 0.5:
            chosen = [scene.goal_object_id]
        else:
            chosen = [int(subjects[1 + int(rng.integers(len(subjects) - 1))])]
        chosen += [int(i) for i in rng.choice(non_wall, size=n, replace=True)]
        billboards = []
        for oid in dict.fromkeys(chosen):
            z = float(rng.uniform(0.8, 7.0))
            half_fov_x = (k.width_px / 2.0) / k.fx_px
            x = float(rng.uniform(-1.1, 1.1) * half_fov_x * z)
            billboards.append(Billboard(oid, x, z))
        obs = synthetic_view(scene, billboards)
        if shows(obs, chosen[0], min_pixels=30):
            made += 1
            yield scene, obs


# --------------------------------------------------------------------------------------------------
# Real renders
# --------------------------------------------------------------------------------------------------


def _footprint_distance_m(obj: SceneObject, x: float, y: float) -> float:
    """Distance (m) from ``(x, y)`` to the object's footprint (its box or disc), 0 inside."""
    dx, dy = x - obj.position_m[0], y - obj.position_m[1]
    if obj.shape == "cylinder":
        return max(0.0, math.hypot(dx, dy) - obj.size_m[0])
    c, s = math.cos(obj.yaw_rad), math.sin(obj.yaw_rad)
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    return math.hypot(max(0.0, abs(lx) - obj.size_m[0]), max(0.0, abs(ly) - obj.size_m[1]))


def rendered_views(
    scene_names: Sequence[str], *, views_per_scene: int, seed: int, min_pixels: int = 30, max_tries: int = 50
) -> Iterator[tuple[SceneSpec, Observation]]:
    """Views rendered by the MuJoCo backend in the catalogue's scenes.

    Even views are aimed at the goal, odd views at a random distractor (1:1 whatever the layout hides).
    The robot is placed 1-5 m from the subject at a random bearing, clear of obstacles and inside the
    scene bounds, facing it with up to 25 degrees of yaw error; the frame is kept once the subject
    shows at least ``min_pixels`` pixels (up to ``max_tries`` poses per view, else the view is skipped).
    """
    from robots.mujoco_backend import MujocoRobot
    from sims.catalogue import build_scene

    rng = np.random.default_rng(seed)
    for s_index, name in enumerate(scene_names):
        scene = build_scene(name, seed=seed + s_index)
        subjects = [scene.goal] + [o for o in scene.objects if o.role == "distractor"]
        obstacles = [o for o in scene.objects if o.is_obstacle and o.role != "wall"]
        x_min, y_min, x_max, y_max = scene.bounds_m
        robot = None
        for view_index in range(views_per_scene):
            # Even views are aimed at the goal, odd ones at a random distractor (when there is one).
            aim_at_goal = view_index % 2 == 0 or len(subjects) == 1
            for attempt in range(max_tries):
                subject = subjects[0] if aim_at_goal else subjects[1 + int(rng.integers(len(subjects) - 1))]
                dist = float(rng.uniform(1.0, 5.0))
                bearing = float(rng.uniform(-math.pi, math.pi))
                x = subject.position_m[0] + dist * math.cos(bearing)
                y = subject.position_m[1] + dist * math.sin(bearing)
                if not (
                    x_min + ROBOT_CLEARANCE_M <= x <= x_max - ROBOT_CLEARANCE_M
                    and y_min + ROBOT_CLEARANCE_M <= y <= y_max - ROBOT_CLEARANCE_M
                ):
                    continue
                if any(_footprint_distance_m(o, x, y) < ROBOT_CLEARANCE_M for o in obstacles):
                    continue
                yaw = bearing + math.pi + float(rng.uniform(-1.0, 1.0)) * math.radians(25.0)
                pose = Pose2D(x, y, wrap_angle(yaw))
                robot = _place_robot(MujocoRobot, robot, scene, pose, seed + view_index * max_tries + attempt)
                obs = robot.observe()
                if shows(obs, subject.object_id, min_pixels=min_pixels):
                    yield scene, obs
                    break
        if robot is not None:
            robot.close()


def _place_robot(cls: Callable[..., Any], robot: Any, scene: SceneSpec, pose: Pose2D, seed: int) -> Any:
    """Teleport the robot when the backend can (``MujocoRobot.teleport``), else build one at ``pose``."""
    if robot is not None and hasattr(robot, "teleport"):
        robot.teleport(pose)
        return robot
    if robot is not None:
        robot.close()
    return cls(scene=scene, fidelity="kinematic", start_pose=pose, seed=seed)


def measure_single_source_accuracy(
    *,
    views: Iterator[tuple[SceneSpec, Observation]],
    seed: int,
    noise: PerceptionNoiseConfig | None = None,
    hit_radius_frac: float = DEFAULT_HIT_RADIUS_FRAC,
    view_kind: str = "synthetic",
) -> CalibrationReport:
    """Single-source SA proxy of the VLM and of both detector profiles over ``views``.

    Args:
        views: ``(scene, observation)`` pairs: :func:`random_synthetic_views` or :func:`rendered_views`.
        seed: seeds the emulator's generator (views carry their own randomness).
        noise: the noise model to measure (the shipped default when None).
        hit_radius_frac: how near an object (fraction of the image width) a VLM point must fall to count
            as pointing at it.
        view_kind: recorded in the report.
    """
    noise = load_noise_model() if noise is None else noise
    rng = np.random.default_rng(seed)
    report = CalibrationReport(view_kind=view_kind)
    for scene, obs in views:
        score_view(obs, scene, rng=rng, noise=noise, report=report, hit_radius_frac=hit_radius_frac)
    return report


#: The paper's five simulation scenes (Table I), the default calibration set.
PAPER_TABLE_I_SCENES: tuple[str, ...] = ("garden_sim", "sidewalk", "road", "warehouse_a", "warehouse_b")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the calibration command (``semexp-bt`` subcommand convention)."""
    parser.add_argument("--views", type=int, default=300, help="views per scene (synthetic: in total)")
    parser.add_argument("--seed", type=int, default=0, help="seeds viewpoints and the emulator")
    parser.add_argument("--synthetic", action="store_true", help="use the synthetic renderer, not MuJoCo")
    parser.add_argument(
        "--scenes",
        default=",".join(PAPER_TABLE_I_SCENES),
        help="comma-separated catalogue scene names, or 'all' (default: the paper's Table I scenes)",
    )
    parser.add_argument(
        "--noise", default=None, help="noise-model YAML (default: sims/perception_noise.yaml)"
    )


def run(args: argparse.Namespace) -> int:
    """Measure and print the single-source SA proxy table; returns the exit status."""
    if args.views < 1:
        print("--views must be positive", file=sys.stderr)
        return 2
    noise = load_noise_model(args.noise)
    if args.synthetic:
        views = random_synthetic_views(np.random.default_rng(args.seed), args.views)
        kind = "synthetic"
    else:
        from sims import catalogue

        names = catalogue.list_scenes() if args.scenes == "all" else [n for n in args.scenes.split(",") if n]
        views = rendered_views(names, views_per_scene=args.views, seed=args.seed)
        kind = "mujoco"
    report = measure_single_source_accuracy(views=views, seed=args.seed, noise=noise, view_kind=kind)
    print(f"views: {kind}, seed {args.seed}")
    print(report.table())
    for scene_name, tallies in sorted(report.per_scene.items()):
        cells = ", ".join(f"{s} {100 * t.accuracy:.1f}%" for s, t in tallies.items())
        cells += f" ({tallies['vlm'].views} views)"
        print(f"  {scene_name}: {cells}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m sims.perception_calibration``."""
    parser = argparse.ArgumentParser(
        prog="python -m sims.perception_calibration", description=__doc__.splitlines()[0]
    )
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
