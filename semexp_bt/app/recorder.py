"""Per-tick recording and the tick-level terminal display.

The recorder is a py_trees visitor: the tree yields each node right after ticking it, so the wall time
between two consecutive visits is the time that node spent in its own tick (for a leaf, its
``update``; for a composite, its own overhead). For each tick it keeps the status of every visited
node, that per-node time and the blackboard writes from py_trees' activity stream. A node that a parent
stopped during the tick (a preempted branch turns INVALID) says so in no visit; the record names such
nodes under ``stopped`` with their status after the tick, so that the record holds every node's status
at every tick.

- With a ``path`` it writes one JSON line per tick (``semexp-bt replay FILE`` prints it back). Each line
  goes to the file in one ``write`` call as its tick ends, so a mission killed in any way (``kill -9``
  included) leaves every whole tick before the kill readable, and at most a torn last line, which
  :func:`replay` skips and reports. The file is fsynced every :data:`FSYNC_EVERY_TICKS` ticks and when the
  mission ends, so a power cut or an OS crash loses at most that many ticks (one second of robot time)
  (an fsync per tick would cost more than the tick: about 13 ms on the development VM).
- With a ``path`` it writes one JSON line per tick (``semexp-bt replay FILE`` prints it back).
- With ``on_record`` (or :meth:`TickRecorder.listen`) it hands each tick's number and JSON line to a
  callable (the browser view's tick feed and saved recording).
- With ``display`` it prints, on every tick where a node changed status or a key other than the
  high-rate command keys was written: the tree with statuses and feedback (ASCII, readable in a plain
  terminal), the blackboard changes, the memory's size and the current subgoal.
- With neither, it adds no visitor and enables no activity stream, so a plain run pays nothing.
"""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

import py_trees

from blackboard.schema import summarize

if TYPE_CHECKING:
    from semexp_bt.app.runner import MissionRun

#: Keys written at the gait or planner rate; the display does not treat them as news.
HIGH_RATE_KEYS = frozenset({"/cmd_twist", "/cmd_stamp_s", "/plan"})
#: The record file is fsynced every this many ticks (one second of robot time at 50 Hz) and at the end.
FSYNC_EVERY_TICKS = 50
#: The JSON of a node's record entry is kept by (name, status, feedback) (see ``_node_entries``); the
#: cache starts again when it holds this many (a feedback message with a counter makes new ones).
NODE_JSON_CACHE = 4096


class RecordError(ValueError):
    """A tick record with a line that is neither a tick nor a torn last line."""


class _TimingVisitor(py_trees.visitors.VisitorBase):
    """Status name, own wall time (ms) and feedback of every node visited in one tick, by name."""

    def __init__(self) -> None:
        super().__init__(full=False)
        self.statuses: dict[str, tuple[str, float, str]] = {}
        self._last = 0.0

    def initialise(self) -> None:
        self.statuses = {}
        self._last = time.perf_counter()

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        # The status by name, read as ``_name_`` (the member's name, one of the enum's documented
        # ``_sunder_`` names): ``Enum.name`` is a Python-level property, and a status kept as the key of
        # the record's caches would hash through ``Enum.__hash__``, a Python call, at every node and tick.
        now = time.perf_counter()
        self.statuses[behaviour.name] = (
            behaviour.status._name_,
            (now - self._last) * 1e3,
            behaviour.feedback_message,
        )
        self._last = now


