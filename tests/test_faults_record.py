"""Nothing lost: a mission killed with SIGKILL leaves its per-tick record readable up to its last whole tick,
and ``semexp-bt replay`` skips a torn last line and says so."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from semexp_bt.app.recorder import RecordError, read_ticks

REPO = Path(__file__).resolve().parents[1]


def replay(path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "semexp_bt", "replay", str(path), *args],
        cwd=REPO, capture_output=True, text=True, timeout=120,
    )  # fmt: skip


def test_a_mission_killed_with_sigkill_replays_up_to_its_last_whole_tick(tmp_path: Path) -> None:
    record = tmp_path / "ticks.jsonl"
    mission = subprocess.Popen(
        [sys.executable, "-m", "semexp_bt", "run", "trees/object_search.yaml", "--scene", "office", "--seed", "0",
         "--relevance", "lexical", "--record", str(record)],
        cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 300.0
        while time.monotonic() < deadline and mission.poll() is None:
            if record.exists() and record.stat().st_size > 400_000:  # a few hundred ticks
                break
            time.sleep(0.2)
        assert mission.poll() is None, "the mission ended before it could be killed"
        os.kill(mission.pid, signal.SIGKILL)
        mission.wait(timeout=60)
    finally:
        if mission.poll() is None:
            mission.kill()
            mission.wait()
    assert mission.returncode == -signal.SIGKILL
    torn: list[int] = []
    ticks = [r["tick"] for r in read_ticks(record, torn=torn)]
    assert len(ticks) > 100 and ticks == list(range(1, len(ticks) + 1))
    done = replay(record)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == f"{len(ticks)} ticks"

    # A kill during a write (or a power cut) can tear the last line: it is skipped, and replay says so.
    with record.open("ab") as handle:
        handle.write(b'{"tick": 99999, "stamp_s": 1.0, "nod')
    torn_run = replay(record)
    assert torn_run.returncode == 0, torn_run.stderr
    lines = torn_run.stdout.splitlines()
    assert lines[-1] == f"{len(ticks)} ticks"
    assert (
        lines[-2] == f"line {len(ticks) + 1}: a torn tick (the mission was killed while writing it), skipped"
    )


def test_a_damaged_line_before_the_last_is_an_error_naming_the_file_and_line(tmp_path: Path) -> None:
    record = tmp_path / "ticks.jsonl"
    tick = {"tick": 1, "stamp_s": 0.0, "nodes": {}, "writes": []}
    record.write_text(json.dumps(tick) + "\nnot json\n" + json.dumps({**tick, "tick": 2}) + "\n")
    with pytest.raises(RecordError, match=r"ticks.jsonl:2: not a JSON tick record"):
        list(read_ticks(record, torn=[]))
    done = replay(record)
    assert done.returncode == 2
    assert done.stderr.strip() == f"error: {record}:2: not a JSON tick record (Expecting value)"
    missing = replay(tmp_path / "missing.jsonl")
    assert missing.returncode == 2 and "cannot read the record" in missing.stderr
