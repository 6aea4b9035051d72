"""The browser view without its heavy parts: what the tick thread records and captures, the bounded queue
that drops frames rather than ticks, the saved recording's format, the page's HTTP API, the map adapter
and the decision's explanation. These run in the default suite (no Rerun, no browser); the world read
back through Rerun and MCAP is tests/test_viewer_world.py, the page in Chromium tests/test_viewer_browser.py.

The missions here run on :class:`robots.null_robot.NullRobot` with scripted perception (as in
tests/test_executive.py): the fire extinguisher 2.5 m ahead, found in about 40 s of robot time.
"""

from __future__ import annotations

import json
import math
import threading
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
import pytest

from robots.go1 import go1_footprint
from robots.null_robot import NullRobot
from semexp_bt.app.recorder import TickRecorder
from semexp_bt.app.runner import MissionComponents, MissionResult, MissionRun, run_mission
from semexp_bt.app.viewer.frames import WorldFrame
from semexp_bt.app.viewer.maps import (
    FREE_CELL,
    INSCRIBED_CELL,
    OCCUPIED_CELL,
    UNKNOWN_CELL,
    map_layer,
    map_version,
    occupancy_values,
)
from semexp_bt.app.viewer.observer import ViewObserver, ViewOptions
from semexp_bt.app.viewer.recording import (
    MANIFEST_FILE,
    TICKS_FILE,
    RecordingError,
    open_recording,
)
from semexp_bt.app.viewer.tree_page import CONTENT_SECURITY_POLICY, TickFeed, ViewServer, rerun_assets_dir
from semexp_bt.app.viewer.world import explain_decision
from semexp_bt.cli import main
from semexp_bt.core.config import DecisionConfig, SemExpConfig
from semexp_bt.core.decision import decide
from semexp_bt.core.relevance import CachedRelevance, LexicalRelevance
from semexp_bt.core.types import NodeState, Pose2D
from semexp_bt.nav.costmap import Costmap, CostmapConfig
from semexp_bt.nav.global_planner import GlobalPlan
from semexp_bt.nav.pure_pursuit import RegulatedPurePursuit
from sims.scripted_perception import ScriptedPerception
from tests.test_executive import TREES, Post, seeing
from trees.loader import parse_mission

TARGET = Post(1, 2.5, 0.0, "fire extinguisher", "fire extinguisher")
INSTRUCTION = "find the fire extinguisher"


class ListSink:
    """A world sink that keeps the frames it is given; ``release`` gates ``log`` (a stalled browser)."""

    def __init__(self, *, stalled: bool = False) -> None:
        self.frames: list[WorldFrame] = []
        self.release = threading.Event()
        self.waited_out = False
        if not stalled:
            self.release.set()

    def log(self, frame: WorldFrame) -> None:
        if not self.release.wait(timeout=60.0):
            self.waited_out = True
        self.frames.append(frame)

    def flush(self) -> None:
        return

    def close(self) -> None:
        return

    def disconnect(self) -> None:
        return


class TruthObserver:
    """Walks the whole tree after every tick: every node's status, the ground truth for the record."""

    wants_activity_stream = False

    def __init__(self) -> None:
        self.statuses: list[dict[str, str]] = []

    def start(self, run: MissionRun) -> None:
        return

    def after_tick(self, run: MissionRun) -> None:
        self.statuses.append({node.name: node.status.name for node in run.tree.root.iterate()})

    def finish(self, run: MissionRun, outcome: str) -> None:
        return


class Releaser:
    """Releases a stalled sink when the mission has ended (listed before the view observer)."""

    wants_activity_stream = False

    def __init__(self, sink: ListSink) -> None:
        self.sink = sink
        self.released_at_tick: int | None = None

    def start(self, run: MissionRun) -> None:
        return

    def after_tick(self, run: MissionRun) -> None:
        return

    def finish(self, run: MissionRun, outcome: str) -> None:
        self.released_at_tick = run.tick
        self.sink.release.set()