class TickRecorder:
    """A :class:`~semexp_bt.app.runner.TickObserver` that records ticks to a JSONL file and/or shows them
    in the terminal.

    Args:
        path: JSONL output, or None.
        display: show the tick-level display.
        stream: where the display prints (stdout by default).
        on_record: called with each tick's number and JSON line (without the newline), or None.
    """

    def __init__(
        self,
        *,
        path: Path | None,
        display: bool,
        stream: TextIO | None = None,
        on_record: Callable[[int, str], None] | None = None,
    ) -> None:
        self.path = path
        self.display = display
        self.stream = stream or sys.stdout
        self.on_record = on_record
        self.wants_activity_stream = display or path is not None or on_record is not None
        self._tree: py_trees.trees.BehaviourTree | None = None
        self._board: Any = None
        self._fd = -1
        self._unsynced = 0
        self._previous: dict[str, str] = {}
        self._nodes: list[py_trees.behaviour.Behaviour] = []
        self._index: dict[str, int] = {}
        self._last: list[str] = []
        self._visitor = _TimingVisitor()
        self._node_json: dict[tuple[str, str, str], tuple[str, str]] = {}

    def listen(self, on_record: Callable[[int, str], None]) -> None:
        """Hand every tick's number and JSON line to ``on_record`` (before the mission starts)."""
        self.on_record = on_record
        self.wants_activity_stream = True

    def visited_statuses(self) -> dict[str, str]:
        """The status of every node ticked in the last tick, by name."""
        return {name: visit[0] for name, visit in self._visitor.statuses.items()}

    def start(self, run: MissionRun) -> None:
        """Attach the timing visitor to the tree and open the record file."""
        if not self.wants_activity_stream:
            return
        self._tree, self._board = run.tree, run.board
        run.tree.visitors.append(self._visitor)
        run.tree.add_pre_tick_handler(lambda _tree: self._visitor.initialise())
        self._nodes = list(run.tree.root.iterate())
        # A mission's node names are unique (the loader checks), so a name is a node.
        self._index = {node.name: i for i, node in enumerate(self._nodes)}
        self._last = [node.status._name_ for node in self._nodes]
        if self.path is not None:
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
            self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND, 0o644)

    def after_tick(self, run: MissionRun) -> None:
        """Record/show the tick that just ran."""
        self.record_tick(run.tick, run.now_s())

    def finish(self, run: MissionRun, outcome: str) -> None:
        """Close the record file."""
        self.close()

    def _drain_activity(self) -> list[dict[str, Any]]:
        stream = py_trees.blackboard.Blackboard.activity_stream
        if stream is None:
            return []
        writes = [
            {
                "key": item.key,
                "client": item.client_name,
                "type": item.activity_type,
                "value": summarize(item.current_value),
            }
            for item in stream.data
            if item.activity_type in ("WRITE", "INITIALISED")
        ]
        stream.clear()
        return writes

    def record_tick(self, tick: int, stamp_s: float) -> None:
        """Record/show tick ``tick``, which ran at ``stamp_s``."""
        if not self.wants_activity_stream:
            return
        statuses = self._visitor.statuses
        writes = self._drain_activity()
        if self._fd >= 0 or self.on_record is not None:
            # The line json.dumps would write for {"tick", "stamp_s", "nodes", "writes"[, "stopped"]}, put
            # together from cached pieces: it is the tick thread's largest share of the record's cost.
            line = (
                f'{{"tick": {tick}, "stamp_s": {round(stamp_s, 4)!r}, "nodes": {{{self._node_entries(statuses)}}}'
                f', "writes": {json.dumps(writes) if writes else "[]"}'
            )
            stopped = self._stopped_nodes(statuses)
            line += f', "stopped": {json.dumps(stopped)}}}' if stopped else "}"
            if self._fd >= 0:
                self._write_line((line + "\n").encode("utf-8"))
            if self.on_record is not None:
                self.on_record(tick, line)
        if self.display:
            names = {name: status for name, (status, _, _) in statuses.items()}
            changed = {name: s for name, s in names.items() if self._previous.get(name) != s}
            news = [w for w in writes if w["key"] not in HIGH_RATE_KEYS]
            if changed or news:
                self._show(tick, stamp_s, news)
            self._previous.update(names)

    def _node_entries(self, statuses: dict[str, tuple[str, float, str]]) -> str:
        """The record's ``nodes`` object without its braces, as ``json.dumps`` writes it: each entry is
        ``"name": {"status": ..., "ms": ..., "feedback": ...}``, and only ``ms`` changes from tick to tick,
        so the JSON before and after it is cached."""
        cache = self._node_json
        if len(cache) > NODE_JSON_CACHE:
            cache.clear()
        entries = []
        for name, (status, ms, feedback) in statuses.items():
            key = (name, status, feedback)
            pieces = cache.get(key)
            if pieces is None:
                pieces = cache[key] = (
                    f'{json.dumps(name)}: {{"status": "{status}", "ms": ',
                    f', "feedback": {json.dumps(feedback)}}}',
                )
            entries.append(f"{pieces[0]}{round(ms, 4)!r}{pieces[1]}")
        return ", ".join(entries)

    def _stopped_nodes(self, statuses: dict[str, tuple[str, float, str]]) -> dict[str, str]:
        """Nodes whose status after the tick differs from what their visit reported, by name.

        A parent may stop a child it did not tick (a selector with memory resuming a later child stops
        the earlier ones) or one it ticked earlier in the same tick (a parallel that succeeds stops its
        running guards): both end INVALID without a visit saying so. The status names after the tick, in
        one list, are compared with what the visits and the previous tick say: the names are the enum's own
        string objects, so on most ticks the two lists are equal and the comparison is one C loop of
        identity checks.
        """
        expected = self._last
        index = self._index
        for name, visit in statuses.items():
            expected[index[name]] = visit[0]
        now = [node.status._name_ for node in self._nodes]
        self._last = now
        if now == expected:
            return {}
        return {
            node.name: status
            for node, status, wanted in zip(self._nodes, now, expected, strict=True)
            if status != wanted
        }

    def _show(self, tick: int, stamp_s: float, news: list[dict[str, Any]]) -> None:
        out = self.stream
        out.write(f"\n--- tick {tick}  t={stamp_s:7.2f} s " + "-" * 40 + "\n")
        assert self._tree is not None  # set in start()
        out.write(py_trees.display.ascii_tree(self._tree.root, show_status=True) + "\n")
        for write in news:
            out.write(f"  board {write['key']} <- {write['client']}: {json.dumps(write['value'])[:160]}\n")
        memory = self._board.memory
        out.write(f"  memory: {len(memory)} nodes, {memory.graph.number_of_edges()} edges\n")
        sg = self._board.subgoal
        if sg is not None:
            x, y, _ = sg.position_m
            out.write(f"  subgoal: node {sg.node_id} {sg.label!r} at ({x:.2f}, {y:.2f}) U={sg.utility:.3f}\n")
        out.flush()

    def _write_line(self, data: bytes) -> None:
        """One whole line in one ``write`` call (a kill tears at most this line); fsync now and then."""
        written = os.write(self._fd, data)
        if written != len(data):
            raise OSError(f"{self.path}: wrote {written} of {len(data)} bytes of a tick record")
        self._unsynced += 1
        if self._unsynced >= FSYNC_EVERY_TICKS:
            os.fsync(self._fd)
            self._unsynced = 0

    def close(self) -> None:
        """Fsync and close the record file (idempotent)."""
        if self._fd >= 0:
            try:
                os.fsync(self._fd)
            finally:
                os.close(self._fd)
                self._fd = -1


