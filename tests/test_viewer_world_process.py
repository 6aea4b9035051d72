"""The world process (``semexp_bt/app/viewer/world_process.py``): the view's Rerun logger in a child.

These run in the default suite, without Rerun: they check that the child's failures come back as clear
errors rather than hangs, and that the child never outlives the mission's process. That it logs a whole
mission to a recording Rerun reads back is tests/test_viewer_world.py (the ``viewer`` marker).
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from semexp_bt.app.viewer.frames import WorldFrame
from semexp_bt.app.viewer.world_process import WorldProcess, WorldProcessError
from semexp_bt.core.config import DecisionConfig

#: Generous wall-time bound for the child to start or end (s); a hang fails the test instead.
CHILD_WAIT_S = 60.0


def test_a_logger_that_cannot_start_is_reported_on_the_next_frame(tmp_path: Path) -> None:
    world = WorldProcess.spawn()
    try:
        # No file and no stream: the child's WorldLogger refuses (or, without the viewer extra, Rerun's
        # import fails first); either way the parent hears of it.
        world.open(
            recording_id="r",
            decision_config=DecisionConfig(),
            file_path=None,
            grpc_port=None,
            cors_origin=None,
        )
        deadline = time.monotonic() + CHILD_WAIT_S
        with pytest.raises(WorldProcessError, match="the world logger could not start") as raised:
            tick = 0
            while time.monotonic() < deadline:  # the answer arrives once the child has tried
                tick += 1
                world.log(WorldFrame(tick=tick, stamp_s=0.02 * tick))
                world.flush()
                time.sleep(0.01)
        print(raised.value)
        with pytest.raises(WorldProcessError):
            world.close()
    finally:
        world.disconnect()
    assert world._process.poll() is not None


def test_the_child_ends_when_the_missions_end_of_the_pipe_closes() -> None:
    world = WorldProcess.spawn()
    world._conn.close()  # as when the mission's process is killed
    exit_code = world._process.wait(timeout=CHILD_WAIT_S)
    print("exit code", exit_code)
    assert exit_code == 0


def test_a_live_stream_that_cannot_open_raises_at_open() -> None:
    world = WorldProcess.spawn()
    try:
        with pytest.raises(WorldProcessError, match="could not start"):
            # An out-of-range port: the gRPC server cannot bind (or Rerun is missing); open waits for the
            # answer and raises, so the page never announces a stream that does not exist.
            world.open(
                recording_id="r",
                decision_config=DecisionConfig(),
                file_path=None,
                grpc_port=70_000,
                cors_origin=None,
            )
    finally:
        world.disconnect()
    assert world._process.poll() is not None


@pytest.mark.viewer
def test_a_view_that_never_started_ends_its_world_process_on_close(tmp_path: Path) -> None:
    from semexp_bt.app.recorder import TickRecorder
    from semexp_bt.app.viewer.observer import ViewObserver, ViewOptions

    view = ViewObserver(
        ViewOptions(record_dir=tmp_path / "view"), recorder=TickRecorder(path=None, display=False)
    )
    child = view._world_process
    assert child is not None  # a saved view's world goes to a child process
    view.close()  # the mission failed before start: nothing else would end the child
    exit_code = child._process.wait(timeout=CHILD_WAIT_S)
    print("exit code", exit_code)
    assert exit_code == 0
