"""Result files written whole or not at all, and JSON-lines logs that a kill cannot corrupt.

A reader of a result file (``report.md``, ``sweep.json``, a benchmark's JSON, a plot) sees either the
previous version or the new one, never half of one, whatever kills the writer (``kill -9``, the OOM
killer, a power cut after the rename is on disk):

- :func:`write_atomic` writes to a temporary file in the same folder, flushes and fsyncs it, renames it
  over the target (``os.replace``, atomic on POSIX within one file system) and fsyncs the folder so
  that the rename itself survives a crash. :func:`atomic_target` does the same for a library that
  writes the file itself (``matplotlib``'s ``savefig``). A writer killed mid-way leaves at most a hidden
  ``.NAME.*.tmp`` file beside the target, never a torn target.
- :class:`JsonLinesAppender` appends one record per line, each line in one ``write`` call followed by
  an fsync, so a record that was appended is on disk and a kill tears at most the last line. On
  opening, it repairs a torn tail left by an earlier kill, so the next record starts on a line of its
  own instead of being glued to the fragment.
- :func:`read_json_lines` reads such a log: a last line that is not JSON is a torn write and is
  reported (``JsonLines.torn_line``), not fatal; a bad line anywhere else is an error naming the file
  and line.

The standard library only (``semexp_bt.core``'s rule), so every layer can use it.

Example:
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = write_atomic(folder / "result.json", '{"sr": 0.5}\\n')
    >>> with JsonLinesAppender(folder / "rows.jsonl") as log:
    ...     log.append({"key": "office/0"})
    >>> read_json_lines(folder / "rows.jsonl").records
    [{'key': 'office/0'}]
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any


class JsonLinesError(ValueError):
    """A JSON-lines file with a line that is neither JSON nor a torn last line."""


def _fsync_folder(folder: Path) -> None:
    """Make a rename or a new file in ``folder`` durable (a no-op where folders cannot be opened)."""
    try:
        handle = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(handle)
    except OSError:
        pass
    finally:
        os.close(handle)


@contextlib.contextmanager
def atomic_target(path: Path | str) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; renamed over ``path`` when the block succeeds.

    The temporary name keeps ``path``'s suffix (libraries such as matplotlib choose the format by it).
    When the block raises, the temporary file is removed and ``path`` is left as it was.

    Args:
        path: the file to (re)place; its folder is created if missing.

    Yields:
        The temporary path.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(
        dir=target.parent, prefix=f".{target.name}.", suffix=f".tmp{target.suffix}"
    )
    os.close(handle)
    temporary = Path(name)
    try:
        yield temporary
        with temporary.open("rb+") as written:
            os.fsync(written.fileno())
        os.replace(temporary, target)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    _fsync_folder(target.parent)


def write_atomic(path: Path | str, content: str | bytes, *, encoding: str = "utf-8") -> Path:
    """Write ``content`` to ``path`` whole or not at all (temporary file, fsync, rename, fsync folder).

    Args:
        path: the file to (re)place; its folder is created if missing.
        content: text (encoded with ``encoding``) or bytes.
        encoding: the text encoding.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.
    """
    data = content.encode(encoding) if isinstance(content, str) else content
    with atomic_target(path) as temporary:
        temporary.write_bytes(data)
    return Path(path)


def write_json(path: Path | str, value: Any, *, indent: int | None = 1) -> Path:
    """Write ``value`` as JSON text (with a final newline) to ``path``, whole or not at all.

    Raises:
        TypeError: for a value JSON cannot encode (``path`` is then left as it was).
    """
    return write_atomic(path, json.dumps(value, indent=indent) + "\n")


@dataclass(frozen=True)
class JsonLines:
    """What :func:`read_json_lines` read.

    Attributes:
        records: the parsed lines, in file order (blank lines skipped).
        line_numbers: the 1-based line number of each record.
        torn_line: the number of a last line that was not JSON (a write cut short), or None.
    """

    records: list[Any]
    line_numbers: list[int]
    torn_line: int | None = None


def read_json_lines(path: Path | str) -> JsonLines:
    """Read a JSON-lines file; a torn last line is reported in the result, not raised.

    Args:
        path: the file (it must exist).

    Raises:
        JsonLinesError: naming the file and line, for a line other than the last that is not JSON or
            not UTF-8.
    """
    path = Path(path)
    lines = path.read_bytes().split(b"\n")
    last = max((i for i, line in enumerate(lines) if line.strip()), default=-1)
    records: list[Any] = []
    numbers: list[int] = []
    torn: int | None = None
    for index, raw in enumerate(lines):
        if not raw.strip():
            continue
        try:
            records.append(json.loads(raw.decode("utf-8")))
            numbers.append(index + 1)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            if index == last:
                torn = index + 1
                continue
            reason = exc.msg if isinstance(exc, json.JSONDecodeError) else "not UTF-8"
            raise JsonLinesError(f"{path}:{index + 1}: not a JSON line ({reason})") from None
    return JsonLines(records=records, line_numbers=numbers, torn_line=torn)


def _json_line(record: Mapping[str, Any], default: Callable[[Any], Any] | None) -> bytes:
    return (json.dumps(record, separators=(",", ":"), default=default) + "\n").encode("utf-8")


class JsonLinesAppender:
    """Appends records to a JSON-lines file, one whole fsynced line each.

    On opening, a last line without its newline (an earlier writer was killed mid-write) is repaired:
    if it is a whole JSON value it gets its newline; otherwise the fragment, which no reader can use,
    is cut off and reported in :attr:`dropped_tail`.

    Args:
        path: the file (created if missing, with its folder).
        default: ``json.dumps``'s ``default`` for values JSON cannot encode.
    """

    def __init__(self, path: Path | str, *, default: Callable[[Any], Any] | None = None) -> None:
        self.path = Path(path)
        self.default = default
        self.path.parent.mkdir(parents=True, exist_ok=True)
        created = not self.path.exists()
        self._handle = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        #: The bytes of a torn last line cut off on opening (empty when there was none).
        self.dropped_tail = b""
        try:
            self._repair_tail()
        except BaseException:
            os.close(self._handle)
            raise
        if created:
            _fsync_folder(self.path.parent)

    def _repair_tail(self) -> None:
        size = os.fstat(self._handle).st_size
        if size == 0:
            return
        with self.path.open("rb") as reader:
            reader.seek(size - 1)
            if reader.read(1) == b"\n":
                return
            reader.seek(0)
            content = reader.read(size)
        start = content.rfind(b"\n") + 1
        tail = content[start:]
        try:
            json.loads(tail.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError):
            os.truncate(self.path, start)
            self.dropped_tail = tail
        else:
            os.write(self._handle, b"\n")
        os.fsync(self._handle)

    def append(self, record: Mapping[str, Any]) -> None:
        """Append ``record`` as one line (one ``write`` call) and fsync it.

        Raises:
            OSError: when the line could not be written whole (the disk is full, ...); the file is then
                cut back to what it held before.
        """
        line = _json_line(record, self.default)
        before = os.fstat(self._handle).st_size
        try:
            written = os.write(self._handle, line)
            if written != len(line):
                raise OSError(f"{self.path}: wrote {written} of {len(line)} bytes of a line")
            os.fsync(self._handle)
        except OSError:
            # Leave no fragment for the next line to be glued to.
            with contextlib.suppress(OSError):
                os.truncate(self.path, before)
            raise

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._handle >= 0:
            os.close(self._handle)
            self._handle = -1

    def __enter__(self) -> JsonLinesAppender:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None
    ) -> None:
        self.close()
