"""End to end: `semexp-bt run --perception models` on MuJoCo against the scripted server (the rendered
frames go to the "models", whose answers are scripted from each request), and `semexp-bt perceive` on a
picture."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("openai")
pytest.importorskip("jsonschema")

from semexp_bt.app.pacing import WallClockPacer
from semexp_bt.cli import main
from sims.scripted_chat_server import ScriptedChatServer, ScriptedReply, scripted_models

ROOT = Path(__file__).resolve().parents[1]
TREES = ROOT / "trees"
SCRIPTED_LABELS = {"open corridor", "unexplored area on the left"}
#: One numbered label of a relevance prompt (`1. "open corridor"`).
NUMBERED_LABEL = re.compile(r'^\d+\. "([^"]*)"', re.MULTILINE)


@pytest.fixture()
def server() -> Iterator[ScriptedChatServer]:
    with ScriptedChatServer(scripted_models) as running:
        yield running


def short_mission(tmp_path: Path, budget_s: float) -> Path:
    document = yaml.safe_load((TREES / "object_search.yaml").read_text())
    document["mission"]["budget_s"] = budget_s
    (tmp_path / "subtrees").symlink_to(TREES / "subtrees")
    path = tmp_path / "mission.yaml"
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return path


def test_a_mujoco_mission_runs_on_the_models_against_the_scripted_server(
    server: ScriptedChatServer, tmp_path: Path
) -> None:
    profile = tmp_path / "profile.yaml"
    profile.write_text(
        f"vlm: {{base_url: '{server.url}', model: scripted-vlm, timeout_s: 10}}\n"
        f"llm: {{base_url: '{server.url}', model: scripted-llm, timeout_s: 10, cache_path: '{tmp_path / 'cache.sqlite3'}'}}\n"
        # At most 4 robot seconds per wall second: the views' HTTP round trips (tens of ms, more on a
        # loaded machine) stay far inside Perceive's 15 s time-out, and the test takes a quarter of the budget.
        "simulation: {real_time_factor: 4}\n"
    )
    out = tmp_path / "record.json"
    status = main(
        ["run", str(short_mission(tmp_path, budget_s=30.0)), "--scene", "road", "--seed", "0", "--perception",
         "models", "--relevance", "llm", "--models", str(profile), "--json", str(out)]
    )  # fmt: skip
    record = json.loads(out.read_text())
    print({k: record[k] for k in ("outcome", "sim_time_s", "wall_time_s", "ticks")}, record["events"][:5])
    assert status in (0, 1)  # ran to an outcome (no success is expected from scripted directions)
    assert not [e for e in record["events"] if e["kind"] == "perception_error"]

    scene_requests = [r for r in server.requests if r.image_data_url() is not None]
    relevance_requests = [r for r in server.requests if r.image_data_url() is None]
    assert len(scene_requests) >= 6  # the panoramic init's six views, at least
    assert {r.model for r in scene_requests} == {"scripted-vlm"}
    assert {r.model for r in relevance_requests} == {"scripted-llm"}
    assert all(r.image_data_url().startswith("data:image/png;base64,") for r in scene_requests)  # type: ignore[union-attr]

    # The VLM's proposals were scored by the LLM's relevance, and the robot decided. Whether a direction's
    # node survives to a decision's candidates depends on where the start puts it (it may merge into a
    # depth frontier's "unexplored area" node), so the test asks the relevance prompts, not the candidates.
    assert record["decisions"], "the robot should have decided where to go"
    asked = {label for r in relevance_requests for label in NUMBERED_LABEL.findall(r.text())}
    assert SCRIPTED_LABELS <= asked, asked

    # The record says what the models cost: calls, failures, latency, the relevance cache's counters.
    models = record["models"]
    assert models["calls"]["vlm"]["calls"] == len(scene_requests) and models["calls"]["vlm"]["failures"] == 0
    assert models["calls"]["vlm"]["latency_s"]["median"] > 0.0
    relevance = models["relevance"]
    assert relevance["asked"] == sum(len(NUMBERED_LABEL.findall(r.text())) for r in relevance_requests)
    assert relevance["lookups"] >= relevance["asked"] > 0 and relevance["fallbacks"] == 0


def test_the_pacer_holds_the_robot_clock_to_the_wall_clock() -> None:
    wall = [0.0]
    slept: list[float] = []

    class Run:
        robot_s = 10.0

        def now_s(self) -> float:
            return self.robot_s

    def sleep(seconds: float) -> None:
        slept.append(seconds)
        wall[0] += seconds

    pacer = WallClockPacer(clock=lambda: wall[0], sleep=sleep)
    run = Run()
    pacer.start(run)  # type: ignore[arg-type]
    run.robot_s, wall[0] = 10.02, 0.005  # a tick ran in 5 ms of wall time for 20 ms of robot time
    pacer.after_tick(run)  # type: ignore[arg-type]
    assert slept == [pytest.approx(0.015)]
    run.robot_s, wall[0] = 10.04, 0.5  # a slow tick: the simulation is behind, nothing to wait for
    pacer.after_tick(run)  # type: ignore[arg-type]
    assert len(slept) == 1 and pacer.slept_s == pytest.approx(0.015)
    fast = WallClockPacer(real_time_factor=4.0, clock=lambda: wall[0], sleep=sleep)
    fast.start(run)  # type: ignore[arg-type]
    run.robot_s, wall[0] = run.robot_s + 0.4, wall[0] + 0.05  # 0.4 robot s may take 0.1 wall s at 4x
    fast.after_tick(run)  # type: ignore[arg-type]
    assert slept[-1] == pytest.approx(0.05)


def write_picture(tmp_path: Path) -> tuple[Path, Path]:
    import cv2

    image = tmp_path / "photo.png"
    rgb = np.full((120, 160, 3), 90, np.uint8)
    rgb[40:80, 60:100] = (200, 30, 30)
    assert cv2.imwrite(str(image), rgb[:, :, ::-1])
    depth = tmp_path / "depth.npy"
    np.save(depth, np.full((120, 160), 2.5, np.float32))
    return image, depth


def test_perceive_prints_each_models_answer_the_proposals_and_the_target(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    image, depth = write_picture(tmp_path)
    reply = json.dumps(
        {"proposals": [{"kind": "object", "label": "red box", "point": [80, 60]},
                       {"kind": "direction", "label": "open corridor", "point": [150, 100]}],
         "scene_confidence": 0.9}
    )  # fmt: skip
    out = tmp_path / "perceive.json"
    with ScriptedChatServer([ScriptedReply(content=reply)]) as server:
        status = main(
            ["perceive", str(image), "--depth", str(depth), "--instruction", "find the red box", "--vlm-url",
             server.url, "--vlm-model", "qwen", "--relevance", "lexical", "--json", str(out)]
        )  # fmt: skip
        sent = server.requests[-1]
    printed = capsys.readouterr().out
    print(printed)
    assert status == 0
    assert "vlm qwen: ok" in printed and f"returned: {reply}" in printed
    assert "object    (80.0, 60.0)" in printed and "red box" in printed and "C_s 0.90" in printed
    assert "target: 'red box' at (80.0, 60.0)" in printed and "depth 2.50 m" in printed
    assert "errors: none" in printed
    report = json.loads(out.read_text())
    assert report["target"]["label"] == "red box" and report["scene"]["scene_confidence"] == 0.9
    assert sent.model == "qwen" and sent.image_data_url() is not None


def test_perceive_shows_a_model_error_and_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    image, _ = write_picture(tmp_path)
    with ScriptedChatServer([ScriptedReply(content="I see a red box in the middle.")]) as server:
        status = main(
            ["perceive", str(image), "--instruction", "find the red box", "--vlm-url", server.url, "--vlm-model",
             "qwen", "--relevance", "lexical"]
        )  # fmt: skip
    printed = capsys.readouterr().out
    print(printed)
    assert status == 1
    assert "vlm qwen: FAILED" in printed and "returned: I see a red box in the middle." in printed
    assert "proposals: none" in printed and "target: none" in printed
    assert "reply is not JSON" in printed


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--instruction", "find it"], "give a models profile"),
        (
            ["--instruction", "find it", "--vlm-url", "http://127.0.0.1:9/v1"],
            "--vlm-url and --vlm-model are both",
        ),
    ],
)
def test_perceive_bad_input_is_one_error_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], arguments: list[str], message: str
) -> None:
    image, _ = write_picture(tmp_path)
    assert main(["perceive", str(image), *arguments]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert main(["perceive", str(tmp_path / "none.png"), "--instruction", "x", "--vlm-url", "http://h/v1",
                 "--vlm-model", "m"]) == 2  # fmt: skip
    assert "no such image" in capsys.readouterr().err
