"""The mission executive end to end on a backend with no physics: every shipped tree is loaded and ticked.

The robot is :class:`robots.null_robot.NullRobot` (a perfect unicycle whose camera ray-casts a floor and
vertical posts) and perception is scripted from what the camera really sees: each visible post is
reported by the "detector" and the "VLM" with the labels and confidences the test sets. This isolates
the tree, the behaviours and the paper's maths from MuJoCo and from the emulator's noise, so each test
can state exactly what the robot must do. Each test prints the tree it asserts on.
"""

from __future__ import annotations

import dataclasses
import enum
import io
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
import pytest

from behaviours.services import MissionServices
from blackboard.schema import SCHEMA, SchemaError, checked_write, register_keys, summarize
from robots.null_robot import NullRobot
from semexp_bt.app.executive import MissionTree, build_tree, prepare_board
from semexp_bt.app.recorder import TickRecorder, replay
from semexp_bt.app.runner import MissionRun
from semexp_bt.core.config import SemExpConfig
from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.relevance import CachedRelevance, LexicalRelevance
from semexp_bt.core.types import (
    Detection,
    Observation,
    Pose2D,
    SceneEvidence,
    SceneProposal,
    Subgoal,
    Twist,
)
from semexp_bt.nav.pure_pursuit import RegulatedPurePursuit
from semexp_bt.perception.interface import PerceptionResult
from sims.scripted_perception import ScriptedPerception

TREES = Path(__file__).resolve().parents[1] / "trees"
TICK_S = 0.02


@dataclass(frozen=True)
class Post:
    """A vertical cylinder in the NullRobot's world and what each model says about it."""

    object_id: int
    x_m: float
    y_m: float
    vlm_label: str
    detector_label: str | None  # None: the detector never reports it
    detector_confidence: float = 0.9
    radius_m: float = 0.2
    height_m: float = 0.6


def seeing(posts: list[Post], *, directions: bool = True) -> Callable[[Observation], PerceptionResult]:
    """Scripted evidence from the segmentation: boxes from visible masks, VLM points at mask centres."""

    def answer(observation: Observation) -> PerceptionResult:
        proposals: list[SceneProposal] = []
        detections: list[Detection] = []
        seg = observation.segmentation
        assert seg is not None
        for post in posts:
            rows, cols = np.nonzero(seg == post.object_id)
            if rows.size < 30:
                continue
            box = (float(cols.min()), float(rows.min()), float(cols.max()), float(rows.max()))
            centre = ((box[0] + box[2]) / 2, (box[1] + box[3]) / 2)
            proposals.append(SceneProposal(point_px=centre, label=post.vlm_label, kind="object"))
            if post.detector_label is not None:
                detections.append(Detection(box, post.detector_label, post.detector_confidence))
        if directions:
            proposals.append(
                SceneProposal(point_px=(40.0, 170.0), label="open area on the left", kind="direction")
            )
            proposals.append(
                SceneProposal(point_px=(280.0, 170.0), label="open area on the right", kind="direction")
            )
        return PerceptionResult(
            scene=SceneEvidence(tuple(proposals), 0.85),
            detections=tuple(detections),
            observation_stamp_s=observation.stamp_s,
        )

    return answer


def make_services(
    robot: NullRobot,
    answer: Callable[[Observation], PerceptionResult],
    *,
    budget_s: float = 240.0,
    config: SemExpConfig | None = None,
) -> MissionServices:
    return MissionServices(
        robot=robot,
        perception=ScriptedPerception([answer], latency_s=2.5),
        relevance=CachedRelevance(LexicalRelevance()),
        config=config or SemExpConfig(),
        planner=RegulatedPurePursuit(),
        rng=np.random.default_rng(0),
        budget_s=budget_s,
    )


def run(
    mission: str,
    services: MissionServices,
    instructions: list[str],
    *,
    max_sim_s: float = 400.0,
    recorder_kwargs: dict | None = None,
) -> tuple[py_trees.trees.BehaviourTree, py_trees.blackboard.Client]:
    robot = services.robot
    board = prepare_board(
        instructions=instructions,
        start_pose=robot.base_pose(),
        memory=TopologicalMemory(services.config.memory),
        activity_stream=recorder_kwargs is not None,
    )
    tree = build_tree(TREES / mission, services=services)
    recorder = TickRecorder(**(recorder_kwargs or {"path": None, "display": False}))
    recorder.start(MissionRun(tree=tree, board=board, services=services))
    tree.setup()
    ticks = 0
    while robot.now_s() < max_sim_s:
        tree.tick()
        ticks += 1
        recorder.record_tick(ticks, robot.now_s())
        if tree.root.status != py_trees.common.Status.RUNNING:
            break
        robot.advance(TICK_S)
    recorder.close()
    print(py_trees.display.unicode_tree(tree.root, show_status=True))
    return tree, board


