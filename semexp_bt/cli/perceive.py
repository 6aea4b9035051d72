"""``semexp-bt perceive IMAGE [--depth DEPTH] --instruction TEXT --models PROFILE [--json OUT]``.

Runs the configured real models (docs/perception.md) and the evidence arbitration (paper Eq. 1-4) on
one picture, the way the tree would on one viewpoint, and prints what each model returned, the parsed
proposals (pixel, label) with C_s, the detections (box, label, confidence), the arbitrated target and
any model errors: how a user checks a setup on their own pictures. ``--vlm-url URL --vlm-model NAME``
(and ``--llm-url``, ``--llm-model``) point at a server without writing a profile; the key, if any, comes
from ``OPENAI_API_KEY``.

DEPTH is a ``.npy`` array in metres, or a 16-bit PNG in millimetres (``--depth-scale`` changes the unit),
the size of the image. Exit status: 0 when every model answered, 1 when one failed (its error is
printed), 2 for bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from semexp_bt.app.components import RELEVANCE_SCORERS
from semexp_bt.app.models_profile import add_models_arguments, models_profile_from_args

#: Seconds ``perceive`` waits for the models before giving up.
DEFAULT_TIMEOUT_S = 180.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("image", type=Path, help="an RGB picture (PNG, JPEG)")
    parser.add_argument("--depth", type=Path, default=None, help="depth: .npy in metres or a 16-bit PNG")
    parser.add_argument("--depth-scale", type=float, default=0.001, help="metres per PNG depth unit (0.001)")
    parser.add_argument("--instruction", required=True, help="e.g. 'find the fire extinguisher'")
    add_models_arguments(parser)
    parser.add_argument(
        "--relevance",
        choices=sorted(RELEVANCE_SCORERS),
        default="embedding",
        help="the scorer that decides which labels name the instructed object (as in `run`)",
    )
    parser.add_argument(
        "--align-threshold",
        type=float,
        default=None,
        help="relevance at which a label is aligned (Arbitrate's)",
    )
    parser.add_argument("--config", type=Path, default=None, help="YAML of config overrides (arbitration)")
    parser.add_argument("--timeout-s", type=float, default=DEFAULT_TIMEOUT_S, help="give up after this long")
    parser.add_argument("--json", type=Path, default=None, help="write everything printed as JSON here")


def run(args: argparse.Namespace) -> int:
    try:
        report = _perceive(args)
    except ValueError as exc:  # ConfigError, InvalidInputError, DetectorLoadError, a bad image
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(render(report))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(report, indent=1))
    return 1 if report["errors"] else 0


def load_rgb(path: Path) -> np.ndarray:
    """An ``(H, W, 3)`` uint8 RGB picture.

    Raises:
        ValueError: naming the file when it is missing or not a picture.
    """
    import cv2

    if not path.is_file():
        raise ValueError(f"{path}: no such image")
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError(f"{path}: not a picture OpenCV can read")
    return np.ascontiguousarray(bgr[:, :, ::-1])


def load_depth(path: Path, *, scale_m: float, shape: tuple[int, int]) -> np.ndarray:
    """Depth in metres (float32, 0 where invalid), the size of the picture.

    Raises:
        ValueError: naming the file when it is missing, unreadable or of another size.
    """
    import cv2

    if not path.is_file():
        raise ValueError(f"{path}: no such depth file")
    if path.suffix == ".npy":
        try:
            depth = np.load(path, allow_pickle=False).astype(np.float32)
        except (OSError, ValueError) as exc:
            raise ValueError(f"{path}: not a numpy array: {exc}") from None
    else:
        raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if raw is None or raw.ndim != 2:
            raise ValueError(f"{path}: not a one-channel depth image")
        depth = raw.astype(np.float32) * float(scale_m)
    if depth.shape != shape:
        raise ValueError(
            f"{path}: depth is {depth.shape[1]}x{depth.shape[0]}, the image {shape[1]}x{shape[0]}"
        )
    return np.where(np.isfinite(depth) & (depth > 0.0), depth, 0.0).astype(np.float32)


def _perceive(args: argparse.Namespace) -> dict[str, Any]:
    from behaviours.arbitrate import Arbitrate
    from robots.camera import CameraConfig
    from semexp_bt.app.components import build_relevance
    from semexp_bt.app.configuration import read_config_file, resolve_config
    from semexp_bt.core.evidence import arbitrate
    from semexp_bt.core.relevance import instruction_target
    from semexp_bt.core.types import CameraIntrinsics, Observation, Pose2D, Twist
    from semexp_bt.perception.adapters.stack import ModelStack

    profile = models_profile_from_args(args)
    if profile is None:
        raise ValueError("give a models profile (--models) or an endpoint (--vlm-url and --vlm-model)")
    rgb = load_rgb(args.image)
    height, width = rgb.shape[:2]
    depth = (
        None
        if args.depth is None
        else load_depth(args.depth, scale_m=args.depth_scale, shape=(height, width))
    )
    config = resolve_config(
        command_line_overrides=None if args.config is None else read_config_file(args.config),
        command_line_source=str(args.config),
    )
    threshold = args.align_threshold
    if threshold is None:
        threshold = float(Arbitrate.PARAMS["align_threshold"].default)
    target_label = instruction_target(args.instruction)

    stack = ModelStack(profile)
    try:
        relevance = stack.relevance() if args.relevance == "llm" else build_relevance(args.relevance)
        source = stack.perception()
        observation = Observation(
            rgb=rgb,
            depth_m=depth if depth is not None else np.zeros((height, width), np.float32),
            intrinsics=CameraIntrinsics.from_fov(
                width_px=width, height_px=height, vertical_fov_deg=CameraConfig().vertical_fov_deg
            ),
            camera_to_world=np.eye(4),
            base_pose=Pose2D(0.0, 0.0, 0.0),
            stamp_s=0.0,
        )
        job = source.submit(
            observation=observation,
            instruction=args.instruction,
            target_label=target_label,
            motion=Twist.zero(),
            now_s=0.0,
        )
        models = job.wait(args.timeout_s)
        if models is None:
            raise ValueError(f"the models did not answer within {args.timeout_s:g} s (--timeout-s)")
        result = models.result
        arbitration = arbitrate(
            scene=result.scene,
            detections=result.detections,
            is_aligned=lambda label: relevance.score(instruction=args.instruction, label=label) >= threshold,
            config=config.arbitration,
            depth_m=depth,
            image_size=(width, height),
        )
        errors = list(result.errors) + [e for e in stack.drain_errors() if e not in result.errors]
    finally:
        stack.close()
    target = arbitration.target
    return {
        "image": str(args.image),
        "size_px": [width, height],
        "depth": None if args.depth is None else str(args.depth),
        "instruction": args.instruction,
        "target_label": target_label,
        "align_threshold": threshold,
        **models.as_dict(),
        "errors": errors,
        "target": None
        if target is None
        else {
            "label": target.label,
            "pixel_px": list(target.pixel_px),
            "fused_confidence": target.fused_confidence,
            "source": target.source,
            "kind": target.kind,
            "depth_m": target.depth_m,
        },
        "arbitration_reason": arbitration.reason,
    }


def _px(values: list[float]) -> str:
    return "(" + ", ".join(f"{v:.1f}" for v in values) + ")"


def render(report: dict[str, Any]) -> str:
    """The report as the terminal shows it."""
    width, height = report["size_px"]
    lines = [
        f"{report['image']} ({width}x{height}): {report['instruction']!r} -> object phrase "
        f"{report['target_label']!r}"
    ]
    for call in report["calls"]:
        stages = ", ".join(f"{k} {v:.1f} ms" for k, v in call["timings_ms"].items())
        state = "ok" if call["ok"] else "FAILED"
        lines.append(
            f"{call['source']} {call['model']}: {state} in {call['latency_s']:.2f} s ({stages or 'no stages'})"
        )
        if call["reply"] is not None:
            lines.append(f"  returned: {call['reply']}")
    scene = report["scene"]
    if scene is None:
        lines.append("proposals: none (no scene-level evidence)")
    else:
        lines.append(f"proposals (C_s {scene['scene_confidence']:.2f}):")
        lines += [f"  {p['kind']:<9} {_px(p['point_px']):<16} {p['label']}" for p in scene["proposals"]]
    detections = report["detections"]
    if detections is None:
        lines.append("detections: none (no object-level evidence)")
    else:
        lines.append(f"detections ({len(detections)}):")
        lines += [f"  {_px(d['box_xyxy_px']):<30} {d['label']}  {d['confidence']:.2f}" for d in detections]
    target = report["target"]
    if target is None:
        lines.append(f"target: none ({report['arbitration_reason']})")
    else:
        depth = "" if target["depth_m"] is None else f", depth {target['depth_m']:.2f} m"
        lines.append(
            f"target: {target['label']!r} at {_px(target['pixel_px'])}, C_f {target['fused_confidence']:.2f}, "
            f"{target['source']} {target['kind']}{depth}"
        )
    lines.append("errors: " + ("none" if not report["errors"] else ""))
    lines += [f"  {e}" for e in report["errors"]]
    return "\n".join(lines)