def run_null_mission(observers: list[Any]) -> MissionResult:
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0), posts=((1, 2.5, 0.0, 0.2, 0.6),))
    components = MissionComponents(
        robot=robot,
        perception=ScriptedPerception([seeing([TARGET])], latency_s=2.5),
        relevance=CachedRelevance(LexicalRelevance()),
        planner=RegulatedPurePursuit(),
    )
    return run_mission(
        mission=parse_mission(TREES / "object_search.yaml"),
        components=components,
        config=SemExpConfig(),
        instructions=[INSTRUCTION],
        seed=0,
        max_time_s=120.0,
        observers=observers,
    )


def record_view(
    directory: Path, sink: ListSink, **option_overrides: Any
) -> tuple[MissionResult, ViewObserver]:
    recorder = TickRecorder(path=None, display=False)
    options = ViewOptions(record_dir=directory, **option_overrides)
    view = ViewObserver(options, recorder=recorder, sink_factory=lambda **_: sink)
    return run_null_mission([recorder, view]), view


def states_from_records(lines: list[str], names: list[str]) -> list[dict[str, str]]:
    """Every node's status after each tick, rebuilt from the records as the page does."""
    state = dict.fromkeys(names, "INVALID")
    out = []
    for line in lines:
        record = json.loads(line)
        state.update({name: node["status"] for name, node in record["nodes"].items()})
        state.update(record.get("stopped", {}))
        out.append(dict(state))
    return out


def test_the_record_holds_every_nodes_status_at_every_tick(tmp_path: Path) -> None:
    lines: list[str] = []
    recorder = TickRecorder(path=None, display=False, on_record=lambda tick, line: lines.append(line))
    truth = TruthObserver()
    result = run_null_mission([recorder, truth])
    assert result.outcome == "success"
    names = list(truth.statuses[0])
    rebuilt = states_from_records(lines, names)
    assert len(rebuilt) == len(truth.statuses) == result.ticks
    mismatches = [(i + 1, n) for i, (got, want) in enumerate(zip(rebuilt, truth.statuses, strict=True))
                  for n in names if got[n] != want[n]]  # fmt: skip
    assert mismatches == []
    # Without ``stopped`` the rebuilt tree would be wrong: preempted branches keep their old status.
    stopped = [json.loads(line).get("stopped", {}) for line in lines]
    assert any("INVALID" in s.values() for s in stopped)
    # The recorder puts each line together from cached pieces: it is exactly what json.dumps writes.
    assert all(json.dumps(json.loads(line)) == line for line in lines)


def test_a_saved_view_holds_every_tick_and_the_worlds_frames(tmp_path: Path) -> None:
    sink = ListSink()
    result, view = record_view(tmp_path / "view", sink, title="null robot: fire extinguisher")
    saved = open_recording(tmp_path / "view")
    print(json.dumps(saved.manifest, indent=1))
    assert saved.complete and saved.manifest["outcome"] == result.outcome == "success"
    assert saved.manifest["ticks"] == result.ticks == len(saved.tick_lines)
    assert [json.loads(line)["tick"] for line in saved.tick_lines] == list(range(1, result.ticks + 1))
    tree_names = {n["name"] for n in saved.tree["nodes"]}
    assert {"Mission", "Search", "Perceive", "Decide", "FollowPath", "ConfirmTarget"} <= tree_names
    assert saved.manifest["frames"] == {"queued": len(sink.frames), "logged": len(sink.frames), "dropped": 0}
    ticks = [f.tick for f in sink.frames]
    assert ticks == sorted(ticks) and ticks[0] == 0 and ticks[-1] == result.ticks
    assert sink.frames[0].memory is not None and sink.frames[-1].outcome == "success"
    # The pose reaches the view at 10 Hz of robot time: every 5th tick of 20 ms.
    posed = [f.tick for f in sink.frames if f.pose is not None][1:-1]
    assert set(np.diff(posed)) == {5}
    # A frame carries a perceived view for every write of `observation`, a model answer for every write
    # of `scene_evidence`, a decision for every decision-log entry.
    writes = [json.loads(line)["writes"] for line in saved.tick_lines]
    observed = sum(1 for w in writes for item in w if item["key"] == "/observation")
    answered = sum(1 for w in writes for item in w if item["key"] == "/scene_evidence")
    assert sum(f.observation is not None for f in sink.frames) == observed > 0
    assert sum(f.answer is not None for f in sink.frames) == answered > 0
    decisions = [f.decision for f in sink.frames if f.decision is not None]
    assert decisions == result.services.decision_log
    assert any(f.map is not None for f in sink.frames)
    assert any(f.memory is not None and len(f.memory.nodes) > 1 for f in sink.frames)