def test_object_search_finds_the_target_and_stops_next_to_it() -> None:
    target = Post(1, 3.0, 0.6, vlm_label="fire extinguisher", detector_label="fire extinguisher")
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, math.pi), posts=((1, 3.0, 0.6, 0.2, 0.6),))
    services = make_services(robot, seeing([target]))
    tree, board = run("object_search.yaml", services, ["find the fire extinguisher"])
    assert tree.root.status == py_trees.common.Status.SUCCESS
    assert board.mission_outcome == "success"
    assert [f["label"] for f in board.found_objects] == ["fire extinguisher"]
    pose = robot.base_pose()
    assert math.hypot(pose.x_m - 3.0, pose.y_m - 0.6) < 1.6
    assert robot.stopped >= 1 and robot.base_twist().linear_x_mps == 0.0
    # The panorama saw the target behind the start heading, so the first decision already chose it.
    first = services.decision_log[0]
    chosen = next(c for c in first["candidates"] if c["node_id"] == first["selected_node_id"])
    assert chosen["label"] == "fire extinguisher"


def test_a_distractor_the_detector_confuses_is_never_confirmed() -> None:
    """The detector calls a red trash can a weak 'fire extinguisher'; the VLM says 'red trash can'.

    Cross-source consistency leaves the uncorroborated confusion with a low posterior score, so the robot
    may go and look, but it never declares success there; it finds the real extinguisher instead.
    """
    distractor = Post(
        2, 2.5, -0.5, vlm_label="red trash can", detector_label="fire extinguisher", detector_confidence=0.45
    )
    target = Post(1, -3.0, 2.5, vlm_label="fire extinguisher", detector_label="fire extinguisher")
    robot = NullRobot(
        start_pose=Pose2D(0.0, 0.0, 0.0), posts=((2, 2.5, -0.5, 0.2, 0.6), (1, -3.0, 2.5, 0.2, 0.6))
    )
    services = make_services(robot, seeing([distractor, target]))
    tree, board = run("object_search.yaml", services, ["find the fire extinguisher"])
    assert board.mission_outcome == "success"
    found = board.found_objects[-1]["position_m"]
    assert math.hypot(found[0] + 3.0, found[1] - 2.5) < 0.5, f"confirmed at {found}, not at the extinguisher"
    assert not any(
        math.hypot(f["position_m"][0] - 2.5, f["position_m"][1] + 0.5) < 1.0 for f in board.found_objects
    )


def test_budget_guard_fails_the_mission_safely_when_nothing_is_found() -> None:
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    services = make_services(robot, seeing([]), budget_s=40.0)
    tree, board = run("object_search.yaml", services, ["find the fire extinguisher"])
    assert tree.root.status == py_trees.common.Status.FAILURE
    assert board.mission_outcome == "budget_exceeded"
    assert robot.now_s() == pytest.approx(40.0, abs=0.05)
    assert robot.stopped >= 1 and robot.base_twist().linear_x_mps == 0.0
    assert any(e["kind"] == "budget_exceeded" for e in services.events)


def test_multi_object_search_confirms_each_object_in_turn() -> None:
    posts = [
        Post(1, 3.0, 0.0, "fire extinguisher", "fire extinguisher"),
        Post(2, -2.0, 2.5, "red trash can", None),
    ]

    def answer(observation: Observation) -> PerceptionResult:
        # The detector is prompted with the current target: it reports only what matches the prompt.
        prompt = services.perception.requests[-1][1]
        result = seeing(posts)(observation)
        dets = tuple(d for d in result.detections if d.label == prompt)
        if prompt == "red trash can":
            dets += tuple(Detection(p.box_xyxy_px, "red trash can", 0.9) for p in _boxes(observation, 2))
        return PerceptionResult(scene=result.scene, detections=dets, observation_stamp_s=observation.stamp_s)

    robot = NullRobot(
        start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, 3.0, 0.0, 0.2, 0.6), (2, -2.0, 2.5, 0.2, 0.6))
    )
    services = make_services(robot, answer, budget_s=500.0)
    tree, board = run(
        "multi_object_search.yaml",
        services,
        ["find the fire extinguisher", "find the red trash can"],
        max_sim_s=520.0,
    )
    assert tree.root.status == py_trees.common.Status.SUCCESS, [e for e in services.events]
    assert [f["label"] for f in board.found_objects] == ["fire extinguisher", "red trash can"]
    assert board.instructions_left == []


