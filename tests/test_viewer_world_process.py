"""The world process (``semexp_bt/app/viewer/world_process.py``): the view's Rerun logger in a child.

These run in the default suite, without Rerun: they check that the child's failures come back as clear
errors rather than hangs, that a child that pauses costs the sender no wait (up to the outbox's bound),
and that the child never outlives the mission's process. That it logs a whole
mission to a recording Rerun reads back is tests/test_viewer_world.py (the ``viewer`` marker).
"""

from __future__ import annotations

import pickle
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from semexp_bt.app.viewer import world_process
from semexp_bt.app.viewer.frames import MapLayer, WorldFrame
from semexp_bt.app.viewer.world_process import WorldProcess, WorldProcessError
from semexp_bt.core.config import DecisionConfig
from semexp_bt.core.evidence.result import ArbitrationResult
from semexp_bt.core.types import Pose2D, Twist
from semexp_bt.nav.control_result import ControlResult

#: Generous wall-time bound for the child to start or end (s); a hang fails the test instead.
CHILD_WAIT_S = 60.0


def _open(world: WorldProcess, *, file_path: Path | None = None, grpc_port: int | None = None) -> None:
    """Open ``world``'s logger as the observer does, for a file, a live stream, or (neither) a refusal."""
    world.open(
        recording_id="r",
        decision_config=DecisionConfig(),
        file_path=file_path,
        grpc_port=grpc_port,
        cors_origin=None,
    )


def test_a_logger_that_cannot_start_is_reported_on_the_next_frame(tmp_path: Path) -> None:
    world = WorldProcess.spawn()
    try:
        # No file and no stream: the child's WorldLogger refuses (or, without the viewer extra, Rerun's
        # import fails first); either way the parent hears of it.
        _open(world)
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
            _open(world, grpc_port=70_000)
    finally:
        world.disconnect()
    assert world._process.poll() is not None


@pytest.mark.viewer
def test_the_live_stream_is_served_from_the_child_once_open_returns() -> None:
    world = WorldProcess.spawn()
    try:
        _open(world, grpc_port=0)
        url = str(world.grpc_url)
        print("stream", url)
        assert url.startswith("rerun+http://127.0.0.1:")
        port = int(url.split(":")[2].split("/")[0])
        with socket.create_connection(("127.0.0.1", port), timeout=5.0):
            pass  # the child's gRPC server takes connections as soon as open has returned
        world.log(WorldFrame(tick=1, stamp_s=0.02, pose=Pose2D(0.0, 0.0, 0.0)))
        world.close()
    finally:
        world.disconnect()
    assert world._process.poll() is not None


def test_a_world_frame_unpickles_without_the_navigation_stack_or_the_tree() -> None:
    # The world process unpickles every frame beside the mission, on the other core: a frame whose types
    # pulled in the costmap (scipy), the planners or the tree's registry cost it 0.9 s of CPU there.
    frame = WorldFrame(
        tick=7,
        stamp_s=0.14,
        pose=Pose2D(1.0, 2.0, 0.5),
        command=Twist(0.3, 0.0, 0.1),
        arbitration=ArbitrationResult(target=None, candidates=(), reason="nothing aligned"),
        plan=ControlResult(Twist(0.3, 0.0, 0.1), "tracking", 0.4, np.zeros((5, 3))),
        map=MapLayer(cells=np.zeros((4, 6), np.int8), origin_xy=(0.0, 0.0), resolution_m=0.05, version=3),
    )
    heavy = (
        "scipy",
        "networkx",
        "py_trees",
        "trees.registry",
        "semexp_bt.nav.costmap",
        "semexp_bt.nav.controller",
    )
    child = subprocess.run(
        [
            sys.executable,
            "-c",
            "import pickle, sys; import semexp_bt.app.viewer.world_process, semexp_bt.app.viewer.world; "
            "frame = pickle.loads(sys.stdin.buffer.read()); "
            f"print(frame.tick, frame.plan.status, sorted(m for m in {heavy!r} if m in sys.modules))",
        ],
        input=pickle.dumps(frame),
        capture_output=True,
        timeout=CHILD_WAIT_S,
        check=True,
    )
    print(child.stdout.decode(), child.stderr.decode())
    assert child.stdout.decode().split() == ["7", "tracking", "[]"]


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


