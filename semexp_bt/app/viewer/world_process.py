"""The world's Rerun logging in a process of its own: the view's frame sink, live and saved.

:class:`WorldProcess` is a :class:`~semexp_bt.app.viewer.observer.FrameSink` whose
:class:`~semexp_bt.app.viewer.world.WorldLogger` runs in a child process. The observer's worker thread
hands it a batch of frames at each ``flush``; the batch goes to the child as one message, and the child
logs it to Rerun (to ``world.rrd``, to the live view's gRPC server, or both) while the mission ticks.

Why a process and not the worker thread alone: in one process every Rerun call of the worker takes the
interpreter lock from the tick thread, and on the two-core development VM the worker's share (about 2 ms
per simulated second) and Rerun's import (about 0.4 s of interpreter time, once) were paid in the
mission's wall time (docs/viewer.md, sessions 23 and 35). A child on the other core takes both off the
tick thread; what stays is pickling each batch. The child is spawned (not forked: the mission's process
holds MuJoCo's GL context and torch's threads) early, so that its interpreter start and imports are done
by the time the mission starts: ``semexp-bt run`` spawns it before it imports the mission stack and
hands it over in ``ViewOptions.world_process``; otherwise the observer spawns it when it is made, and it
overlaps the mission's set-up. What it imports is kept small (Rerun, the logger and the frames'
plain types, ``frames.py``): a child that imported the navigation stack and the tree's registry to
unpickle its first batch spent 0.9 s of CPU on it beside the mission, and the live view cost more in the
child than in process until that was gone (docs/viewer.md, session 35).

A child that stops reading for a while (its Rerun import on a cold disk, a core taken by other work, a
debugger) must not cost the saved recording frames: each message is pickled on the caller's thread into
an outbox, and a sender thread of its own writes the outbox to the socket, so the observer's worker keeps
draining its frame queue while the child catches up. The outbox holds at most :data:`BACKLOG_BYTES`; only
past that does the worker wait, its queue fill, and frames drop (docs/viewer.md, session 27: a child
stopped for 15 s of the README's mission cost 413 of 951 frames before the outbox, none after).

The child ends when it is told to, or when the mission's process is gone (its end of the pipe closes).
An error in the child is reported back: at once if the logger could not be made (the next ``log`` or
``flush`` raises it), per frame otherwise (``close`` raises them, and the observer counts them as worker
errors).

Example:
    >>> world = WorldProcess.spawn()  # doctest: +SKIP
    >>> world.open(recording_id="r", decision_config=DecisionConfig(), file_path=Path("world.rrd"),
    ...            grpc_port=None, cors_origin=None)  # doctest: +SKIP
    >>> world.log(frame); world.flush(); world.close(); world.disconnect()  # doctest: +SKIP
"""

from __future__ import annotations

import collections
import contextlib
import multiprocessing.connection
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
from multiprocessing.reduction import ForkingPickler
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    # Types only: the child imports this module first, then Rerun, then the logger (which brings the
    # frames' light modules, so that the first batch unpickles with no import).
    from semexp_bt.app.viewer.frames import WorldFrame
    from semexp_bt.core.config import DecisionConfig

#: How long ``open`` waits for the child's logger in live mode, and ``close`` for the recording to be
#: complete (wall seconds).
REPLY_TIMEOUT_S = 120.0
#: How long ``disconnect`` waits for the child to end before it is killed (wall seconds).
EXIT_TIMEOUT_S = 10.0
#: How long one message to the child may wait for room in the socket, or in a full outbox (wall
#: seconds): past it the child counts as stuck, is killed, and the view reports it; the mission never
#: waits longer.
SEND_TIMEOUT_S = 60.0
#: Pickled messages the child has not taken yet, at most this many bytes. A whole 600 s mission's frames
#: (its camera images included) are well under it, so a child that pauses and resumes loses nothing;
#: a child that has stopped for good costs this much memory before frames drop.
BACKLOG_BYTES = 256 * 1024 * 1024
#: At most this many of the child's per-frame errors travel back.
MAX_ERRORS = 10
#: The child's scheduling priority below the mission's (``nice``): on two cores its Rerun threads would
#: otherwise take turns with the tick thread and the renderer's; the view may lag, the mission may not.
WORLD_NICENESS = 10


class WorldProcessError(RuntimeError):
    """The child process failed to log the world (its message says what and where)."""


