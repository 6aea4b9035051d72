"""Per-tick recording and the tick-level terminal display.

The recorder is a py_trees visitor: the tree yields each node right after ticking it, so the wall time
between two consecutive visits is the time that node spent in its own tick (for a leaf, its
``update``; for a composite, its own overhead). For each tick it keeps the status of every visited
node, that per-node time and the blackboard writes from py_trees' activity stream. A node that a parent
stopped during the tick (a preempted branch turns INVALID) says so in no visit; the record names such
nodes under ``stopped`` with their status after the tick, so that the record holds every node's status
at every tick.

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
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

import py_trees

from blackboard.schema import summarize

if TYPE_CHECKING:
    from semexp_bt.app.runner import MissionRun

_STATUS_BY_NAME = {status.name: status for status in py_trees.common.Status}
#: Keys written at the gait or planner rate; the display does not treat them as news.
HIGH_RATE_KEYS = frozenset({"/cmd_twist", "/cmd_stamp_s", "/plan"})


class _TimingVisitor(py_trees.visitors.VisitorBase):
    """Status and own wall time of every node visited in one tick."""

    def __init__(self) -> None:
        super().__init__(full=False)
        self.statuses: dict[str, tuple[str, float, str]] = {}
        self._last = 0.0

    def initialise(self) -> None:
        self.statuses = {}
        self._last = time.perf_counter()

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        now = time.perf_counter()
        self.statuses[behaviour.name] = (
            behaviour.status.name,
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
        self._file: TextIO | None = None
        self._previous: dict[str, str] = {}
        self._nodes: list[py_trees.behaviour.Behaviour] = []
        self._last: list[py_trees.common.Status] = []
        self._visitor = _TimingVisitor()

    def listen(self, on_record: Callable[[int, str], None]) -> None:
        """Hand every tick's number and JSON line to ``on_record`` (before the mission starts)."""
        self.on_record = on_record
        self.wants_activity_stream = True

    def visited_statuses(self) -> dict[str, str]:
        """The status of every node ticked in the last tick, by name."""
        return {name: status for name, (status, _, _) in self._visitor.statuses.items()}

    def start(self, run: MissionRun) -> None:
        """Attach the timing visitor to the tree and open the record file."""
        if not self.wants_activity_stream:
            return
        self._tree, self._board = run.tree, run.board
        run.tree.visitors.append(self._visitor)
        run.tree.add_pre_tick_handler(lambda _tree: self._visitor.initialise())
        self._nodes = list(run.tree.root.iterate())
        self._last = [node.status for node in self._nodes]
        if self.path is not None:
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "w")

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
        if self._file is not None or self.on_record is not None:
            record: dict[str, Any] = {
                "tick": tick,
                "stamp_s": round(stamp_s, 4),
                "nodes": {
                    name: {"status": s, "ms": round(ms, 4), "feedback": fb}
                    for name, (s, ms, fb) in statuses.items()
                },
                "writes": writes,
            }
            stopped = self._stopped_nodes(statuses)
            if stopped:
                record["stopped"] = stopped
            line = json.dumps(record)
            if self._file is not None:
                self._file.write(line + "\n")
            if self.on_record is not None:
                self.on_record(tick, line)
        if self.display:
            changed = {name: s for name, (s, _, _) in statuses.items() if self._previous.get(name) != s}
            news = [w for w in writes if w["key"] not in HIGH_RATE_KEYS]
            if changed or news:
                self._show(tick, stamp_s, news)
            self._previous.update({name: s for name, (s, _, _) in statuses.items()})

    def _stopped_nodes(self, statuses: dict[str, tuple[str, float, str]]) -> dict[str, str]:
        """Nodes whose status after the tick differs from what their visit reported, by name.

        A parent may stop a child it did not tick (a selector with memory resuming a later child stops
        the earlier ones) or one it ticked earlier in the same tick (a parallel that succeeds stops its
        running guards): both end INVALID without a visit saying so. One pass over the nodes' statuses,
        compared by identity (the enum's ``name`` is a slow property), finds them.
        """
        stopped = {}
        last = self._last
        for i, node in enumerate(self._nodes):
            status = node.status
            visit = statuses.get(node.name)
            expected = last[i] if visit is None else _STATUS_BY_NAME[visit[0]]
            if status is not expected:
                stopped[node.name] = status.name
            last[i] = status
        return stopped

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

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def replay(path: Path, *, stream: TextIO | None = None, only_changes: bool = True) -> int:
    """Print a recorded JSONL tick file back, tick by tick (statuses, feedback, writes). Returns ticks read."""
    out = stream or sys.stdout
    previous: dict[str, str] = {}
    count = 0
    with open(path) as handle:
        for line_no, line in enumerate(handle, start=1):
            try:
                record = json.loads(line)
            except json.JSONDecodeError as exc:
                raise ValueError(f"{path}:{line_no}: not a JSON tick record: {exc}") from exc
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
    return count
