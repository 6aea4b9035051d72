"""The view as a :class:`~semexp_bt.app.runner.TickObserver`: live, saved, or both, never in the way.

:class:`ViewObserver` watches a running mission with the tick recorder it is given
(:class:`~semexp_bt.app.recorder.TickRecorder`: statuses, per-node time, feedback, blackboard writes).
On the tick thread it does only cheap things: it hands each tick's record to the page's feed and the
saved recording, and it puts the tick's :class:`~semexp_bt.app.viewer.frames.WorldFrame` (if the tick
changed anything worth drawing) into a bounded queue. A worker thread takes the frames from the queue
and hands them in batches to the view's world process (``world_process.py``: Rerun's logger, file sink
and gRPC server, in a child interpreter on the other core), and writes the saved recording's tick
records. When the queue is full the frame is dropped and counted, and the tick goes on:
a slow browser, a slow disk or a busy core cost the view frames, never the tree ticks. The tick
records themselves are small and are never dropped.

With ``record_dir`` the view is saved (``semexp_bt.app.viewer.recording``); with ``live`` it is served
(``semexp_bt.app.viewer.tree_page``, the world through Rerun's gRPC server). The mission itself is
unchanged by either: the observer reads the board and the robot, and writes nothing the tree reads.

Example:
    >>> recorder = TickRecorder(path=None, display=False)  # doctest: +SKIP
    >>> view = ViewObserver(ViewOptions(record_dir=Path("runs/view")), recorder=recorder)  # doctest: +SKIP
    >>> run_mission(..., observers=[recorder, view])  # doctest: +SKIP
"""

from __future__ import annotations

import queue
import sys
import threading
import time
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from semexp_bt.app.recorder import TickRecorder
from semexp_bt.app.viewer.capture import FrameCapture
from semexp_bt.app.viewer.frames import WorldFrame
from semexp_bt.app.viewer.recording import RecordingWriter
from semexp_bt.app.viewer.tree_page import TickFeed, ViewServer, tree_structure, world_view_available
from semexp_bt.app.viewer.world_process import WorldProcess

if TYPE_CHECKING:
    from semexp_bt.app.runner import MissionRun

#: World frames buffered between the tick thread and the worker before frames are dropped. A mission
#: makes about 15 frames per simulated second; 512 is half a minute of a worker that stopped.
QUEUE_FRAMES = 512
#: How long ``finish`` waits for the worker to log what is queued (wall seconds).
DRAIN_TIMEOUT_S = 120.0
#: Once woken by a frame, the worker lets frames gather this long (wall seconds) and then logs all that
#: are queued as one batch: the pose-rate streams go as columns, and the worker takes the interpreter
#: lock a few times a batch rather than a few times a frame (on two cores every take waits for the tick
#: thread). The live view runs up to this much behind the mission.
BATCH_GATHER_S = 0.25


class ViewerUnavailableError(RuntimeError):
    """The view was asked for, but the ``viewer`` extra (Rerun) is not installed."""


class FrameSink(Protocol):
    """Where the worker thread sends frames (:class:`~semexp_bt.app.viewer.world.WorldLogger`): ``log``
    for each frame of a batch, then ``flush`` once."""

    def log(self, frame: WorldFrame) -> None: ...

    def flush(self) -> None: ...

    def close(self) -> None: ...

    def disconnect(self) -> None: ...


@dataclass(frozen=True)
class ViewOptions:
    """What to do with the view of a mission.

    Attributes:
        live: serve the live view (the tree page and Rerun's gRPC stream) on the loopback interface.
        record_dir: save the view here (``semexp-bt view DIR`` replays it), or None.
        world: log the world through Rerun (needs the ``viewer`` extra); without it the view is the tree.
        host: the interface the page is served on.
        port: the page's port (0: a free one).
        grpc_port: the Rerun stream's port in live mode (0: a free one).
        open_browser: open the live page in the user's browser.
        queue_frames: world frames buffered before frames are dropped.
        title: a line that names the mission (scene, seed, instruction).
        mission: what the manifest records about the mission (scene, seed, strategy, ...).
        announce: called with the page's URL once it is served (the CLI prints it).
        after_mission: live only: called with the observer and the outcome when the mission has ended,
            before the page and the stream close (the CLI keeps them open there until Ctrl-C).
        world_process: a world process the caller spawned early (:meth:`WorldProcess.spawn`), for one
            mission: its interpreter start and Rerun's import then overlap the caller's own start-up
            rather than the mission's set-up (the CLI spawns it before it imports the mission stack).
            None: the observer spawns one when it is made.
    """

    live: bool = False
    record_dir: Path | None = None
    world: bool = True
    host: str = "127.0.0.1"
    port: int = 0
    grpc_port: int = 0
    open_browser: bool = False
    queue_frames: int = QUEUE_FRAMES
    title: str = ""
    mission: Mapping[str, Any] = field(default_factory=dict)
    announce: Callable[[str], None] | None = None
    after_mission: Callable[[ViewObserver, str], None] | None = None
    world_process: WorldProcess | None = None