@dataclass(frozen=True)
class _Box:
    box_xyxy_px: tuple[float, float, float, float]


def _boxes(observation: Observation, object_id: int) -> list[_Box]:
    rows, cols = np.nonzero(observation.segmentation == object_id)
    if rows.size < 30:
        return []
    return [_Box((float(cols.min()), float(rows.min()), float(cols.max()), float(rows.max())))]


def test_search_and_return_walks_back_to_the_start() -> None:
    target = Post(1, 3.5, 0.0, "fire extinguisher", "fire extinguisher")
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, 3.5, 0.0, 0.2, 0.6),))
    services = make_services(robot, seeing([target]), budget_s=400.0)
    tree, board = run("search_and_return.yaml", services, ["find the fire extinguisher"])
    assert tree.root.status == py_trees.common.Status.SUCCESS
    assert [f["label"] for f in board.found_objects] == ["fire extinguisher"]
    pose = robot.base_pose()
    assert math.hypot(pose.x_m, pose.y_m) < 0.6, (
        f"ended at ({pose.x_m:.2f}, {pose.y_m:.2f}), not at the start"
    )


def test_two_missions_in_one_process_share_no_state() -> None:
    target = Post(1, 3.0, 0.0, "fire extinguisher", "fire extinguisher")
    first_robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, 3.0, 0.0, 0.2, 0.6),))
    first = make_services(first_robot, seeing([target]))
    _, board_one = run("object_search.yaml", first, ["find the fire extinguisher"])
    memory_one, map_one = board_one.memory, board_one.local_map  # the board is process-wide: keep the objects
    assert board_one.mission_outcome == "success" and len(memory_one) > 1

    empty_robot = NullRobot(start_pose=Pose2D(10.0, 10.0, 0.0))
    second = make_services(empty_robot, seeing([], directions=False), budget_s=20.0)
    _, board_two = run("object_search.yaml", second, ["find the fire extinguisher"])
    assert board_two.memory is not memory_one
    # Nothing carried over: no node of the first mission (all near the origin, one a fire extinguisher)
    # is in the second memory, whose nodes all lie around its own start at (10, 10).
    assert all(
        math.hypot(n.position_m[0] - 10.0, n.position_m[1] - 10.0) < 8.0 for n in board_two.memory.nodes()
    )
    assert not any(n.label == "fire extinguisher" for n in board_two.memory.nodes())
    map_two = board_two.local_map
    assert map_two is not map_one and map_two.origin_xy == (10.0, 10.0)
    assert map_one.state_at((2.82, 0.0)) == "lethal"  # the first map saw the post ...
    assert map_two.state_at((2.82, 0.0)) == "unknown"  # ... the second map has never seen it
    assert board_two.found_objects == [] and board_two.mission_outcome == "budget_exceeded"


def test_display_shows_changes_and_the_record_replays(tmp_path: Path) -> None:
    target = Post(1, 2.5, 0.0, "fire extinguisher", "fire extinguisher")
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, 2.5, 0.0, 0.2, 0.6),))
    services = make_services(robot, seeing([target]))
    stream = io.StringIO()
    record = tmp_path / "ticks.jsonl"
    tree, board = run(
        "object_search.yaml",
        services,
        ["find the fire extinguisher"],
        recorder_kwargs={"path": record, "display": True, "stream": stream},
    )
    shown = stream.getvalue()
    assert board.mission_outcome == "success"
    assert "--- tick 1 " in shown and "[o] Mission" in shown.replace("[-]", "[o]") or "Mission" in shown
    assert "memory:" in shown and "subgoal: node" in shown and "board /target <- Arbitrate" in shown
    # Only ticks where something changed are shown: far fewer blocks than ticks.
    ticks = sum(1 for _ in record.open())
    assert 0 < shown.count("--- tick ") < ticks / 3
    lines = [json.loads(line) for line in record.open()]
    assert lines[0]["tick"] == 1 and "Gait50Hz" in lines[0]["nodes"]
    assert all(node["ms"] >= 0.0 for line in lines for node in line["nodes"].values())
    out = io.StringIO()
    assert replay(record, stream=out) == ticks
    assert "ConfirmTarget: SUCCESS" in out.getvalue()


