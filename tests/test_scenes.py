"""Scene catalogue: every scene builds, is reachable, is deterministic per seed, and matches its docs."""

from __future__ import annotations

import argparse
import json
import math
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from semexp_bt.cli import scene as scene_cli
from semexp_bt.core.scene import SceneSpec
from semexp_bt.core.types import InvalidInputError
from sims.catalogue import UnknownSceneError, build_scene, list_scenes, scene_summary
from sims.geodesic import GeodesicOracle
from sims.naming import named_objects
from sims.occupancy import GridGeometry, rasterise_object
from sims.scenes import placement
from sims.scenes.placement import (
    GOAL_APPROACH_MARGIN_M,
    GOAL_SUCCESS_RADIUS_M,
    SceneDataError,
    load_scene_data,
)

SEEDS = range(20)

#: name -> (area m^2 or None for the simulation scenes, goal label, labels of the semantically close
#: distractors). This is the table in docs/scenes.md.
DOCUMENTED = {
    "garden_sim": (None, "green bin", {"blue bin"}),
    "sidewalk": (None, "traffic sign", {"advertising board"}),
    "road": (None, "bus station", {"kiosk"}),
    "warehouse_a": (None, "loading cart", {"hand truck"}),
    "warehouse_b": (None, "fire extinguisher", {"red trash can", "red gas cylinder"}),
    "office": (30.0, "fire extinguisher", {"red trash can"}),
    "showroom": (40.0, "quadruped robot", {"toy robot dog", "robot arm"}),
    "laboratory": (30.0, "black chair", {"grey chair"}),
    "living_room": (30.0, "bucket shelf", {"shelf"}),
    "garden_real": (50.0, "carton box", {"plastic crate"}),
}


@cache
def scene(name: str, seed: int) -> SceneSpec:
    return build_scene(name, seed=seed)


def test_catalogue_lists_the_ten_documented_scenes() -> None:
    assert list_scenes() == list(DOCUMENTED)


@pytest.mark.parametrize("name", list(DOCUMENTED))
def test_every_seed_builds_with_a_reachable_goal(name: str) -> None:
    for seed in SEEDS:
        spec = scene(name, seed)
        oracle = GeodesicOracle(spec)
        field = oracle.object_distance_field(spec.goal_object_id, success_radius_m=GOAL_SUCCESS_RADIUS_M)
        reachable = np.isfinite(field)
        assert reachable.any(), f"{name} seed {seed}: goal unreachable"
        # Deeper than the success region's rim: the robot can stand well inside r_s.
        inner = GOAL_SUCCESS_RADIUS_M - GOAL_APPROACH_MARGIN_M
        approach = oracle.object_distance_field(spec.goal_object_id, success_radius_m=inner)
        assert np.isfinite(approach).any(), f"{name} seed {seed}: goal reachable only on the rim of r_s"
        # Somewhere reachable is far enough for an episode: the sampler's minimum is feasible.
        assert field[reachable].max() >= spec.extra["min_geodesic_m"], f"{name} seed {seed}"


@pytest.mark.parametrize("name", list(DOCUMENTED))
def test_same_seed_same_scene_and_different_seeds_different_layouts(name: str) -> None:
    assert build_scene(name, seed=3) == build_scene(name, seed=3)
    layouts = set()
    for seed in range(5):
        placed = tuple(obj.position_m for obj in scene(name, seed).objects if obj.role != "wall")
        layouts.add(placed)
    assert len(layouts) == 5
    goal_positions = {scene(name, seed).goal.position_m[:2] for seed in SEEDS}
    assert len(goal_positions) == len(SEEDS)


