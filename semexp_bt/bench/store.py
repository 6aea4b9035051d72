"""A sweep's folder, read and written so that nothing finished is lost.

``DIR/`` holds:

- ``episodes.jsonl``: one row per finished episode (``bench.rows``), appended by the sweep's parent
  process only, each as one whole line flushed and fsynced before the sweep moves on
  (:class:`~semexp_bt.core.durable.JsonLinesAppender`). A kill (even ``kill -9``) tears at most the
  line being written; the reader skips a torn last line and says so, and the next writer cuts the
  fragment off before it appends, so a resumed sweep runs that episode again and loses no other.
- ``trajectories/<key>.json``: the base path and the final memory of a few episodes, for the report's
  plots, each written whole (temporary file and rename) before its row names it.
- ``invocations.jsonl``: one line per call of the sweep on this folder (wall time, counts, revision),
  appended the same way; a resumed sweep's wall time is the sum of its lines.
- ``sweep.json``: the last specs run here, the machine and the code revision, replaced whole.
- ``.lock``: held (``flock``) by the one sweep writing the folder; the kernel releases it when that
  process ends, however it ends.
"""

from __future__ import annotations

import fcntl
import json
import os
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path
from typing import Any, TextIO

from semexp_bt.bench.rows import EXTRAS_KEY
from semexp_bt.bench.sweep import HarnessError, SweepSpec
from semexp_bt.core.durable import JsonLinesAppender, JsonLinesError, read_json_lines, write_atomic

EPISODES_FILE = "episodes.jsonl"
TRAJECTORY_DIR = "trajectories"
SWEEP_META_FILE = "sweep.json"
#: One line per call of the sweep on a folder: a resumed sweep's wall time is the sum of its lines.
INVOCATIONS_FILE = "invocations.jsonl"
LOCK_FILE = ".lock"


def _warn(stream: TextIO | None, message: str) -> None:
    print(f"warning: {message}", file=stream or sys.stderr)


def _read_lines(path: Path, *, stream: TextIO | None) -> list[tuple[int, Any]]:
    """(line number, record) of a JSON-lines file; a torn last line is skipped with a warning.

    Raises:
        HarnessError: naming the file and line of a damaged line other than the last.
    """
    try:
        lines = read_json_lines(path)
    except JsonLinesError as exc:
        raise HarnessError(str(exc)) from None
    if lines.torn_line is not None:
        _warn(stream, f"{path}:{lines.torn_line}: torn last line skipped (a write was cut short)")
    return list(zip(lines.line_numbers, lines.records, strict=True))


def load_rows(out_dir: Path, *, stream: TextIO | None = None) -> list[dict[str, Any]]:
    """Rows of ``out_dir/episodes.jsonl``, the newest per key, in file order of that newest row.

    A torn last line (the sweep was killed mid-write) is skipped with a warning on ``stream``.

    Raises:
        HarnessError: naming the file and line of a damaged line other than the last, or of a line that
            is not a row (an object with a ``key``).
    """
    path = Path(out_dir) / EPISODES_FILE
    if not path.is_file():
        return []
    latest: dict[str, dict[str, Any]] = {}
    for number, row in _read_lines(path, stream=stream):
        if not isinstance(row, dict) or not isinstance(row.get("key"), str):
            raise HarnessError(f"{path}:{number}: expected an episode row (an object with a 'key')")
        latest.pop(row["key"], None)  # re-insert so order follows the newest row
        latest[row["key"]] = row
    return list(latest.values())


def load_invocations(out_dir: Path, *, stream: TextIO | None = None) -> list[dict[str, Any]]:
    """The lines of ``DIR/invocations.jsonl`` (empty when the folder has none).

    A torn last line is skipped with a warning on ``stream``.

    Raises:
        HarnessError: naming the file and line of a line that is not a JSON object with a ``wall_s``.
    """
    path = Path(out_dir) / INVOCATIONS_FILE
    if not path.is_file():
        return []
    records = []
    for number, record in _read_lines(path, stream=stream):
        if not isinstance(record, dict) or not isinstance(record.get("wall_s"), (int, float)):
            raise HarnessError(f"{path}:{number}: expected an object with a numeric 'wall_s'")
        records.append(record)
    return records