def test_no_display_and_no_record_add_no_visitor() -> None:
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    services = make_services(robot, seeing([]), budget_s=5.0)
    prepare_board(
        instructions=["find the fire extinguisher"],
        start_pose=robot.base_pose(),
        memory=TopologicalMemory(services.config.memory),
    )
    tree = build_tree(TREES / "object_search.yaml", services=services)
    board = py_trees.blackboard.Client(name="test")
    TickRecorder(path=None, display=False).start(MissionRun(tree=tree, board=board, services=services))
    assert tree.visitors == []
    assert py_trees.blackboard.Blackboard.activity_stream is None


def test_schema_refuses_unknown_keys_wrong_types_and_undeclared_remaps() -> None:
    prepare_board(instructions=["find x"], start_pose=Pose2D(0, 0, 0), memory=TopologicalMemory())
    client = py_trees.blackboard.Client(name="probe")
    with pytest.raises(SchemaError, match="not in blackboard.schema.SCHEMA"):
        register_keys(client, read=("no_such_key",))
    with pytest.raises(SchemaError, match="not in blackboard.schema.SCHEMA"):
        register_keys(client, read=("subgoal",), remap={"subgoal": "somewhere_else"})
    with pytest.raises(SchemaError, match="does not use"):
        register_keys(client, read=("subgoal",), remap={"memory": "subgoal"})
    register_keys(client, write=("mission_outcome",))
    with pytest.raises(SchemaError, match="expects"):
        checked_write(client, "mission_outcome", 3)
    assert set(SCHEMA) >= {"memory", "subgoal", "target", "cmd_twist", "mission_outcome"}


@dataclass(frozen=True)
class _Leaf:
    label: str
    score: float


class _Kind(enum.Enum):
    NEAR = "near"


@dataclass
class _Branch:
    twist: Twist
    leaves: list[_Leaf]
    kind: _Kind = _Kind.NEAR
    trajectory: np.ndarray = field(default_factory=lambda: np.zeros((40, 3)))
    scores: dict[str, float] = field(default_factory=lambda: {"path": 0.5, "goal": math.inf})
    candidates: tuple[int, int] = (12, 3)


@dataclass
class _Tree:
    branch: _Branch
    pair: tuple[_Leaf, _Leaf]
    numbers: list[float]


def test_a_summary_reads_a_dataclass_as_asdict_copies_it() -> None:
    """The tick record's summaries skip ``asdict``'s deep copy where it copies a field into an equal value;
    what they say is what summarising ``asdict``'s copy says, nested dataclasses and long lists included."""

    def through_asdict(value: Any) -> dict[str, Any]:  # the summary as it was, from asdict's copy
        out = {}
        for key, item in dataclasses.asdict(value).items():
            if isinstance(item, np.ndarray) and item.size > 16:
                continue
            if isinstance(item, (list, tuple)) and len(item) > 20:
                item = f"<{len(item)} items>"
            out[key] = summarize(item)
        return out

    short = [_Leaf("chair", 0.25)]
    long = [_Leaf(f"leaf {i}", i / 7) for i in range(30)]
    values = [
        Twist(0.3, 0.0, -0.1),
        _Branch(Twist(0.2, 0.1, 0.0), short),
        _Branch(Twist(0.2, 0.1, 0.0), long, trajectory=np.arange(6.0).reshape(2, 3)),
        _Tree(_Branch(Twist(), short), (short[0], short[0]), [0.5] * 25),
        _Tree(_Branch(Twist(), long), (short[0], short[0]), [0.5, math.nan]),  # a nested long list, printed
        Subgoal(node_id=3, position_m=(1.0, 2.0, 0.0), label="door", utility=0.75),
    ]
    for value in values:
        assert json.dumps(summarize(value)) == json.dumps(through_asdict(value)), value


