"""Configuration is resolved once, before anything is built: defaults < strategy < mission file < command line.

Every key of SemExpConfig set in a mission file's ``config:`` must reach the objects that read it: the
services every behaviour reads (``services.config``) and the topological memory on the board.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import pytest
import yaml

from robots.null_robot import NullRobot
from semexp_bt.app.configuration import read_config_file, resolve_config
from semexp_bt.app.runner import MissionComponents, run_mission
from semexp_bt.core.bounds import Interval, field_interval
from semexp_bt.core.config import ConfigError, SemExpConfig
from semexp_bt.core.relevance import CachedRelevance, LexicalRelevance
from semexp_bt.core.types import Pose2D, SceneEvidence
from semexp_bt.nav.pure_pursuit import RegulatedPurePursuit
from semexp_bt.perception.interface import PerceptionResult
from sims.scripted_perception import ScriptedPerception
from trees.loader import parse_mission

TREES = Path(__file__).resolve().parents[1] / "trees"
NOTHING_SEEN = PerceptionResult(scene=SceneEvidence((), 0.0), detections=(), observation_stamp_s=0.0)


def _changed_value(value: Any, field: dataclasses.Field[Any]) -> Any:
    """A valid value of the field's type that differs from ``value`` (its default)."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        interval = field_interval(field) or Interval()
        candidate = value * 0.9 if value > 0 else value + 1e-3
        if not interval.contains(candidate):
            candidate = (value + (math.inf if interval.high is None else interval.high)) / 2
        return candidate
    if isinstance(value, str):  # a Literal: the other allowed value
        return {"graph": "euclidean", "euclidean": "graph"}[value]
    raise AssertionError(f"no changed value for {field.name} = {value!r}")


def every_leaf_override() -> list[tuple[str, str, Any]]:
    defaults = SemExpConfig()
    leaves = []
    for section in dataclasses.fields(SemExpConfig):
        group = getattr(defaults, section.name)
        for field in dataclasses.fields(group):
            leaves.append((section.name, field.name, _changed_value(getattr(group, field.name), field)))
    return leaves


def _mission_with(tmp_path: Path, config: dict[str, Any]) -> Path:
    document = yaml.safe_load((TREES / "object_search.yaml").read_text())
    document["mission"]["config"] = config
    document["mission"]["budget_s"] = 1.0
    (tmp_path / "subtrees").symlink_to(TREES / "subtrees")
    path = tmp_path / "mission.yaml"
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return path


def test_layers_apply_in_order_defaults_strategy_mission_command_line() -> None:
    config = resolve_config(
        strategy_overrides={"decision": {"alpha": 0.1, "beta": 0.2, "eta": 0.3}},
        mission_overrides={"decision": {"beta": 0.4, "eta": 0.5}},
        command_line_overrides={"decision": {"eta": 0.6}},
    )
    print(config.decision)
    assert (config.decision.alpha, config.decision.beta, config.decision.eta) == (0.1, 0.4, 0.6)
    assert config.decision.gamma == SemExpConfig().decision.gamma


def test_a_bad_layer_is_reported_against_its_own_source() -> None:
    with pytest.raises(ConfigError, match=r"missions/m\.yaml: unknown key 'memory\.delta'"):
        resolve_config(mission_overrides={"memory": {"delta": 1.0}}, mission_source="missions/m.yaml")
    with pytest.raises(ConfigError, match=r"strategy 'x': key 'decision\.alpha' must lie in"):
        resolve_config(strategy_overrides={"decision": {"alpha": -1.0}}, strategy_source="strategy 'x'")


def test_a_config_file_is_read_and_checked(tmp_path: Path) -> None:
    good = tmp_path / "good.yaml"
    good.write_text("memory: {xi: 0.5}\n")
    assert read_config_file(good) == {"memory": {"xi": 0.5}}
    bad = tmp_path / "bad.yaml"
    bad.write_text("- not a mapping\n")
    with pytest.raises(ConfigError, match="bad.yaml: top level must be a mapping"):
        read_config_file(bad)


@pytest.mark.parametrize(("section", "key", "value"), every_leaf_override(), ids=lambda v: str(v))
def test_every_mission_override_reaches_the_objects_that_use_it(
    tmp_path: Path, section: str, key: str, value: Any
) -> None:
    path = _mission_with(tmp_path, {section: {key: value}})
    mission = parse_mission(path)
    config = resolve_config(mission_overrides=mission.settings.config_overrides, mission_source=str(path))
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    result = run_mission(
        mission=mission,
        components=MissionComponents(
            robot=robot,
            perception=ScriptedPerception([NOTHING_SEEN]),
            relevance=CachedRelevance(LexicalRelevance()),
            planner=RegulatedPurePursuit(),
        ),
        config=config,
        instructions=["find the fire extinguisher"],
        seed=0,
        max_time_s=0.1,
    )
    assert getattr(getattr(result.services.config, section), key) == value
    assert result.memory.config == result.services.config.memory
