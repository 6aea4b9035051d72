"""A sweep killed with SIGKILL and resumed loses no finished episode and runs none twice (issue #22).

A real sweep runs in a subprocess with a fast fake run function (module-level, so spawned pool workers
import it by name) that logs every episode it starts; the test kills the sweep's process mid-run, as
``kill -9`` or the OOM killer would, resumes the same grid, and checks the rows and the start logs.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from semexp_bt.bench.engine import run_sweep
from semexp_bt.bench.store import (
    EPISODES_FILE,
    INVOCATIONS_FILE,
    exclusive_folder,
    load_invocations,
    load_rows,
)
from semexp_bt.bench.sweep import EpisodeTask, HarnessError, SweepSpec
from tests.test_harness import fake_record

REPO = Path(__file__).resolve().parents[1]
#: Where the fake run function logs ``pid key`` for every episode it starts.
START_LOG_ENV = "SEMEXP_TEST_START_LOG"
#: How long one fake episode takes (s); the long one outlives any test.
EPISODE_S = float(os.environ.get("SEMEXP_TEST_EPISODE_S", "0.1"))
#: Rows the first sweep must have written before it is killed.
KILL_AFTER_ROWS = 6

SWEEPER = """
import sys
from pathlib import Path
from semexp_bt.bench.engine import run_sweep
from tests.test_sweep_kill import grid, logged_run
run_sweep(grid(), Path(sys.argv[1]), run_fn=logged_run, workers=int(sys.argv[2]), progress=None,
          check_names=False)
"""


def grid() -> SweepSpec:
    """30 episodes: two scenes x 15 seeds x one strategy."""
    return SweepSpec(
        scenes=("alpha", "beta"), seeds=tuple(range(15)), strategies=("ours",), relevance="lexical"
    )


def logged_run(task: EpisodeTask) -> dict[str, Any]:
    """Log the start (one append, so lines of two workers never mix), take EPISODE_S, return a record."""
    handle = os.open(os.environ[START_LOG_ENV], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(handle, f"{os.getpid()} {task.key.id}\n".encode())
    finally:
        os.close(handle)
    time.sleep(EPISODE_S)
    return fake_record(task)


def _starts(log: Path) -> list[tuple[int, str]]:
    if not log.is_file():
        return []
    return [(int(pid), key) for pid, key in (line.split(" ", 1) for line in log.read_text().splitlines())]


def _start_sweep(out: Path, workers: int, log: Path, **env: str) -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, "-c", SWEEPER, str(out), str(workers)], cwd=REPO,
                            env={**os.environ, START_LOG_ENV: str(log), **env})  # fmt: skip


def _wait_for(condition: Any, *, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


def _row_lines(out: Path) -> int:
    path = out / EPISODES_FILE
    return path.read_bytes().count(b"\n") if path.is_file() else 0


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # A zombie (dead, not reaped) counts as gone.
    stat = Path(f"/proc/{pid}/stat")
    return not (stat.is_file() and stat.read_text().split(")")[-1].split()[0] == "Z")


@pytest.mark.parametrize("workers", [0, 2], ids=["in-process", "pool"])
def test_a_sweep_killed_mid_run_and_resumed_loses_nothing_and_runs_nothing_twice(
    tmp_path: Path, workers: int
) -> None:
    out, first_log, resumed_log = tmp_path / "sweep", tmp_path / "starts_1.log", tmp_path / "starts_2.log"
    total = len(grid().tasks())
    sweep = _start_sweep(out, workers, first_log)
    try:
        _wait_for(lambda: _row_lines(out) >= KILL_AFTER_ROWS, timeout_s=120, what="the first rows")
        sweep.send_signal(signal.SIGKILL)
        sweep.wait(timeout=30)
    finally:
        if sweep.poll() is None:
            sweep.kill()
    assert sweep.returncode == -signal.SIGKILL
    finished = {row["key"] for row in load_rows(out)}
    started_before = _starts(first_log)
    print(f"killed with {len(finished)} of {total} rows written, {len(started_before)} episodes started")
    assert KILL_AFTER_ROWS <= len(finished) < total, "the kill did not land mid-run"
    assert not (out / INVOCATIONS_FILE).exists()  # a kill -9 logs no invocation: nothing ran its finally
    # Orphaned pool workers end (they would otherwise finish episodes no one will write).
    worker_pids = {pid for pid, _ in started_before} - {sweep.pid}
    _wait_for(lambda: not any(_alive(pid) for pid in worker_pids), timeout_s=20, what="the orphaned workers")

    resumed = _start_sweep(out, workers, resumed_log)
    assert resumed.wait(timeout=300) == 0
    rows = [json.loads(line) for line in (out / EPISODES_FILE).read_text().splitlines()]
    counts = Counter(row["key"] for row in rows)
    assert set(counts) == {t.key.id for t in grid().tasks()}
    assert max(counts.values()) == 1, [key for key, n in counts.items() if n > 1]
    rerun = {key for _, key in _starts(resumed_log)}
    assert not rerun & finished, "a finished episode ran again"
    assert rerun == set(counts) - finished  # the rest, the episodes in flight at the kill included
    (log,) = load_invocations(out)
    assert (log["ran"], log["skipped"], log["completed"]) == (total - len(finished), len(finished), True)


def test_pool_workers_exit_when_the_sweep_is_killed(tmp_path: Path) -> None:
    """A worker busy in a 10-minute episode ends within seconds of its sweep's SIGKILL."""
    out, log = tmp_path / "sweep", tmp_path / "starts.log"
    sweep = _start_sweep(out, 2, log, SEMEXP_TEST_EPISODE_S="600")
    try:
        _wait_for(lambda: len(_starts(log)) >= 2, timeout_s=120, what="two episodes to start")
        sweep.send_signal(signal.SIGKILL)
        sweep.wait(timeout=30)
    finally:
        if sweep.poll() is None:
            sweep.kill()
    pids = {pid for pid, _ in _starts(log)}
    try:
        _wait_for(lambda: not any(_alive(pid) for pid in pids), timeout_s=20, what="the orphaned workers")
    finally:
        for pid in pids:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


def test_a_second_sweep_on_a_folder_in_use_is_refused(tmp_path: Path) -> None:
    with (
        exclusive_folder(tmp_path),
        pytest.raises(HarnessError, match=f"another sweep \\(pid {os.getpid()}\\)"),
    ):
        run_sweep(grid(), tmp_path, run_fn=logged_run, workers=0, progress=None, check_names=False)
    assert not (tmp_path / EPISODES_FILE).exists()
