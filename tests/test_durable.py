"""Files written whole or not at all, and JSON-lines logs a kill cannot corrupt (``semexp_bt.core.durable``).

The kill tests run a real writer in a subprocess and stop it with SIGKILL at fixed delays (chosen before
any run), then read what it left.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from semexp_bt.core import durable
from semexp_bt.core.durable import (
    JsonLinesAppender,
    JsonLinesError,
    atomic_target,
    read_json_lines,
    write_atomic,
    write_json,
)

REPO = Path(__file__).resolve().parents[1]
#: Delays (s) after the writer's first write at which it is killed.
KILL_DELAYS_S = (0.05, 0.13, 0.21, 0.34)


def _kill_writer(code: str, delay_s: float, *args: str) -> None:
    """Run ``code`` in a subprocess and SIGKILL it ``delay_s`` after it prints ``started``."""
    writer = subprocess.Popen([sys.executable, "-c", code, *args], cwd=REPO, stdout=subprocess.PIPE)
    assert writer.stdout is not None
    assert writer.stdout.readline().strip() == b"started", "the writer did not start"
    time.sleep(delay_s)
    writer.send_signal(signal.SIGKILL)
    writer.wait(timeout=30)
    assert writer.returncode == -signal.SIGKILL


def test_write_atomic_replaces_the_file_and_leaves_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "deep" / "report.md"
    write_atomic(target, "old\n")
    write_atomic(target, b"new\n")
    assert target.read_text() == "new\n"
    assert sorted(p.name for p in target.parent.iterdir()) == ["report.md"]
    write_json(tmp_path / "figures.json", {"sr": 0.5})
    assert json.loads((tmp_path / "figures.json").read_text()) == {"sr": 0.5}


def test_a_failed_write_leaves_the_old_file_whole(tmp_path: Path) -> None:
    target = tmp_path / "sweep.json"
    write_atomic(target, '{"old": true}\n')
    with pytest.raises(TypeError):
        write_json(target, {"bad": object()})
    with pytest.raises(RuntimeError), atomic_target(target) as temporary:
        temporary.write_text('{"half": ')
        raise RuntimeError("the writer failed half-way")
    assert target.read_text() == '{"old": true}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.json"]


def test_atomic_target_keeps_the_suffix_for_libraries_that_choose_a_format_by_it(tmp_path: Path) -> None:
    with atomic_target(tmp_path / "bars_sr.png") as temporary:
        assert temporary.suffix == ".png" and temporary.parent == tmp_path
        temporary.write_bytes(b"\x89PNG")
    assert (tmp_path / "bars_sr.png").read_bytes() == b"\x89PNG"


WHOLE_FILE_WRITER = """
import sys
from semexp_bt.core.durable import write_atomic
target, size = sys.argv[1], int(sys.argv[2])
for i in range(100000):
    write_atomic(target, (b"ABCDEFGH"[i % 8:i % 8 + 1]) * size)
    if i == 0:
        print("started", flush=True)
"""


@pytest.mark.parametrize("delay_s", KILL_DELAYS_S)
def test_a_file_rewritten_by_a_killed_writer_is_always_one_whole_version(
    tmp_path: Path, delay_s: float
) -> None:
    target, size = tmp_path / "report.md", 2_000_000
    _kill_writer(WHOLE_FILE_WRITER, delay_s, str(target), str(size))
    content = target.read_bytes()
    print(f"killed after {delay_s} s: {len(content)} bytes of {content[:1]!r}")
    assert len(content) == size and content == content[:1] * size


LINE_WRITER = """
import sys
from semexp_bt.core.durable import JsonLinesAppender
with JsonLinesAppender(sys.argv[1]) as log:
    for i in range(100000):
        log.append({"n": i, "payload": "x" * 5000})
        if i == 0:
            print("started", flush=True)
"""


@pytest.mark.parametrize("delay_s", KILL_DELAYS_S)
def test_a_killed_appender_leaves_whole_lines_and_the_next_one_continues_cleanly(
    tmp_path: Path, delay_s: float
) -> None:
    path = tmp_path / "episodes.jsonl"
    _kill_writer(LINE_WRITER, delay_s, str(path))
    lines = read_json_lines(path)
    numbers = [record["n"] for record in lines.records]
    print(f"killed after {delay_s} s: {len(numbers)} whole lines, torn line: {lines.torn_line}")
    assert numbers == list(range(len(numbers))) and numbers
    with JsonLinesAppender(path) as log:
        log.append({"n": -1})
    again = read_json_lines(path)
    assert again.torn_line is None
    assert [record["n"] for record in again.records] == numbers + [-1]


def test_a_torn_tail_is_cut_off_and_a_whole_one_gets_its_newline(tmp_path: Path) -> None:
    path = tmp_path / "rows.jsonl"
    path.write_bytes(b'{"n": 0}\n{"n": 1, "pay')
    with JsonLinesAppender(path) as log:
        assert log.dropped_tail == b'{"n": 1, "pay'
        log.append({"n": 2})
    assert path.read_bytes() == b'{"n": 0}\n{"n":2}\n'
    path.write_bytes(b'{"n": 0}\n{"n": 1}')  # whole, only its newline missing (edited by hand)
    with JsonLinesAppender(path) as log:
        assert log.dropped_tail == b""
        log.append({"n": 2})
    assert [r["n"] for r in read_json_lines(path).records] == [0, 1, 2]


def test_a_short_write_is_cut_back_so_no_fragment_is_left(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "rows.jsonl"
    log = JsonLinesAppender(path)
    log.append({"n": 0})
    real_write = os.write
    monkeypatch.setattr(durable.os, "write", lambda fd, data: real_write(fd, data[: len(data) // 2]))
    with pytest.raises(OSError, match="wrote .* of .* bytes"):
        log.append({"n": 1, "payload": "x" * 100})
    monkeypatch.undo()
    log.append({"n": 2})
    log.close()
    assert path.read_bytes() == b'{"n":0}\n{"n":2}\n'


def test_the_reader_reports_a_torn_last_line_and_refuses_damage_elsewhere(tmp_path: Path) -> None:
    path = tmp_path / "rows.jsonl"
    path.write_bytes(b'{"n": 0}\n\n{"n": 1}\n{"n": 2, "x"')
    lines = read_json_lines(path)
    assert lines.records == [{"n": 0}, {"n": 1}] and lines.line_numbers == [1, 3] and lines.torn_line == 4
    path.write_bytes(b'{"n": 0}\n{"n": \n{"n": 2}\n')
    with pytest.raises(JsonLinesError, match=r"rows\.jsonl:2: not a JSON line"):
        read_json_lines(path)
    path.write_bytes(b'{"n": "\xff"}\n{"n": 2}\n')
    with pytest.raises(JsonLinesError, match=r"rows\.jsonl:1: not a JSON line \(not UTF-8\)"):
        read_json_lines(path)