def require_world_view() -> None:
    """Raise :class:`ViewerUnavailableError` unless Rerun and its web viewer are installed."""
    if not world_view_available():
        raise ViewerUnavailableError(
            "the world view needs the viewer extra (Rerun and its web viewer): pip install -e '.[viewer]'"
        )


class ViewObserver:
    """A :class:`~semexp_bt.app.runner.TickObserver` that serves and/or saves the mission's view.

    Args:
        options: live, saved, or both (see :class:`ViewOptions`).
        recorder: the mission's tick recorder; the view takes its records (it must be an observer of the
            same mission, listed before this one).
        sink_factory: builds the world's frame sink from ``(recording_id, run, world_file, grpc_port,
            cors_origin)``; the default logs to Rerun. Tests pass a slow one.

    Raises:
        ValueError: when neither ``live`` nor ``record_dir`` is asked for.
        ViewerUnavailableError: when the world view is asked for without the ``viewer`` extra.
    """

    wants_activity_stream = True

    def __init__(
        self,
        options: ViewOptions,
        *,
        recorder: TickRecorder,
        sink_factory: Callable[..., FrameSink] | None = None,
    ) -> None:
        if not options.live and options.record_dir is None:
            raise ValueError("a view needs live=True, a record_dir, or both")
        if options.world and sink_factory is None:
            require_world_view()
        self.options = options
        self.recorder = recorder
        self.sink_factory = sink_factory or self._default_sink
        recorder.listen(self._on_tick_record)
        self.recording_id = uuid.uuid4().hex
        self.writer = RecordingWriter(options.record_dir) if options.record_dir is not None else None
        self.feed: TickFeed | None = None
        self.server: ViewServer | None = None
        self.sink: FrameSink | None = None
        self.capture: FrameCapture | None = None
        self.frames_queued = 0
        self.frames_dropped = 0
        self.frames_logged = 0
        self.worker_errors: list[str] = []
        self._queue: queue.Queue[WorldFrame | None] = queue.Queue(maxsize=max(1, options.queue_frames))
        self._worker: threading.Thread | None = None
        # Set when the mission has ended: the worker stops letting frames gather and drains the queue.
        self._draining = threading.Event()
        self._world_file: Path | None = None
        # The world is logged to Rerun in a child process, live or saved (world_process.py says why),
        # spawned by the caller or now, so that its interpreter and Rerun's import overlap what the
        # mission sets up before ``start``.
        self._world_process: WorldProcess | None = None
        if options.world and sink_factory is None:
            self._world_process = options.world_process or WorldProcess.spawn()
        elif options.world_process is not None:  # spawned for a world this view does not log
            options.world_process.disconnect()

    @property
    def url(self) -> str | None:
        """The live page's URL (None before ``start`` or without ``live``)."""
        return None if self.server is None else self.server.url

    # ------------------------------------------------------------------ TickObserver
    def start(self, run: MissionRun) -> None:
        """Open the recording, serve the page, start the world logger and its worker."""
        options = self.options
        structure = tree_structure(run.tree.root)
        title = options.title or f"{run.tree.root.name}: {run.board.instruction}"
        world_file = self.writer.world_path if self.writer is not None and options.world else None
        self._world_file = world_file
        if self.writer is not None:
            self.writer.start(
                manifest={
                    "recording_id": self.recording_id,
                    "title": title,
                    "mission": {**options.mission, "instruction": run.board.instruction},
                    "world": world_file.name if world_file is not None else None,
                    "timelines": {"tick": "sequence", "sim_time": "duration_s"},
                    "started_unix_s": round(time.time(), 3),
                },
                tree=structure,
            )
        if options.live:
            self.feed = TickFeed({"mode": "live", "title": title, "tree": structure, "world": None})
            self.server = ViewServer(self.feed, host=options.host, port=options.port)
        if options.world:
            self.sink = self.sink_factory(
                recording_id=self.recording_id,
                run=run,
                world_file=world_file,
                grpc_port=options.grpc_port if options.live else None,
                cors_origin=self.server.origin if self.server is not None else None,
            )
            grpc_url = getattr(self.sink, "grpc_url", None)
            if self.feed is not None and grpc_url:
                self.feed.update_session(world={"kind": "grpc", "url": grpc_url})
        if self.sink is not None or self.writer is not None:
            self._worker = threading.Thread(target=self._work, name="semexp-view", daemon=True)
            self._worker.start()
        self.capture = FrameCapture.for_tree(run.tree.root)
        self._enqueue(self.capture.capture(run, visited={}, force_pose=True))
        if self.server is not None:
            if options.announce is not None:
                options.announce(self.server.url)
            if options.open_browser:
                self.server.open_browser()

    def _on_tick_record(self, tick: int, line: str) -> None:
        if self.writer is not None:
            self.writer.write_tick(line)
        if self.feed is not None:
            self.feed.append(tick, line)

    def after_tick(self, run: MissionRun) -> None:
        """Queue the tick's world frame (or drop it when the worker is behind)."""
        if self.capture is None or self.sink is None:
            return
        self._enqueue(self.capture.capture(run, visited=self.recorder.visited_statuses()))

    def finish(self, run: MissionRun, outcome: str) -> None:
        """Log the last frame, wait for the worker, complete the recording; then (live) hand over to
        ``after_mission`` and close."""
        if self.capture is not None and self.sink is not None:
            last = self.capture.capture(run, visited={}, force_pose=True, outcome=outcome)
            self._enqueue(last, wait_s=DRAIN_TIMEOUT_S)
        self._stop_worker()
        if self.sink is not None:
            try:
                self.sink.close()
            except Exception as exc:
                self.worker_errors.append(f"closing the world recording: {exc}")
        summary = {
            "outcome": outcome,
            "ticks": run.tick,
            "sim_time_s": round(run.now_s(), 4),
            "frames": {
                "queued": self.frames_queued,
                "logged": self.frames_logged,
                "dropped": self.frames_dropped,
            },
            "worker_errors": self.worker_errors[:10],
            "world": self._world_file.name
            if self._world_file is not None and self._world_file.is_file()
            else None,
        }
        if self.writer is not None:
            self.writer.finish(**summary)
        if self.feed is not None:
            self.feed.finish(outcome=outcome)
        if self.frames_dropped or self.worker_errors:
            print(
                f"view: {self.frames_dropped} of {self.frames_queued} world frames dropped"
                + (f"; first worker error: {self.worker_errors[0]}" if self.worker_errors else ""),
                file=sys.stderr,
            )
        try:
            if self.options.live and self.options.after_mission is not None:
                self.options.after_mission(self, outcome)
        finally:
            self.close()

    def close(self) -> None:
        """Stop serving the page and the Rerun stream."""
        if self.server is not None:
            self.server.close()
            self.server = None
        if self.sink is not None:
            try:
                self.sink.disconnect()
            finally:
                self.sink = None
        elif self._world_process is not None:  # spawned, never opened (the mission did not start)
            self._world_process.disconnect()
        self._world_process = None

    def _default_sink(
        self,
        *,
        recording_id: str,
        run: MissionRun,
        world_file: Path | None,
        grpc_port: int | None,
        cors_origin: str | None,
    ) -> FrameSink:
        """Rerun's logger for this mission, in the world process spawned in ``__init__``."""
        assert self._world_process is not None  # spawned whenever the default sink is used
        self._world_process.open(
            recording_id=recording_id,
            decision_config=run.services.config.decision,
            file_path=world_file,
            grpc_port=grpc_port,
            cors_origin=cors_origin,
        )
        return self._world_process

    # ------------------------------------------------------------------ the worker
    def _enqueue(self, frame: WorldFrame | None, *, wait_s: float = 0.0) -> None:
        """Queue ``frame`` for the worker (None: the tick had nothing to draw), or drop and count it."""
        if self.sink is None or frame is None:
            return
        self.frames_queued += 1
        try:
            if wait_s > 0.0:
                self._queue.put(frame, timeout=wait_s)
            else:
                self._queue.put_nowait(frame)
        except queue.Full:
            self.frames_dropped += 1

    def _work(self) -> None:
        while True:
            try:
                frame = self._queue.get(timeout=BATCH_GATHER_S)
            except queue.Empty:  # no world frames (or no world): the tick records still go to disk
                self._flush()
                continue
            if frame is not None:
                # Not a sleep: at the mission's end the last batch goes at once rather than after the
                # rest of the gathering time (up to a quarter of a second of the mission's wall time).
                self._draining.wait(BATCH_GATHER_S)
            # The batch is what has been queued by now; frames are taken one at a time, so the worker
            # never holds more than one beyond the bounded queue.
            remaining = self._queue.qsize()
            while frame is not None:
                self._log(frame)
                if remaining == 0:
                    break
                remaining -= 1
                frame = self._queue.get()
            self._flush()
            if frame is None:
                return

    def _log(self, frame: WorldFrame) -> None:
        assert self.sink is not None  # only frames for a sink are queued
        try:
            self.sink.log(frame)
            self.frames_logged += 1
        except Exception as exc:
            self._worker_error(f"tick {frame.tick}: {type(exc).__name__}: {exc}")

    def _flush(self) -> None:
        """Send the batch's held rows to the world and write the tick records handed over so far."""
        try:
            if self.sink is not None:
                self.sink.flush()
            if self.writer is not None:
                self.writer.flush()
        except Exception as exc:
            self._worker_error(f"writing a batch: {type(exc).__name__}: {exc}")

    def _worker_error(self, message: str) -> None:
        if len(self.worker_errors) < 10:
            self.worker_errors.append(message)

    def _stop_worker(self) -> None:
        if self._worker is None:
            return
        self._draining.set()
        try:
            self._queue.put(None, timeout=DRAIN_TIMEOUT_S)
        except queue.Full:
            self.worker_errors.append("the world logger did not drain its queue; the recording is incomplete")
        self._worker.join(timeout=DRAIN_TIMEOUT_S)
        self._worker = None