def read_ticks(path: Path, *, torn: list[int] | None = None) -> Iterator[dict[str, Any]]:
    """The tick records of a file written by :class:`TickRecorder`, one at a time (records are large).

    A last line that is not JSON is a tick torn by a kill: it is skipped and its line number appended to
    ``torn``. Any other line that is not a JSON object is an error.

    Raises:
        RecordError: naming the file and line.
        OSError: when the file cannot be read.
    """
    with open(path, "rb") as handle:
        pending: tuple[int, bytes] | None = None
        for line_no, raw in enumerate(handle, start=1):
            if not raw.strip():
                continue
            if pending is not None:
                yield _parse_tick(path, *pending)
            pending = (line_no, raw)
        if pending is not None:
            line_no, raw = pending
            try:
                yield _parse_tick(path, line_no, raw)
            except RecordError:
                if torn is None:
                    raise
                torn.append(line_no)


def _parse_tick(path: Path, line_no: int, raw: bytes) -> dict[str, Any]:
    try:
        record = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        reason = exc.msg if isinstance(exc, json.JSONDecodeError) else "not UTF-8"
        raise RecordError(f"{path}:{line_no}: not a JSON tick record ({reason})") from None
    if not isinstance(record, dict) or not {"tick", "stamp_s", "nodes", "writes"} <= set(record):
        raise RecordError(f"{path}:{line_no}: not a tick record (needs tick, stamp_s, nodes, writes)")
    return record


def replay(path: Path, *, stream: TextIO | None = None, only_changes: bool = True) -> int:
    """Print a recorded JSONL tick file back, tick by tick (statuses, feedback, writes). Returns ticks read.

    A torn last line (the mission was killed while writing it) is skipped, and a line says so.

    Raises:
        RecordError: for a line other than the last that is not a tick record (naming file and line).
    """
    out = stream or sys.stdout
    previous: dict[str, str] = {}
    count = 0
    torn: list[int] = []
    for record in read_ticks(path, torn=torn):
        count += 1
        nodes = record["nodes"]
        changed = {n: v for n, v in nodes.items() if previous.get(n) != v["status"]}
        writes = [w for w in record["writes"] if w["key"] not in HIGH_RATE_KEYS]
        if only_changes and not changed and not writes:
            continue
        out.write(f"tick {record['tick']} t={record['stamp_s']:.2f}s\n")
        for name, v in (changed if only_changes else nodes).items():
            out.write(f"  {name}: {v['status']} ({v['ms']:.3f} ms) {v['feedback']}\n")
        for w in writes:
            out.write(f"  board {w['key']} <- {w['client']}\n")
        previous.update({n: v["status"] for n, v in nodes.items()})
    for line_no in torn:
        out.write(f"line {line_no}: a torn tick (the mission was killed while writing it), skipped\n")
    return count
