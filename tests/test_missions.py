"""Simulated missions are tests: the paper's mission on the MuJoCo backend, kinematic fidelity.

- Seed 0 of each scene (a list fixed before outcomes, ``slow`` marker): the mission declares success next
  to the goal object (within r_s of its footprint) and what it reached is of the instructed category.
- With the goal hidden (sunk under the floor, so no camera can see it), the robot explores among the
  distractors and never declares success: calibrated arbitration, the 3-of-8 confirmation vote and the
  label majority at the spot do not accept a red trash can for an extinguisher, a grey chair for a black
  chair, a toy robot dog for a quadruped robot, a plain shelf for a bucket shelf (living_room seed 1 is
  the episode where 3 of 4 votes alone confirmed that shelf, before the label majority).

The solved episodes use the protocol's embedding relevance scorer, loaded once per test process (about
15 s); the distractor episodes use the lexical one. The all-scene sweep is a benchmark command, not a
unit test.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

import semexp_bt.app.episode
import sims.catalogue
from semexp_bt.app.episode import EpisodeOptions, run_episode

MISSION = Path(__file__).resolve().parents[1] / "trees" / "object_search.yaml"

#: Seed 0 of every scene, fixed before any outcome of the navigation stack of issue #17 was seen (the list
#: before it was each scene's solved protocol episode, chosen from outcomes). How many of them the
#: committed code solves is stated in docs/planner.md; the test is behind the ``slow`` marker so that the
#: default suite does not depend on a benchmark figure (``pytest -m slow tests/test_missions.py``).
MISSION_EPISODES: list[tuple[str, int]] = [
    (scene, 0)
    for scene in ("garden_sim", "sidewalk", "road", "warehouse_a", "warehouse_b", "office", "showroom",
                  "laboratory", "living_room", "garden_real")
]  # fmt: skip


def _summary(record: dict) -> str:
    return (
        f"{record['scene']} seed {record['seed']}: {record['outcome']}, reached {record['reached_category']}, "
        f"{record['distance_to_goal_m']:.2f} m from the goal, path {record['path_length_m']:.1f} m "
        f"(L* {record['geodesic_length_m']:.1f}), {len(record['decisions'])} decisions, events "
        f"{[e['kind'] for e in record['events']][:12]}"
    )


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "seed"), MISSION_EPISODES)
def test_paper_mission_finds_the_goal(scene: str, seed: int) -> None:
    record = run_episode(EpisodeOptions(mission_path=MISSION, scene=scene, seed=seed, relevance="embedding"))
    print(_summary(record))
    assert record["outcome"] == "success", _summary(record)
    assert record["success"], _summary(record)
    assert record["reached_category"] == record["goal_category"], _summary(record)
    assert record["distance_to_goal_m"] <= record["success_radius_m"]
    assert record["path_length_m"] >= record["geodesic_length_m"] * 0.9  # a path cannot beat L* by much


@pytest.mark.parametrize("scene", ["office", "laboratory", "showroom", "living_room"])
def test_no_success_is_declared_when_only_distractors_are_there(
    scene: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The goal object is sunk 5 m under the floor: the camera never sees it, the distractors stay."""
    build = sims.catalogue.build_scene

    def without_visible_goal(name: str, *, seed: int):  # type: ignore[no-untyped-def]
        spec = build(name, seed=seed)
        objects = tuple(
            dataclasses.replace(o, position_m=(o.position_m[0], o.position_m[1], -5.0), is_obstacle=False)
            if o.object_id == spec.goal_object_id
            else o
            for o in spec.objects
        )
        return dataclasses.replace(spec, objects=objects)

    # The episode module's own name is patched: it imported build_scene (patching the catalogue's name
    # alone left the goal where it was, and the test passed only while the robot never came near it).
    monkeypatch.setattr(semexp_bt.app.episode, "build_scene", without_visible_goal)
    record = run_episode(
        EpisodeOptions(
            mission_path=MISSION,
            scene=scene,
            seed=1,
            relevance="lexical",
            max_sim_s=150.0,
        )
    )
    print(_summary(record))
    assert record["goal"]["position_m"][2] == -5.0, "the episode ran on the scene with the goal sunk"
    assert record["outcome"] != "success", _summary(record)
    assert record["found_objects"] == []
    assert record["decisions"], "the robot should have explored (decided at least once) before giving up"
    # The mission loop's wall time (what the ROS 2 bench compares) is within the episode's, set-up aside.
    assert 0.0 < record["mission_wall_s"] < record["wall_time_s"]


@pytest.mark.slow
def test_dynamic_fidelity_mission_walks_with_the_rl_gait_without_falling() -> None:
    """Dynamic fidelity: legs, physics and the shipped RL gait realise the planner's twists."""
    record = run_episode(
        EpisodeOptions(
            mission_path=MISSION,
            scene="showroom",
            seed=1,
            relevance="lexical",
            fidelity="dynamic",
            max_sim_s=120.0,
        )
    )
    print(_summary(record))
    assert record["fidelity"] == "dynamic"
    assert record["outcome"] != "fallen" and not any(e["kind"] == "fallen" for e in record["events"])
    assert record["path_length_m"] > 5.0, "the gait should carry the robot through several subgoals"
    assert len(record["decisions"]) >= 3