def test_remapped_memory_key_is_what_the_behaviours_use(tmp_path: Path) -> None:
    """A mission can point a behaviour's logical key elsewhere on the board; the schema must allow the target."""
    tree_file = tmp_path / "remap.yaml"
    tree_file.write_text(
        "tree:\n  type: Sequence\n  name: Root\n  params: {memory: true}\n  children:\n"
        "    - type: SetSubgoalToStart\n      name: Home\n      remap: {memory: memory}\n"
    )
    robot = NullRobot(start_pose=Pose2D(1.0, 2.0, 0.0))
    services = make_services(robot, seeing([]))
    board = prepare_board(instructions=["find x"], start_pose=robot.base_pose(), memory=TopologicalMemory())
    board.memory.add_master(position_m=(1.0, 2.0, 0.0), stamp_s=0.0)
    tree = build_tree(tree_file, services=services)
    tree.tick()
    print(py_trees.display.unicode_tree(tree.root, show_status=True))
    assert tree.root.status == py_trees.common.Status.SUCCESS
    assert board.subgoal is not None and board.subgoal.position_m[:2] == (1.0, 2.0)


#: One standpoint (``view_from_m: 0``): these tests are about the votes, with no costmap to move on; the two
#: standpoints are tests/behaviours/test_confirm_target.py's.
CONFIRM_TREE = (
    "tree:\n  type: Sequence\n  name: Root\n  params: {memory: true}\n  children:\n"
    "    - type: Perceive\n      name: Perceive\n"
    "    - type: Arbitrate\n      name: Arbitrate\n"
    "    - type: ConfirmTarget\n      name: Confirm\n      params: {view_from_m: 0.0}\n"
)


def confirm_tree_facing_a_post(  # type: ignore[no-untyped-def]
    tmp_path: Path, script: list, instruction: str, *, post_x_m: float = 0.8
):
    """CONFIRM_TREE on a robot facing one post ``post_x_m`` ahead, with scripted perception answers in order.

    Returns (tree, robot, services, board); the tree is set up, not yet ticked.
    """
    tree_file = tmp_path / "confirm.yaml"
    tree_file.write_text(CONFIRM_TREE)
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, post_x_m, 0.0, 0.2, 0.6),))
    services = make_services(robot, script[0])
    services.perception = ScriptedPerception(script, latency_s=1.0)
    board = prepare_board(
        instructions=[instruction], start_pose=robot.base_pose(), memory=TopologicalMemory()
    )
    board.memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    tree = build_tree(tree_file, services=services)
    tree.setup()
    return tree, robot, services, board


def tick_until_done(tree, robot, *, limit_s: float = 30.0) -> None:  # type: ignore[no-untyped-def]
    """Tick until the root leaves RUNNING (or ``limit_s`` of robot time), then print the tree."""
    while robot.now_s() < limit_s:
        tree.tick()
        if tree.root.status != py_trees.common.Status.RUNNING:
            break
        robot.advance(TICK_S)
    print(py_trees.display.unicode_tree(tree.root, show_status=True))


@pytest.mark.parametrize(
    ("extra_view_votes", "outcome", "views_taken"),
    [
        ((True, True, True), py_trees.common.Status.SUCCESS, 3),
        ((False, True, True, True), py_trees.common.Status.SUCCESS, 4),
        ((True, True, False, True), py_trees.common.Status.SUCCESS, 4),
        ((False,) * 5 + (True,) * 3, py_trees.common.Status.SUCCESS, 8),
        ((False,) * 6, py_trees.common.Status.FAILURE, 6),
        ((True, True) + (False,) * 6, py_trees.common.Status.FAILURE, 8),
    ],
)
def test_confirmation_is_three_votes_out_of_at_most_eight_further_views(
    tmp_path: Path, extra_view_votes: tuple[bool, ...], outcome: py_trees.common.Status, views_taken: int
) -> None:
    """The target 0.8 m ahead; each further view either sees it or sees nothing. ConfirmTarget succeeds as
    soon as three further views vote, and fails as soon as three votes can no longer be reached in eight."""
    target = Post(1, 0.8, 0.0, vlm_label="fire extinguisher", detector_label="fire extinguisher")
    sees, blind = seeing([target], directions=False), seeing([], directions=False)
    script = [sees] + [sees if vote else blind for vote in extra_view_votes]
    tree, robot, services, board = confirm_tree_facing_a_post(tmp_path, script, "find the fire extinguisher")
    tick_until_done(tree, robot)
    assert tree.root.status == outcome
    assert len(services.perception.requests) == 1 + views_taken
    found = board.found_objects if outcome == py_trees.common.Status.SUCCESS else []
    assert [f["label"] for f in found] == (["fire extinguisher"] if found else [])