@pytest.mark.parametrize("name", list(DOCUMENTED))
def test_roles_labels_and_sizes_match_the_docs(name: str) -> None:
    area, goal_label, distractor_labels = DOCUMENTED[name]
    for seed in (0, 7):
        spec = scene(name, seed)
        roles = [obj.role for obj in spec.objects]
        assert roles.count("goal") == 1 and spec.goal.role == "goal"
        assert "occluder" in roles
        assert spec.goal.label == goal_label
        assert spec.goal.category == spec.goal_category
        assert goal_label.split()[-1] in spec.instruction
        distractors = {obj.label for obj in spec.objects if obj.role == "distractor"}
        assert distractors == distractor_labels
        # The scene's own instruction names the goal and never a distractor (sims/naming.py).
        named = named_objects(spec, spec.instruction)
        assert spec.goal in named and not any(obj.role == "distractor" for obj in named)
        assert [obj.object_id for obj in spec.objects] == list(range(len(spec.objects)))
        assert len({obj.name for obj in spec.objects}) == len(spec.objects)
        assert roles.count("wall") == 4
        x_min, y_min, x_max, y_max = spec.bounds_m
        width, depth = x_max - x_min, y_max - y_min
        if area is None:  # simulation scenes: a street-block section or a warehouse hall
            assert 12.0 <= width <= 16.0 and 12.0 <= depth <= 16.0
        else:
            assert width * depth == pytest.approx(area)
        assert scene_summary(name).area_m2 == pytest.approx(width * depth)


@pytest.mark.parametrize("name", list(DOCUMENTED))
def test_obstacles_stay_in_bounds_and_do_not_overlap(name: str) -> None:
    spec = scene(name, 1)
    grid = GridGeometry.over_bounds(spec.bounds_m, resolution_m=0.05)
    seen = np.zeros(grid.shape, dtype=bool)
    for obj in spec.objects:
        if obj.role == "wall" or not obj.is_obstacle:
            continue
        x, y, _ = obj.position_m
        assert spec.bounds_m[0] <= x <= spec.bounds_m[2] and spec.bounds_m[1] <= y <= spec.bounds_m[3]
        mask = rasterise_object(obj, grid)
        assert mask.any(), obj.name
        assert not (mask & seen).any(), f"{name}: {obj.name} overlaps an earlier obstacle"
        seen |= mask


def test_bad_names_and_seeds_are_rejected() -> None:
    with pytest.raises(UnknownSceneError, match="known scenes: garden_sim"):
        build_scene("moon_base", seed=0)
    with pytest.raises(InvalidInputError, match="seed"):
        build_scene("office", seed=-1)


def test_malformed_scene_data_names_the_file_and_key(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    data = json.loads(json.dumps(load_scene_data("office")))
    del data["kinds"]["desk"]["rgba"]
    (tmp_path / "broken.yaml").write_text(json.dumps(data))
    data["objects"][2]["slot"] = "nowhere"
    del data["kinds"]["desk"]
    (tmp_path / "broken2.yaml").write_text(json.dumps(data))
    monkeypatch.setattr(placement, "DATA_DIR", tmp_path)
    placement.load_scene_data.cache_clear()
    try:
        with pytest.raises(SceneDataError, match=r"broken\.yaml: kinds\.desk: missing key 'rgba'"):
            load_scene_data("broken")
        with pytest.raises(
            SceneDataError, match=r"broken2\.yaml: objects\[2\]\.slot: unknown slot group 'nowhere'"
        ):
            load_scene_data("broken2")
        with pytest.raises(SceneDataError, match="not found"):
            load_scene_data("absent")
    finally:
        placement.load_scene_data.cache_clear()


def test_scene_list_prints_every_scene(capsys: pytest.CaptureFixture[str]) -> None:
    assert scene_cli.run(argparse.Namespace(scene_command="list")) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:3] == ["name", "title", "area"]
    for name in DOCUMENTED:
        assert any(line.startswith(name + " ") for line in lines)
    office_line = next(line for line in lines if line.startswith("office "))
    assert "30" in office_line.split() and "find the fire extinguisher" in office_line


def test_scene_render_writes_topdown_and_episode(tmp_path: Path) -> None:
    args = argparse.Namespace(
        scene_command="render", scene="laboratory", seed=2, episode_seed=None, out=tmp_path, no_camera=True
    )
    assert scene_cli.run(args) == 0
    assert (tmp_path / "topdown.png").stat().st_size > 10_000
    record = json.loads((tmp_path / "episode.json").read_text())
    assert record["episode"]["seed"] == 2 and record["scene"]["seed"] == 2
    assert record["goal_object"]["label"] == "black chair"
    assert record["scene"]["area_m2"] == pytest.approx(30.0)
    path = np.asarray(record["geodesic_path_m"])
    length = float(np.hypot(*np.diff(path, axis=0).T).sum())
    assert length == pytest.approx(record["episode"]["geodesic_length_m"], abs=0.01)
    assert math.dist(path[0], (record["episode"]["start"]["x_m"], record["episode"]["start"]["y_m"])) < 1e-3