def _frames_of(size_bytes: int, count: int, first_tick: int = 1) -> list[WorldFrame]:
    """``count`` frames that pickle to about ``size_bytes`` each (an event carries the padding: one string
    per frame, since pickle writes a string it has seen in the same message once)."""
    return [
        WorldFrame(tick=tick, stamp_s=0.02 * tick, events=({"padding": f"{tick:x}".rjust(size_bytes, "x")},))
        for tick in range(first_tick, first_tick + count)
    ]


def test_a_paused_child_costs_the_sender_no_wait(tmp_path: Path) -> None:
    world = WorldProcess.spawn()
    try:
        world._process.send_signal(signal.SIGSTOP)  # a child that reads nothing for a while
        # 8 MB in batches of 1 MB: forty times what a socket holds, so a send to the socket would block.
        done = threading.Event()

        def send_batches() -> None:
            for batch in range(8):
                for frame in _frames_of(100_000, 10, first_tick=10 * batch + 1):
                    world.log(frame)
                world.flush()
            done.set()

        sender = threading.Thread(target=send_batches)
        sender.start()
        finished_while_paused = done.wait(timeout=CHILD_WAIT_S)
        print("outbox after the batches:", len(world._outbox), "messages,", world._outbox_bytes, "bytes")
        assert finished_while_paused and world._process.poll() is None
        assert world._outbox_bytes > 4_000_000  # the batches wait in the outbox, not in the caller
        world._process.send_signal(signal.SIGCONT)
        sender.join()
    finally:
        world._process.send_signal(signal.SIGCONT)
        world.disconnect()
    assert world._process.poll() is not None


def test_a_child_that_never_resumes_is_given_up_once_the_outbox_is_full(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(world_process, "BACKLOG_BYTES", 2_000_000)
    monkeypatch.setattr(world_process, "SEND_TIMEOUT_S", 1.0)
    world = WorldProcess.spawn()
    try:
        world._process.send_signal(signal.SIGSTOP)
        with pytest.raises(WorldProcessError, match="took no message for 1 s") as raised:
            for batch in range(100):  # 100 MB, fifty times the outbox: the limit is met long before
                for frame in _frames_of(100_000, 10, first_tick=10 * batch + 1):
                    world.log(frame)
                world.flush()
        print(raised.value)
        assert world._process.wait(timeout=CHILD_WAIT_S) != 0  # killed
        with pytest.raises(WorldProcessError):
            world.flush()
    finally:
        world.disconnect()


@pytest.mark.viewer
def test_frames_sent_while_the_child_was_paused_all_reach_the_recording(tmp_path: Path) -> None:
    from tests.viewer_support import timed_rows

    world = WorldProcess.spawn()
    world_file = tmp_path / "world.rrd"
    try:
        _open(world, file_path=world_file)
        world._process.send_signal(signal.SIGSTOP)
        ticks = range(1, 3001)  # about 1 MB pickled: five times what the socket holds
        for tick in ticks:
            world.log(
                WorldFrame(
                    tick=tick,
                    stamp_s=0.02 * tick,
                    pose=Pose2D(0.01 * tick, 0.0, 0.0),
                    base_twist=Twist(linear_x_mps=0.5),
                    command=Twist(linear_x_mps=0.5),
                )
            )
            if tick % 100 == 0:
                world.flush()
        print("outbox while paused:", world._outbox_bytes, "bytes")
        assert world._outbox_bytes > 0 and world._process.poll() is None
        world._process.send_signal(signal.SIGCONT)
        world.close()
    finally:
        world._process.send_signal(signal.SIGCONT)
        world.disconnect()
    logged = timed_rows(world_file)
    print({entity: len(rows) for entity, rows in logged.items()})
    assert logged["robot/base_twist"] == list(ticks)