def test_decide_falls_back_to_unreached_nodes_when_every_potential_decayed(tmp_path: Path) -> None:
    """Eq. 8 leaves no candidate (all potentials under tau_p); Decide then picks among never-reached nodes."""
    tree_file = tmp_path / "decide.yaml"
    tree_file.write_text("tree:\n  type: Decide\n  name: Decide\n")
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    services = make_services(robot, seeing([]))
    board = prepare_board(instructions=["find the fire extinguisher"], start_pose=robot.base_pose(),
                          memory=TopologicalMemory())  # fmt: skip
    memory = board.memory
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    reached = memory.update(position_m=(1.0, 0.0, 0.3), label="unexplored area", confidence=0.6, stamp_s=0.0)
    glimpsed = memory.update(position_m=(3.0, 1.0, 0.3), label="unexplored area", confidence=0.6, stamp_s=0.0)
    memory.mark_visited(node_id=reached.node_id)
    for node_id in (reached.node_id, glimpsed.node_id):
        memory.scale_potential(node_id=node_id, factor=0.1)
    tree = build_tree(tree_file, services=services)
    tree.tick()
    print(py_trees.display.unicode_tree(tree.root, show_status=True))
    assert tree.root.status == py_trees.common.Status.SUCCESS
    assert board.subgoal.node_id == glimpsed.node_id
    assert services.decision_log[-1]["reason"].startswith("relaxed: ")

    # The relaxed choice was not reached (its potential only fell): it is not chosen a second time.
    memory.scale_potential(node_id=glimpsed.node_id, factor=0.2)
    tree.tick()
    assert tree.root.status == py_trees.common.Status.FAILURE
    assert board.subgoal is None
    assert services.decision_log[-1]["reason"] == "relaxed: empty candidate set"

    strict = tmp_path / "strict.yaml"
    strict.write_text("tree:\n  type: Decide\n  name: Decide\n  params: {relax_when_exhausted: false}\n")
    tree = build_tree(strict, services=services)
    tree.tick()
    assert tree.root.status == py_trees.common.Status.FAILURE
    assert services.decision_log[-1]["reason"] == "empty candidate set"


def test_oracle_decide_uses_the_privileged_goal_and_refuses_to_run_without_it(tmp_path: Path) -> None:
    """The oracle strategy ranks by travel + true goal distance: geodesic when given, else straight line."""
    tree_file = tmp_path / "decide.yaml"
    tree_file.write_text("tree:\n  type: Decide\n  name: Decide\n")
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    services = make_services(robot, seeing([]))
    services.strategy = {"decision": "oracle"}
    board = prepare_board(instructions=["find the fire extinguisher"], start_pose=robot.base_pose(),
                          memory=TopologicalMemory())  # fmt: skip
    memory = board.memory
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    east = memory.update(position_m=(2.0, 0.0, 0.3), label="unexplored area", confidence=0.6, stamp_s=0.0)
    west = memory.update(position_m=(-2.0, 0.0, 0.3), label="unexplored area", confidence=0.6, stamp_s=0.0)
    tree = build_tree(tree_file, services=services)

    services.privileged_goal_xy = (-6.0, 0.0)
    tree.tick()
    print(py_trees.display.unicode_tree(tree.root, show_status=True))
    assert tree.root.status == py_trees.common.Status.SUCCESS
    assert board.subgoal.node_id == west.node_id

    # A geodesic distance overrides the straight line (here: the way west is walled off).
    services.privileged_goal_distance = lambda xy: 1.0 if xy[0] > 0.0 else 50.0
    tree.tick()
    assert board.subgoal.node_id == east.node_id

    services.privileged_goal_xy = services.privileged_goal_distance = None
    with pytest.raises(RuntimeError, match="privileged_goal_xy"):
        tree.tick()


REVIVE_TREE = """
tree:
  type: Sequence
  name: Look
  params: {memory: true}
  children:
    - {type: Perceive, name: Perceive}
    - {type: Arbitrate, name: Arbitrate}
    - {type: UpdateMemory, name: UpdateMemory, params: {max_revivals: 2}}
"""


