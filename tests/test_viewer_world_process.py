"""The world process (``semexp_bt/app/viewer/world_process.py``): the view's Rerun logger in a child.

These run in the default suite, without Rerun: they check that the child's failures come back as clear
errors rather than hangs, and that the child never outlives the mission's process. That it logs a whole
mission to a recording Rerun reads back is tests/test_viewer_world.py (the ``viewer`` marker).
"""

from __future__ import annotations

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
        with pytest.raises(WorldProcessError, match="the world logger could not start") as raised:
            for tick in range(1, 100_000):  # the reply arrives after the child has tried
                world.log(WorldFrame(tick=tick, stamp_s=0.02 * tick))
                world.flush()
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
        with pytest.raises(WorldProcessError):
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
