"""Helpers shared by the models tests: the scripted server fixture's clients, a one-Perceive mission."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from robots.null_robot import NullRobot
from semexp_bt.app.pacing import WallClockPacer
from semexp_bt.app.runner import MissionComponents, MissionResult, run_mission
from semexp_bt.core.config import SemExpConfig
from semexp_bt.core.relevance import CachedRelevance, LexicalRelevance
from semexp_bt.core.types import Observation, Pose2D, Twist
from semexp_bt.nav.pure_pursuit import RegulatedPurePursuit
from semexp_bt.perception.adapters.chat import CircuitBreaker, OpenAIChatClient
from semexp_bt.perception.adapters.vlm import SceneVLM
from semexp_bt.perception.interface import PerceptionSource
from semexp_bt.perception.model_config import CircuitBreakerConfig, VLMConfig
from trees.loader import parse_mission

INSTRUCTION = "find the fire extinguisher"
TARGET = "fire extinguisher"
WIDTH, HEIGHT = 320, 240

#: A mission that perceives once: the record's events show what the models did.
PERCEIVE_ONCE = """\
mission:
  name: perceive_once
  robot: go1
  backend: mujoco
  fidelity: kinematic
  budget_s: 30
tree:
  type: Perceive
  name: Perceive
  params: {timeout_s: 20}
"""


def frame(seed: int = 0) -> np.ndarray:
    """A 320x240 RGB frame of noise (the models under test never look at its content)."""
    return np.random.default_rng(seed).integers(0, 255, (HEIGHT, WIDTH, 3), dtype=np.uint8)


def observation(rgb: np.ndarray | None = None) -> Observation:
    from semexp_bt.core.types import CameraIntrinsics

    rgb = frame() if rgb is None else rgb
    return Observation(
        rgb=rgb,
        depth_m=np.zeros(rgb.shape[:2], np.float32),
        intrinsics=CameraIntrinsics.from_fov(
            width_px=rgb.shape[1], height_px=rgb.shape[0], vertical_fov_deg=42.5
        ),
        camera_to_world=np.eye(4),
        base_pose=Pose2D(0.0, 0.0, 0.0),
        stamp_s=1.5,
    )


def vlm_config(url: str, **overrides: Any) -> VLMConfig:
    values: dict[str, Any] = {"base_url": url, "model": "Qwen/Qwen2.5-VL-7B-Instruct", "timeout_s": 2.0}
    values.update(overrides)
    return VLMConfig(**values)


def breaker(**overrides: Any) -> CircuitBreaker:
    return CircuitBreaker(CircuitBreakerConfig(**overrides), name="test endpoint")


def scene_vlm(url: str, *, environ: dict[str, str] | None = None, **overrides: Any) -> SceneVLM:
    config = vlm_config(url, **overrides)
    client = OpenAIChatClient(
        config=config, breaker=breaker(), role="vlm", environ=environ or {}, sleep=lambda s: None
    )
    return SceneVLM(config, client)


def scene_json(proposals: list[dict[str, Any]] | None = None, confidence: float = 0.8, **extra: Any) -> str:
    if proposals is None:
        proposals = [
            {"kind": "object", "label": TARGET, "point": [150, 120]},
            {"kind": "direction", "label": "open corridor", "point": [300, 200]},
        ]
    return json.dumps({"proposals": proposals, "scene_confidence": confidence, **extra})


def perceive_once(tmp_path: Path, perception: PerceptionSource) -> MissionResult:
    """Run the one-Perceive mission on a NullRobot at wall-clock pace, as a MuJoCo run with models would."""
    mission_path = tmp_path / "perceive_once.yaml"
    mission_path.write_text(PERCEIVE_ONCE)
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    return run_mission(
        mission=parse_mission(mission_path),
        components=MissionComponents(
            robot=robot,
            perception=perception,
            relevance=CachedRelevance(LexicalRelevance()),
            planner=RegulatedPurePursuit(),
        ),
        config=SemExpConfig(),
        instructions=[INSTRUCTION],
        seed=0,
        max_time_s=25.0,
        observers=[WallClockPacer()],
    )


def still() -> Twist:
    return Twist.zero()