@pytest.mark.parametrize(
    ("vlm_label", "detector_confidence", "revivals"),
    [("fire extinguisher", 0.9, 2), ("red box", 0.4, 0)],
    ids=["both-sources-agree", "one-weak-detection"],
)
def test_clear_sight_of_the_target_revives_its_demoted_node_at_most_twice(
    tmp_path: Path, vlm_label: str, detector_confidence: float, revivals: int
) -> None:
    """A demoted target node regains its potential when the robot sees the target clearly again (both
    sources agree, raw Eq. 2 score over revive_min_score), twice at most; a lone weak detection that the
    VLM contradicts revives nothing."""
    tree_file = tmp_path / "revive.yaml"
    tree_file.write_text(REVIVE_TREE)
    target = Post(
        1, 2.0, 0.0, vlm_label=vlm_label, detector_label="fire extinguisher",
        detector_confidence=detector_confidence,
    )  # fmt: skip
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, 2.0, 0.0, 0.2, 0.6),))
    services = make_services(robot, seeing([target], directions=False))
    board = prepare_board(
        instructions=["find the fire extinguisher"], start_pose=robot.base_pose(), memory=TopologicalMemory()
    )
    board.memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    tree = build_tree(tree_file, services=services)
    tree.setup()

    def look() -> None:
        tree.tick()
        while tree.root.status == py_trees.common.Status.RUNNING:
            robot.advance(TICK_S)
            tree.tick()
        print(py_trees.display.unicode_tree(tree.root, show_status=True))
        assert tree.root.status == py_trees.common.Status.SUCCESS

    look()
    (node,) = [n for n in board.memory.nodes() if n.label == "fire extinguisher"]
    potentials = []
    for _ in range(3):
        board.memory.scale_potential(node_id=node.node_id, factor=0.1)
        look()
        potentials.append(board.memory.node(node.node_id).potential)
    confidence = board.memory.node(node.node_id).confidence
    revived = [p >= confidence - 1e-9 for p in potentials]
    assert revived == [True] * revivals + [False] * (3 - revivals)


@pytest.mark.parametrize(
    ("views_naming_something_else", "outcome"),
    [(1, py_trees.common.Status.SUCCESS), (2, py_trees.common.Status.FAILURE)],
)
def test_confirmation_needs_most_names_heard_at_the_spot_to_name_the_target(
    tmp_path: Path, views_naming_something_else: int, outcome: py_trees.common.Status
) -> None:
    """An object the VLM first calls 'shelf' (earlier steps) and then 'bucket shelf' in four views: with one
    earlier 'shelf', 4 of 5 names agree (>= 0.7) and it is confirmed; with two, 4 of 6 do not."""
    as_target = Post(1, 0.8, 0.0, vlm_label="bucket shelf", detector_label="bucket shelf")
    as_other = Post(1, 0.8, 0.0, vlm_label="shelf", detector_label=None)
    named_target, named_other = seeing([as_target], directions=False), seeing([as_other], directions=False)
    script = [named_other] * views_naming_something_else + [named_target] * 4
    tree, robot, services, _ = confirm_tree_facing_a_post(tmp_path, script, "find the bucket shelf")
    statuses = []
    while robot.now_s() < 60.0 and len(statuses) < views_naming_something_else + 1:
        tree.tick()
        if tree.root.status != py_trees.common.Status.RUNNING:
            statuses.append(tree.root.status)
        robot.advance(TICK_S)
    print(py_trees.display.unicode_tree(tree.root, show_status=True))
    # Each earlier step's single view names a shelf, so its confirmation fails at once.
    assert statuses[:-1] == [py_trees.common.Status.FAILURE] * views_naming_something_else
    assert statuses[-1] == outcome
    assert len(services.perception.requests) == views_naming_something_else + 4


@pytest.mark.parametrize(
    ("post_x_m", "outcome"),
    [(1.05, py_trees.common.Status.SUCCESS), (1.45, py_trees.common.Status.FAILURE)],
    ids=["surface-0.85m-confirmed", "surface-1.25m-votes-but-beyond-r_s"],
)
def test_confirmation_declares_only_when_the_mean_vote_lies_within_the_success_radius(
    tmp_path: Path, post_x_m: float, outcome: py_trees.common.Status
) -> None:
    """Single views may vote up to confirm_radius_m + vote_slack_m (1.3 m) away; success needs the mean
    voting position within confirm_radius_m less declare_margin_m (0.95 m). A post whose front surface is 1.25 m away gets every
    vote and is still not declared."""
    target = Post(1, post_x_m, 0.0, vlm_label="fire extinguisher", detector_label="fire extinguisher")
    sees = seeing([target], directions=False)
    tree, robot, services, _ = confirm_tree_facing_a_post(
        tmp_path, [sees] * 5, "find the fire extinguisher", post_x_m=post_x_m
    )
    tick_until_done(tree, robot)
    assert tree.root.status == outcome
    assert len(services.perception.requests) == 4  # the first view and three voting further views