def test_a_stalled_world_sink_costs_frames_never_ticks(tmp_path: Path) -> None:
    plain = run_null_mission([])
    sink = ListSink(stalled=True)
    recorder = TickRecorder(path=None, display=False)
    view = ViewObserver(ViewOptions(record_dir=tmp_path / "view", queue_frames=8), recorder=recorder,
                        sink_factory=lambda **_: sink)  # fmt: skip
    releaser = Releaser(sink)
    watched = run_null_mission([recorder, releaser, view])
    # The whole mission ran while the sink was stalled (it was released only at the end) ...
    assert releaser.released_at_tick == watched.ticks and not sink.waited_out
    # ... and it is the same mission: the view changes nothing the tree reads.
    assert (watched.outcome, watched.ticks) == (plain.outcome, plain.ticks)
    np.testing.assert_array_equal(np.array(watched.positions), np.array(plain.positions))
    # The queue held 8 frames (and the worker one more); the rest were dropped and counted.
    assert view.frames_dropped > 0
    assert view.frames_logged == len(sink.frames) == view.frames_queued - view.frames_dropped
    assert len(sink.frames) <= 8 + 2 and sink.frames[-1].outcome == "success"
    assert open_recording(tmp_path / "view").manifest["frames"]["dropped"] == view.frames_dropped


def test_a_broken_recording_is_named_by_file_and_line(tmp_path: Path) -> None:
    record_view(tmp_path / "view", ListSink())
    directory = tmp_path / "view"
    ticks = directory / TICKS_FILE
    lines = ticks.read_text().splitlines()
    ticks.write_text("\n".join([lines[0], lines[1], "{not json", *lines[3:]]) + "\n")
    with pytest.raises(RecordingError, match=rf"{TICKS_FILE}:3: not a JSON tick record"):
        open_recording(directory)
    ticks.write_text("\n".join([lines[1], lines[0]]) + "\n")
    with pytest.raises(RecordingError, match=rf"{TICKS_FILE}:2: .*increasing integer 'tick'"):
        open_recording(directory)
    # A recording cut short mid-line (the process died) still opens, without the partial line.
    manifest = json.loads((directory / MANIFEST_FILE).read_text())
    (directory / MANIFEST_FILE).write_text(json.dumps({**manifest, "status": "recording"}))
    ticks.write_text("\n".join(lines[:5]) + "\n" + lines[5][:20])
    cut = open_recording(directory)
    assert not cut.complete and len(cut.tick_lines) == 5
    (directory / MANIFEST_FILE).write_text(json.dumps({**manifest, "version": 99}))
    with pytest.raises(RecordingError, match=rf"{MANIFEST_FILE}: version 99 is not readable"):
        open_recording(directory)
    (directory / MANIFEST_FILE).unlink()
    with pytest.raises(RecordingError, match=rf"{MANIFEST_FILE}: missing"):
        open_recording(directory)


def test_view_and_export_commands_report_a_bad_directory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["view", str(tmp_path / "nothing"), "--no-browser"]) == 2
    assert "nothing: not a directory" in capsys.readouterr().err
    assert main(["export", str(tmp_path), "--mcap", str(tmp_path / "out.mcap")]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / MANIFEST_FILE}: missing" in err and "Traceback" not in err


