"""The view in a real browser: Debian's Chromium, headless, driven by Playwright (no browser download).

The replay test loads a saved MuJoCo mission, reads the tree off the page at chosen ticks and compares
every node's status with the tick records, scrubs, and checks that Rerun's world view followed (its own
time events come back to the page) and that moving Rerun's time moves the tree. The live test watches a
running mission through the gRPC stream. Neither lets the page reach anything but this machine. A
screenshot of each is kept in ``runs/test-artifacts/``.

Needs Chromium (``apt-get install chromium``), the viewer and viewer-test extras: ``make viewer-test``
(marker ``browser``).
"""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from semexp_bt.app.recorder import TickRecorder
from semexp_bt.app.viewer.observer import ViewObserver, ViewOptions
from semexp_bt.app.viewer.replay import serve_recording
from tests.test_viewer_observer import run_null_mission, states_from_records
from tests.test_viewer_world import record_mujoco_view
from tests.viewer_support import ARTIFACTS, RERUN_START_S, page_statuses, require_chromium, wait_for

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def saved_view(tmp_path_factory: pytest.TempPathFactory) -> Path:
    require_chromium()  # before the recording, which takes a while
    directory = tmp_path_factory.mktemp("browser") / "road-0"
    record_mujoco_view(directory)
    return directory


def first_tick(lines: list[str], name: str, status: str) -> int:
    for line in lines:
        record = json.loads(line)
        if record["nodes"].get(name, {}).get("status") == status:
            return int(record["tick"])
    raise AssertionError(f"{name} never {status}")


def test_replay_shows_the_tree_at_each_tick_and_rerun_moves_with_it(
    saved_view: Path, browser_context: tuple[Any, list[str]]
) -> None:
    context, outside = browser_context
    server, recording = serve_recording(saved_view)
    try:
        page = context.new_page()
        page.goto(server.url)
        wait_for(page, "window.semexpView && window.semexpView.done", 30.0)
        lines = recording.tick_lines
        names = [n["name"] for n in recording.tree["nodes"]]
        truth = states_from_records(lines, names)
        assert page.evaluate("window.semexpView.ticks") == len(lines)
        assert set(page_statuses(page)) == set(names)

        decided = first_tick(lines, "Decide", "SUCCESS")
        page.evaluate(f"window.semexpView.seek({decided})")
        shown = page_statuses(page)
        print(f"tick {decided}:", shown)
        assert shown == truth[decided - 1] and shown["Decide"] == "SUCCESS"
        assert page.locator('.node[data-name="Decide"] > .row .feedback').inner_text().startswith("node ")

        # Scrub back with the slider itself, to a tick of the panoramic scan: the tree changes with it.
        thinking = first_tick(lines, "PanoPerceive", "RUNNING") + 5
        page.locator("#scrub").fill(str(thinking - 1))
        scrubbed = page_statuses(page)
        assert scrubbed == truth[thinking - 1] and scrubbed != shown
        assert scrubbed["PanoPerceive"] == "RUNNING" and scrubbed["Decide"] == "INVALID"
        assert page.evaluate("window.semexpView.shownTick") == thinking

        # Rerun's world view follows the scrub: its own time event comes back with the tick ...
        wait_for(page, "window.semexpView.rerun.ready", RERUN_START_S)
        page.locator("#scrub").fill(str(decided - 1))
        wait_for(page, f"window.semexpView.rerun.time === {decided}", 30.0)
        # ... and moving Rerun's time moves the tree.
        page.evaluate(f"window.semexpView.seekWorld({thinking})")
        wait_for(page, f"window.semexpView.shownTick === {thinking}", 30.0)
        assert page_statuses(page) == truth[thinking - 1]
        page.evaluate(f"window.semexpView.seek({decided})")
        wait_for(page, f"window.semexpView.rerun.time === {decided}", 30.0)
        time.sleep(2.0)  # let the software rasteriser draw the frame for the screenshot
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "viewer-replay.png"))
        assert outside == [], f"the page tried to reach {outside}"
    finally:
        server.close()


def test_the_live_view_follows_a_running_mission(browser_context: tuple[Any, list[str]]) -> None:
    context, outside = browser_context
    urls: list[str] = []
    ended = threading.Event()
    checked = threading.Event()
    seen: dict[str, Any] = {}

    def hold_open(view: ViewObserver, outcome: str) -> None:
        seen["outcome"] = outcome
        ended.set()
        checked.wait(timeout=RERUN_START_S + 60.0)

    recorder = TickRecorder(path=None, display=False)
    view = ViewObserver(
        ViewOptions(live=True, announce=urls.append, after_mission=hold_open), recorder=recorder
    )
    mission = threading.Thread(target=lambda: seen.update(result=run_null_mission([recorder, view])))
    mission.start()
    try:
        while not urls and mission.is_alive():
            time.sleep(0.05)
        page = context.new_page()
        page.goto(urls[0])
        early = wait_for(page, "window.semexpView.ticks > 0 && window.semexpView.ticks", 30.0)
        assert ended.wait(timeout=120.0)
        done = wait_for(page, "window.semexpView.done && window.semexpView.ticks", 30.0)
        result = seen["result"] if "result" in seen else None
        assert done >= early and page.inner_text("#outcome") == f"outcome: {seen['outcome']}"
        assert page.evaluate("window.semexpView.shownTick") == done  # following the mission to its end
        # Rerun receives the live stream over gRPC from the mission's process.
        wait_for(page, "window.semexpView.rerun.ready && window.semexpView.rerun.time > 100", RERUN_START_S)
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "viewer-live.png"))
        assert outside == [], f"the page tried to reach {outside}"
        assert result is None or done == result.ticks
    finally:
        checked.set()
        mission.join(timeout=60.0)
    assert seen["result"].ticks == done