@pytest.mark.parametrize(("rate_hz", "expected_frames"), [(12.0, 24), (6.0, 12), (1.0, 2)])
def test_the_costmap_takes_depth_at_its_own_rate(
    tmp_path: Path, rate_hz: float, expected_frames: int
) -> None:
    """The controller runs at 12 Hz, the costmap takes a depth frame at its RateLimiter's rate (the first
    tick always does). In 2 simulated seconds: 24 control cycles, and 24, 12 or 2 costmap frames."""
    tree_file = tmp_path / "plan.yaml"
    tree_file.write_text(
        "tree:\n  type: Parallel\n  name: Nav\n  params: {policy: SuccessOnAll}\n  children:\n"
        f"    - type: RateLimiter\n      name: Map\n      params: {{rate_hz: {rate_hz}}}\n      children:\n"
        "        - type: UpdateCostmap\n          name: UpdateCostmap\n"
        "    - type: RateLimiter\n      name: Plan12Hz\n      params: {rate_hz: 12.0}\n      children:\n"
        "        - type: ComputePathToSubgoal\n          name: ComputePath\n"
        "    - type: RateLimiter\n      name: Follow12Hz\n      params: {rate_hz: 12.0}\n      children:\n"
        "        - type: FollowPath\n          name: FollowPath\n"
    )
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0))
    services = make_services(robot, seeing([]))
    board = prepare_board(instructions=["find x"], start_pose=robot.base_pose(), memory=TopologicalMemory())
    board.subgoal = Subgoal(node_id=1, position_m=(30.0, 0.0, 0.0), label="far away", utility=1.0)
    tree = build_tree(tree_file, services=services)
    tree.setup()
    cycles = 0
    while robot.now_s() < 2.0 - 1e-9:
        before = py_trees.blackboard.Blackboard.storage.get("/plan")
        tree.tick()
        cycles += py_trees.blackboard.Blackboard.storage.get("/plan") is not before
        robot.advance(TICK_S)
    print(py_trees.display.unicode_tree(tree.root, show_status=True))
    assert tree.root.status == py_trees.common.Status.RUNNING
    assert cycles == 24
    assert board.local_map.frames == expected_frames


def _recorded_ticks(tree_class: type[py_trees.trees.BehaviourTree], *, full: bool) -> list[str]:
    """What handlers and a visitor see over three ticks of a small tree built as ``tree_class``."""
    log: list[str] = []

    class Recorder(py_trees.visitors.VisitorBase):
        def __init__(self) -> None:
            super().__init__(full=full)

        def initialise(self) -> None:
            log.append("visitor initialise")

        def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
            log.append(f"visit {behaviour.name} {behaviour.status.name}")

        def finalise(self) -> None:
            log.append("visitor finalise")

    root = py_trees.composites.Selector(
        name="Root",
        memory=False,
        children=[
            py_trees.behaviours.Failure(name="Fails"),
            py_trees.behaviours.StatusQueue(
                name="Queue",
                queue=[py_trees.common.Status.RUNNING, py_trees.common.Status.SUCCESS],
                eventually=py_trees.common.Status.FAILURE,
            ),
            py_trees.behaviours.Success(name="NeverReached"),
        ],
    )
    tree = tree_class(root=root)
    tree.visitors.append(Recorder())
    tree.add_pre_tick_handler(lambda t: log.append(f"pre {t.count}"))
    tree.add_post_tick_handler(lambda t: log.append(f"post {t.count}"))
    for _ in range(3):
        tree.tick(
            pre_tick_handler=lambda t: log.append("pre once"),
            post_tick_handler=lambda t: log.append(f"post once {t.root.status.name}"),
        )
    log.append(f"count {tree.count}")
    print(py_trees.display.unicode_tree(tree.root, show_status=True))
    return log


@pytest.mark.parametrize("full", [False, True])
def test_mission_tree_ticks_exactly_as_py_trees_does(full: bool) -> None:
    """MissionTree skips py_trees' idle whole-tree walk; handlers, visitors, statuses and count are the same."""
    expected = _recorded_ticks(py_trees.trees.BehaviourTree, full=full)
    assert _recorded_ticks(MissionTree, full=full) == expected
    # Only the whole-tree walk visits a node that has not been ticked yet.
    assert ("visit NeverReached INVALID" in expected) == full