def log_invocation(out_dir: Path, record: Mapping[str, Any], *, stream: TextIO | None = None) -> None:
    """Append one invocation's line to ``DIR/invocations.jsonl``."""
    with JsonLinesAppender(Path(out_dir) / INVOCATIONS_FILE) as log:
        if log.dropped_tail:
            _warn(stream, f"{log.path}: cut off a torn last line of {len(log.dropped_tail)} bytes")
        log.append(record)


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    if hasattr(value, "item"):
        return value.item()
    return str(value)


def trajectory_file_name(key: str) -> str:
    """The trajectory file of the episode with this key (its ``/`` made file-name safe)."""
    return key.replace("/", "__") + ".json"


class RowWriter:
    """Appends rows to ``episodes.jsonl`` (the parent process only) and trajectories to their files.

    Args:
        out_dir: the sweep's folder.
        stream: where a repaired torn line is reported.
    """

    def __init__(self, out_dir: Path, *, stream: TextIO | None = None) -> None:
        self.out_dir = Path(out_dir)
        self._log = JsonLinesAppender(self.out_dir / EPISODES_FILE, default=_json_default)
        if self._log.dropped_tail:
            _warn(stream, f"{self._log.path}: cut off a torn last line of {len(self._log.dropped_tail)} bytes "
                          "(its episode runs again)")  # fmt: skip

    def write(self, row: dict[str, Any]) -> dict[str, Any]:
        """Write the trajectory file a row carries (whole), then the row (one fsynced line).

        Returns:
            The row as written (without its extras, with ``trajectory_file`` when it had them).
        """
        extras = row.pop(EXTRAS_KEY, None)
        if extras:
            name = trajectory_file_name(row["key"])
            payload = {"key": row["key"], "scene": row.get("scene"), "seed": row.get("seed"),
                       "strategy": row.get("strategy"), "outcome": row.get("outcome"),
                       "success": row.get("success"), "start_pose": row.get("start_pose"),
                       "final_pose": row.get("final_pose"), **extras}  # fmt: skip
            write_atomic(self.out_dir / TRAJECTORY_DIR / name, json.dumps(payload, separators=(",", ":")))
            row["trajectory_file"] = f"{TRAJECTORY_DIR}/{name}"
        self._log.append(row)
        return row

    def close(self) -> None:
        """Close ``episodes.jsonl``."""
        self._log.close()


def write_sweep_meta(
    out_dir: Path, specs: Sequence[SweepSpec], *, workers: int, ray_address: str | None, revision: str | None
) -> None:
    """``sweep.json``: the last specs run here, the machine and the code revision (not part of keys)."""
    meta = {
        "specs": [
            {k: (str(v) if isinstance(v, Path) else v) for k, v in asdict(one).items()} for one in specs
        ],
        "workers": workers,
        "ray_address": ray_address,
        "cpu_count": os.cpu_count(),
        "python": sys.version.split()[0],
        "git_revision": revision,
        "written_unix_s": round(time.time(), 1),
    }
    write_atomic(Path(out_dir) / SWEEP_META_FILE, json.dumps(meta, indent=1, default=str) + "\n")


def read_sweep_meta(out_dir: Path) -> dict[str, Any]:
    """``sweep.json`` as a dict (empty when the folder has none)."""
    path = Path(out_dir) / SWEEP_META_FILE
    return json.loads(path.read_text()) if path.is_file() else {}


@contextmanager
def exclusive_folder(out_dir: Path) -> Iterator[None]:
    """Hold ``DIR/.lock`` for the block, so two sweeps never append to one folder at once.

    The lock is an ``flock`` on an open file: the kernel drops it when the holder exits, a ``kill -9``
    included, so a stale lock file never blocks a resumed sweep.

    Raises:
        HarnessError: when another process holds the folder (naming its pid when it wrote one).
    """
    path = Path(out_dir) / LOCK_FILE
    with path.open("a+", encoding="utf-8") as handle:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "?"
            raise HarnessError(f"{out_dir}: another sweep (pid {holder}) is writing this folder") from None
        handle.truncate(0)
        handle.write(f"{os.getpid()}\n")
        handle.flush()
        try:
            yield
        finally:
            handle.truncate(0)
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)