class WorldProcess:
    """A frame sink whose Rerun logger runs in a spawned child process (see the module docstring)."""

    def __init__(
        self, connection: multiprocessing.connection.Connection, process: subprocess.Popen[bytes]
    ) -> None:
        self._conn = connection
        self._process = process
        self._pending: list[WorldFrame] = []
        self._failed: str | None = None
        # Pickled messages in the order they were sent, and their bytes (the one being written included).
        # The worker thread sends batches and ``finish`` sends "close" on the mission's thread: both
        # append here, and only the sender thread writes to the socket, so the child never reads a torn
        # message.
        self._outbox: collections.deque[memoryview] = collections.deque()
        self._outbox_bytes = 0
        self._outbox_changed = threading.Condition()
        # Set when nothing more can or should be written to the child: the socket failed, the child was
        # given up, or ``disconnect`` has ended it. (A child that reports a failure is still written to:
        # it must hear "disconnect".)
        self._link_down = False
        self._sender = threading.Thread(target=self._send_outbox, name="semexp-view-send", daemon=True)
        self._sender.start()
        self.grpc_url: str | None = None

    @classmethod
    def spawn(cls) -> WorldProcess:
        """Start the child (it imports Rerun, then waits for :meth:`open`).

        The child is a fresh interpreter running :func:`serve_world` on one end of a socket pair, not a
        ``multiprocessing`` process: that would re-run the caller's main script in the child, which a
        user's script without a ``__main__`` guard does not survive.
        """
        parent_end, child_end = socket.socketpair()
        seconds = int(SEND_TIMEOUT_S)
        parent_end.setsockopt(socket.SOL_SOCKET, socket.SO_SNDTIMEO, struct.pack("ll", seconds, 0))
        try:
            with child_end:
                command = f"from {__name__} import serve_world_on; serve_world_on({child_end.fileno()})"
                process = subprocess.Popen([sys.executable, "-c", command], pass_fds=(child_end.fileno(),))
        except BaseException:
            parent_end.close()
            raise
        return cls(multiprocessing.connection.Connection(parent_end.detach()), process)

    def open(
        self,
        *,
        recording_id: str,
        decision_config: DecisionConfig,
        file_path: Path | None,
        grpc_port: int | None,
        cors_origin: str | None,
    ) -> None:
        """Make the child's :class:`~semexp_bt.app.viewer.world.WorldLogger` (the arguments are its own).

        With a ``grpc_port`` (live) it waits until the logger serves the stream, so the page never
        announces a stream that is not there yet, and sets :attr:`grpc_url`.

        Raises:
            WorldProcessError: live, when the child could not make the logger.
        """
        self._send(
            (
                "open",
                {
                    "recording_id": recording_id,
                    "decision_config": decision_config,
                    "file_path": file_path,
                    "grpc_port": grpc_port,
                    "cors_origin": cors_origin,
                },
            )
        )
        if grpc_port is not None:
            self.grpc_url = self._reply("opening the live world stream")

    def log(self, frame: WorldFrame) -> None:
        """Hold ``frame`` for the next batch."""
        self._raise_if_failed()
        self._pending.append(frame)

    def flush(self) -> None:
        """Send the held frames to the child as one batch."""
        self._raise_if_failed()
        if self._pending:
            batch, self._pending = self._pending, []
            self._send(("batch", batch))

    def close(self) -> None:
        """Send what is held and wait until the child has logged everything and flushed its sinks.

        Raises:
            WorldProcessError: the child's errors (the first :data:`MAX_ERRORS` of them), if any.
        """
        self.flush()
        self._send(("close", None))
        errors = self._reply("completing the world recording")
        if errors:
            raise WorldProcessError("; ".join(errors))

    def disconnect(self) -> None:
        """Stop the child (its gRPC server and file end with it)."""
        try:
            self._send(("disconnect", None))
        except WorldProcessError:
            pass  # already gone
        try:
            self._process.wait(timeout=EXIT_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait(timeout=EXIT_TIMEOUT_S)
        with self._outbox_changed:
            self._link_down = True
            self._outbox_changed.notify_all()
        self._sender.join(timeout=EXIT_TIMEOUT_S)
        self._conn.close()

    def _send(self, message: tuple[str, Any]) -> None:
        """Pickle ``message`` into the outbox; wait (at most :data:`SEND_TIMEOUT_S`) only while the
        outbox holds :data:`BACKLOG_BYTES` already."""
        if self._failed is not None and message[0] != "disconnect":
            raise WorldProcessError(self._failed)
        payload = ForkingPickler.dumps(message)
        with self._outbox_changed:
            room = self._outbox_changed.wait_for(
                lambda: (
                    self._link_down or not self._outbox or self._outbox_bytes + len(payload) <= BACKLOG_BYTES
                ),
                timeout=SEND_TIMEOUT_S,
            )
            if self._link_down:
                if message[0] == "disconnect":
                    return
                raise WorldProcessError(self._failed or "the world process was disconnected")
            if not room:
                self._fail(
                    f"the world process took no message for {SEND_TIMEOUT_S:.0f} s "
                    f"({self._outbox_bytes / 1e6:.0f} MB waiting)"
                )
                raise WorldProcessError(str(self._failed))
            self._outbox.append(payload)
            self._outbox_bytes += len(payload)
            self._outbox_changed.notify_all()

    def _send_outbox(self) -> None:
        """The sender thread: write the outbox to the child in order, until it fails or is disconnected."""
        while True:
            with self._outbox_changed:
                self._outbox_changed.wait_for(lambda: self._link_down or bool(self._outbox))
                if self._link_down:
                    return
                payload = self._outbox[0]
            try:
                self._conn.send_bytes(payload)
            except OSError as exc:  # gone, or stuck past SEND_TIMEOUT_S (the stream may be torn: end it)
                with self._outbox_changed:
                    self._fail(f"the world process stopped taking frames ({type(exc).__name__}: {exc})")
                return
            with self._outbox_changed:
                self._outbox.popleft()
                self._outbox_bytes -= len(payload)
                self._outbox_changed.notify_all()

    def _fail(self, reason: str) -> None:
        """Record why the child is given up, kill it, and wake every waiter (hold ``_outbox_changed``)."""
        if self._failed is None:
            self._failed = reason
        self._link_down = True
        self._process.kill()
        self._outbox_changed.notify_all()

    def _reply(self, doing: str) -> Any:
        """The value of the child's next reply.

        Raises:
            WorldProcessError: no reply in time, the child ended, or it reports that it failed (which
                :meth:`_raise_if_failed` then keeps raising).
        """
        if not self._conn.poll(REPLY_TIMEOUT_S):
            raise WorldProcessError(
                f"the world process did not answer within {REPLY_TIMEOUT_S:.0f} s ({doing})"
            )
        try:
            kind, value = self._conn.recv()
        except (EOFError, OSError) as exc:
            raise WorldProcessError(
                f"the world process ended while {doing} (exit code {self._process.poll()})"
            ) from exc
        if kind == "failed":
            self._failed = str(value)
            raise WorldProcessError(self._failed)
        return value

    def _raise_if_failed(self) -> None:
        if self._failed is None and self._conn.poll():
            try:
                kind, value = self._conn.recv()
            except (EOFError, OSError):
                kind, value = "failed", f"the world process ended (exit code {self._process.poll()})"
            if kind == "failed":
                self._failed = str(value)
        if self._failed is not None:
            raise WorldProcessError(self._failed)


def serve_world_on(fd: int) -> None:
    """The child's entry point: :func:`serve_world` on the inherited socket ``fd``."""
    serve_world(multiprocessing.connection.Connection(fd))


def serve_world(connection: multiprocessing.connection.Connection) -> None:
    """The child's loop: make the logger on ``open``, log each ``batch``, flush on ``close``, end on
    ``disconnect`` or when the parent's end of the pipe closes."""
    # Ctrl-C reaches the whole process group: the mission's process decides when the view ends.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.nice(WORLD_NICENESS)
    with contextlib.suppress(ImportError):  # now, while the mission sets up; a missing SDK fails at "open"
        import rerun  # noqa: F401

    from semexp_bt.app.viewer.world import WorldLogger

    logger: WorldLogger | None = None
    errors: list[str] = []
    while True:
        try:
            kind, value = connection.recv()
        except Exception:  # the mission's process is gone (EOF), or a torn message after a timeout
            break
        if kind == "open":
            try:
                logger = WorldLogger(**value)
            except Exception as exc:
                connection.send(("failed", f"the world logger could not start: {type(exc).__name__}: {exc}"))
                continue
            if value["grpc_port"] is not None:
                connection.send(("opened", logger.grpc_url))
        elif kind == "batch" and logger is not None:
            for frame in value:
                try:
                    logger.log(frame)
                except Exception as exc:
                    if len(errors) < MAX_ERRORS:
                        errors.append(f"tick {frame.tick}: {type(exc).__name__}: {exc}")
            try:
                logger.flush()
            except Exception as exc:
                if len(errors) < MAX_ERRORS:
                    errors.append(f"writing a batch: {type(exc).__name__}: {exc}")
        elif kind == "close":
            if logger is not None:
                try:
                    logger.close()
                except Exception as exc:
                    errors.append(f"closing the world recording: {type(exc).__name__}: {exc}")
            connection.send(("closed", errors))
        elif kind == "disconnect":
            if logger is not None:
                logger.disconnect()
            break
    connection.close()
