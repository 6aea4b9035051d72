"""The saved recording of a mission view: one directory that ``semexp-bt view`` replays and
``semexp-bt export`` converts.

Layout (names are constants here, the one place they are written)::

    DIR/manifest.json   what was recorded: format, version, status, mission, ticks, outcome, frame counts
    DIR/tree.json       the mission tree's structure (every node's name, type, kind and children)
    DIR/ticks.jsonl     one line per tick, the tick recorder's record (statuses, per-node ms, feedback,
                        blackboard writes, nodes a parent stopped)
    DIR/world.rrd       the Rerun recording of the world, on the ``tick`` and ``sim_time`` timelines

The manifest is written when recording starts (``status: recording``) and again when the mission ends
(``status: complete``), so a recording cut short by a crash still opens, and says so.

:func:`open_recording` checks all of it and names the file (and line) of anything wrong.
"""

from __future__ import annotations

import json
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

MANIFEST_FILE = "manifest.json"
TREE_FILE = "tree.json"
TICKS_FILE = "ticks.jsonl"
WORLD_FILE = "world.rrd"
#: The manifest's ``format`` and ``version``; a reader refuses other formats and newer versions.
RECORDING_FORMAT = "semexp-bt-view"
RECORDING_VERSION = 1
STATUS_RECORDING = "recording"
STATUS_COMPLETE = "complete"


class RecordingError(ValueError):
    """A saved recording that cannot be read; the message names the file (and line) at fault."""


@dataclass
class SavedRecording:
    """A saved recording, read and checked.

    Attributes:
        directory: where it lies.
        manifest: the manifest (see the module docstring).
        tree: the tree's structure (``semexp_bt.app.viewer.tree_page.tree_structure``).
        tick_lines: the tick records, one JSON line each, in tick order.
        world_path: the Rerun recording, or None when the mission was recorded without one.
    """

    directory: Path
    manifest: dict[str, Any]
    tree: dict[str, Any]
    tick_lines: list[str]
    world_path: Path | None

    @property
    def complete(self) -> bool:
        """Whether the mission ended normally while recording (a crash leaves ``recording``)."""
        return self.manifest.get("status") == STATUS_COMPLETE


class RecordingWriter:
    """Writes a recording directory as the mission runs (the view observer drives it).

    The tick thread only hands each tick's line over (:meth:`write_tick`); the view's worker thread
    writes what has been handed over (:meth:`flush`), so a slow disk holds up the worker and never the
    tree. A crash loses the lines not yet flushed (the worker flushes a few times a second) and tears at
    most the last line written, which :func:`open_recording` drops.

    Args:
        directory: created if missing; an existing recording there is replaced.
    """

    def __init__(self, directory: Path) -> None:
        self.directory = Path(directory)
        self.manifest: dict[str, Any] = {}
        self._ticks: TextIO | None = None
        # A deque: the tick thread appends while the worker pops, with no lock (both are atomic).
        self._pending: deque[str] = deque()

    @property
    def world_path(self) -> Path:
        return self.directory / WORLD_FILE

    def start(self, *, manifest: dict[str, Any], tree: dict[str, Any]) -> None:
        """Write the tree and a first manifest, and open the tick file."""
        self.directory.mkdir(parents=True, exist_ok=True)
        for name in (MANIFEST_FILE, TREE_FILE, TICKS_FILE, WORLD_FILE):
            (self.directory / name).unlink(missing_ok=True)
        self.manifest = {
            "format": RECORDING_FORMAT,
            "version": RECORDING_VERSION,
            "status": STATUS_RECORDING,
            **manifest,
        }
        _write_json(self.directory / TREE_FILE, tree)
        self._write_manifest()
        self._ticks = open(self.directory / TICKS_FILE, "w")

    def write_tick(self, line: str) -> None:
        """Hand over one tick record (a JSON line without its newline); :meth:`flush` writes it."""
        self._pending.append(line)

    def flush(self) -> None:
        """Write the tick records handed over so far, in one write (the view's worker calls this)."""
        if self._ticks is None or not self._pending:
            return
        pending = self._pending
        lines = [pending.popleft() for _ in range(len(pending))]
        self._ticks.write("\n".join(lines) + "\n")
        self._ticks.flush()

    def finish(self, **summary: Any) -> None:
        """Write what is left, close the tick file and complete the manifest with ``summary`` (outcome,
        ticks, counts)."""
        if self._ticks is not None:
            self.flush()
            self._ticks.close()
            self._ticks = None
        self.manifest.update(summary, status=STATUS_COMPLETE)
        self._write_manifest()

    def _write_manifest(self) -> None:
        _write_json(self.directory / MANIFEST_FILE, self.manifest)


def _write_json(path: Path, data: Any) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    tmp.replace(path)


def _read_json(path: Path) -> Any:
    if not path.is_file():
        raise RecordingError(f"{path}: missing (not a recording written by `semexp-bt run --view-record`?)")
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise RecordingError(f"{path}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}") from exc


def open_recording(directory: Path) -> SavedRecording:
    """Read and check a saved recording.

    Raises:
        RecordingError: naming the file (and line) of a missing or malformed part.
    """
    directory = Path(directory)
    if not directory.is_dir():
        raise RecordingError(f"{directory}: not a directory")
    manifest = _read_json(directory / MANIFEST_FILE)
    where = directory / MANIFEST_FILE
    if not isinstance(manifest, dict) or manifest.get("format") != RECORDING_FORMAT:
        raise RecordingError(f"{where}: 'format' must be {RECORDING_FORMAT!r}")
    version = manifest.get("version")
    if not isinstance(version, int) or version > RECORDING_VERSION:
        raise RecordingError(
            f"{where}: version {version!r} is not readable by this semexp-bt (reads up to {RECORDING_VERSION})"
        )
    tree = _read_json(directory / TREE_FILE)
    if not isinstance(tree, dict) or not isinstance(tree.get("nodes"), list) or not tree["nodes"]:
        raise RecordingError(f"{directory / TREE_FILE}: 'nodes' must be a non-empty list")
    ticks_path = directory / TICKS_FILE
    if not ticks_path.is_file():
        raise RecordingError(f"{ticks_path}: missing")
    lines: list[str] = []
    previous = 0
    with open(ticks_path) as handle:
        for line_no, raw in enumerate(handle, start=1):
            line = raw.rstrip("\n")
            if not line:
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError as exc:
                if raw.endswith("\n") or manifest.get("status") == STATUS_COMPLETE:
                    raise RecordingError(
                        f"{ticks_path}:{line_no}: not a JSON tick record: {exc.msg}"
                    ) from exc
                break  # the last line of a recording cut short mid-write
            tick = record.get("tick") if isinstance(record, dict) else None
            if not isinstance(tick, int) or tick <= previous or not isinstance(record.get("nodes"), dict):
                raise RecordingError(
                    f"{ticks_path}:{line_no}: a tick record needs an increasing integer 'tick' and 'nodes'"
                )
            previous = tick
            lines.append(line)
    world = directory / WORLD_FILE
    world_path = world if world.is_file() else None
    if world_path is None and manifest.get("world"):
        raise RecordingError(f"{world}: missing (the manifest says the world was recorded)")
    return SavedRecording(
        directory=directory, manifest=manifest, tree=tree, tick_lines=lines, world_path=world_path
    )