def _get(url: str) -> tuple[int, dict[str, str], bytes]:
    try:
        with urllib.request.urlopen(url, timeout=10) as answer:
            return answer.status, dict(answer.headers), answer.read()
    except urllib.error.HTTPError as error:
        return error.code, dict(error.headers), error.read()


def test_the_page_server_answers_the_session_and_the_ticks_after_one() -> None:
    lines = [json.dumps({"tick": t, "stamp_s": 0.02 * t, "nodes": {}, "writes": []}) for t in range(1, 8)]
    feed = TickFeed(
        {"mode": "live", "title": "t", "tree": {"root": "R", "nodes": []}, "world": None}, lines[:5]
    )
    server = ViewServer(feed)
    try:
        status, headers, body = _get(server.url)
        assert status == 200 and b"viewer.js" in body
        assert (
            headers["Content-Security-Policy"] == CONTENT_SECURITY_POLICY
            and "connect-src 'self'" in CONTENT_SECURITY_POLICY
        )
        assert _get(server.url + "static/viewer.js")[0] == 200
        assert _get(server.url + "static/..%2F..%2Fobserver.py")[0] == 404
        session = json.loads(_get(server.url + "api/session")[2])
        assert session["mode"] == "live" and session["ticks"] == 5 and session["done"] is False
        answer = json.loads(_get(server.url + "api/ticks?after=2&limit=2")[2])
        assert [r["tick"] for r in answer["ticks"]] == [3, 4] and answer["done"] is False
        for line in lines[5:]:
            feed.append(json.loads(line)["tick"], line)
        feed.finish(outcome="success")
        answer = json.loads(_get(server.url + "api/ticks?after=4")[2])
        assert [r["tick"] for r in answer["ticks"]] == [5, 6, 7] and answer["done"] is True
        assert json.loads(_get(server.url + "api/session")[2])["outcome"] == "success"
        assert _get(server.url + "api/ticks?after=x")[0] == 400
        widget = _get(server.url + "rerun/widget.js")[0]
        assert widget == (200 if rerun_assets_dir() is not None else 404)
    finally:
        server.close()


def test_the_map_layer_is_the_costmap_in_ros_order_from_its_corner_with_the_path() -> None:
    costmap = Costmap(CostmapConfig(), footprint=go1_footprint(), origin_xy=(0.0, 0.0))
    assert map_layer({"/local_map": costmap}) is None  # nothing observed yet
    lethal = np.zeros((40, 60), dtype=bool)  # 2 m (y) x 3 m (x) at 5 cm
    lethal[10, 50] = True  # one obstacle cell, 1 m to the right of the path's end
    costmap.set_known(lethal, lower_left_xy=(1.0, 2.0), resolution_m=0.05)
    plan = GlobalPlan("ok", np.array([[1.2, 2.5], [2.0, 2.5], [2.9, 2.5]]), (3.0, 2.5), 1.7, costmap.revision)
    layer = map_layer({"/local_map": costmap, "/global_plan": plan})
    assert layer is not None
    print(layer.cells[::5, ::5])
    rows, cols = np.nonzero(layer.cells == OCCUPIED_CELL)
    assert (rows.tolist(), cols.tolist()) == ([10], [50])
    # Row is y and column is x, counted from the corner of cell (0, 0).
    centre = np.array(layer.origin_xy) + (np.array([cols[0], rows[0]]) + 0.5) * layer.resolution_m
    np.testing.assert_allclose(centre, (1.0 + 50.5 * 0.05, 2.0 + 10.5 * 0.05), atol=1e-9)
    # The inflation gradient: inscribed next to the obstacle, then falling with the distance (to the cost
    # at the inflation radius, where the distance field stops).
    assert layer.cells[10, 48] == INSCRIBED_CELL
    along = layer.cells[10, 20:45].astype(int)
    assert (np.diff(along) >= 0).all() and FREE_CELL < along[0] < along[-1] < INSCRIBED_CELL
    assert UNKNOWN_CELL not in layer.cells
    np.testing.assert_array_equal(layer.path_xy, plan.path_xy)
    moved = GlobalPlan("ok", plan.path_xy[::-1], (1.2, 2.5), 1.7, costmap.revision, stamp_s=1.0)
    assert map_version({"/local_map": costmap, "/global_plan": moved}) != layer.version


def test_the_map_cells_translate_nav2_costs_as_nav2s_costmap_publisher() -> None:
    costs = np.arange(256, dtype=np.uint8)
    cells = occupancy_values(costs.reshape(16, 16)).ravel().astype(int)
    assert (cells[0], cells[253], cells[254], cells[255]) == (
        FREE_CELL,
        INSCRIBED_CELL,
        OCCUPIED_CELL,
        UNKNOWN_CELL,
    )
    # The inflation costs 1-252 spread over 1-98 as costmap_2d_publisher's 1 + 97 (cost - 1) / 251.
    assert cells[1:253].tolist() == [1 + (97 * (cost - 1)) // 251 for cost in range(1, 253)]
    assert cells[252] == 98


def test_the_explanation_gives_eq9s_terms_and_their_product_is_the_utility() -> None:
    config = DecisionConfig(alpha=1.0, beta=0.5, eta=1.0, gamma=0.15)
    nodes = [
        NodeState(1, (2.0, 0.0, 0.0), "fire extinguisher", 0.8, 0.9),
        NodeState(2, (0.0, 3.0, 0.0), "open corridor", 0.6, 0.6),
        NodeState(3, (-4.0, 0.0, 0.0), "chair", 0.9, 0.5),
    ]
    costs = {1: 2.0, 2: 3.0, 3: 4.0}
    result = decide(nodes=nodes, instruction=INSTRUCTION, relevance=LexicalRelevance(), travel_costs=costs,
                    config=config)  # fmt: skip
    entry = {
        "stamp_s": 12.0,
        "selected_node_id": result.subgoal.node_id if result.subgoal else None,
        "reason": result.reason,
        "candidates": [c._asdict() for c in result.candidates],
    }
    text = explain_decision(entry, config)
    print(text)
    rows = [
        line.split("|")[1:-1] for line in text.splitlines() if line.startswith("| ") and "node" not in line
    ]
    assert rows[0][0].strip() == "**★**" and int(rows[0][1]) == entry["selected_node_id"] == 1
    for row in rows:
        s_a, c_b, p_e, decay, u = (float(v) for v in row[7:12])
        assert math.isclose(s_a * c_b * p_e * decay, u, rel_tol=0.01, abs_tol=2e-4)
    assert [float(r[11]) for r in rows] == sorted((float(r[11]) for r in rows), reverse=True)


def test_py_trees_kinds_are_named_for_the_page() -> None:
    from semexp_bt.app.viewer.tree_page import tree_structure

    root = py_trees.composites.Sequence("S", memory=True, children=[
        py_trees.decorators.Inverter("I", child=py_trees.behaviours.Success("A")),
        py_trees.composites.Selector("O", memory=False, children=[py_trees.behaviours.Failure("B")]),
        py_trees.composites.Parallel("P", policy=py_trees.common.ParallelPolicy.SuccessOnAll()),
    ])  # fmt: skip
    structure = tree_structure(root)
    kinds = {n["name"]: (n["kind"], n["parent"], n["depth"]) for n in structure["nodes"]}
    assert kinds == {
        "S": ("sequence", None, 0), "I": ("decorator", "S", 1), "A": ("behaviour", "I", 2),
        "O": ("selector", "S", 1), "B": ("behaviour", "O", 2), "P": ("parallel", "S", 1),
    }  # fmt: skip
