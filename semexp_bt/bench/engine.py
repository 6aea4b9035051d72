"""The sweep: run every episode of a grid that its folder does not hold yet, and keep each row.

:func:`run_sweep` reads the rows already in ``DIR`` (``bench.store``), skips every key that has one
(``retry_failed`` reruns the ``error`` and ``timeout`` keys; the newest row of a key wins), runs the
rest on an executor (``bench.executors``) and writes each row the moment it comes back, so a sweep
stopped in any way, ``kill -9`` included, loses only the episodes in flight and a resumed one runs no
finished episode again. Each call appends its wall time, counts and code revision to
``DIR/invocations.jsonl``, also when it is stopped by an exception (Ctrl-C, or SIGTERM, which the CLI
turns into one), so a sweep resumed over several invocations still has a total wall time.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from semexp_bt.bench.executors import run_inline, run_pool, run_ray
from semexp_bt.bench.progress import Progress
from semexp_bt.bench.rows import STATUS_ERROR, STATUS_OK, STATUS_TIMEOUT
from semexp_bt.bench.store import RowWriter, exclusive_folder, load_rows, log_invocation, write_sweep_meta
from semexp_bt.bench.sweep import HarnessError, RunFunction, SweepSpec, unique_tasks, validate_names
from semexp_bt.bench.worker import run_real_episode


@dataclass
class SweepResult:
    """What a sweep did.

    Attributes:
        out_dir: the output folder.
        total: episodes in the grid.
        skipped: episodes that already had a row.
        ran: episodes run now.
        errors: of those, rows with status ``error``.
        timeouts: of those, rows with status ``timeout``.
        wall_s: wall time of this call.
    """

    out_dir: Path
    total: int
    skipped: int
    ran: int = 0
    errors: int = 0
    timeouts: int = 0
    wall_s: float = 0.0


def git_revision() -> str | None:
    """``git describe --always --dirty`` of the checkout this code runs from, or None outside one."""
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=Path(__file__).resolve().parents[2],
                             capture_output=True, text=True, timeout=10)  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


def run_sweep(
    spec: SweepSpec | Sequence[SweepSpec],
    out_dir: Path,
    *,
    workers: int = 1,
    run_fn: RunFunction = run_real_episode,
    ray_address: str | None = None,
    retry_failed: bool = False,
    progress: TextIO | None = sys.stderr,
    check_names: bool = True,
) -> SweepResult:
    """Run every episode of ``spec`` that ``out_dir`` does not hold yet.

    Args:
        spec: the grid, or several grids run as one (episodes with the same key run once).
        out_dir: output folder (created); rows go to ``episodes.jsonl``.
        workers: parallel worker processes (0: run in this process, for debugging).
        run_fn: runs one episode; a module-level function (picklable by name).
        ray_address: run on a Ray cluster (``auto`` or ``ray://host:10001``) instead of local processes.
        retry_failed: rerun keys whose row is ``error`` or ``timeout``.
        progress: where progress lines and warnings go (None: silent, warnings to stderr).
        check_names: validate scene and strategy names against the catalogues first.

    Returns:
        A :class:`SweepResult`.

    Raises:
        HarnessError: on unknown names, a negative worker count, Ray missing, a damaged
            ``episodes.jsonl`` line (other than a torn last one), or another sweep writing ``out_dir``.
    """
    if workers < 0:
        raise HarnessError(f"workers must be >= 0, got {workers}")
    specs = [spec] if isinstance(spec, SweepSpec) else list(spec)
    if not specs:
        raise HarnessError("run_sweep: no sweep given")
    if check_names:
        for one in specs:
            validate_names(one)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with exclusive_folder(out_dir):
        return _run_locked(specs, out_dir, workers=workers, run_fn=run_fn, ray_address=ray_address,
                           retry_failed=retry_failed, progress=progress)  # fmt: skip


def _run_locked(specs: list[SweepSpec], out_dir: Path, *, workers: int, run_fn: RunFunction,
                ray_address: str | None, retry_failed: bool, progress: TextIO | None) -> SweepResult:  # fmt: skip
    started = time.monotonic()
    tasks = unique_tasks(specs)
    existing = {row["key"]: row for row in load_rows(out_dir, stream=progress)}
    todo = [
        t for t in tasks
        if t.key.id not in existing or (retry_failed and existing[t.key.id].get("status") != STATUS_OK)
    ]  # fmt: skip
    result = SweepResult(out_dir=out_dir, total=len(tasks), skipped=len(tasks) - len(todo))
    revision = git_revision()
    write_sweep_meta(out_dir, specs, workers=workers, ray_address=ray_address, revision=revision)
    if progress is not None:
        print(f"[sweep] {len(tasks)} episodes, {result.skipped} already done, {len(todo)} to run"
              f" on {'ray ' + ray_address if ray_address else f'{workers} worker(s)'} -> {out_dir}",
              file=progress, flush=True)  # fmt: skip
    meter = Progress(total=len(tasks), already_done=result.skipped, stream=progress)
    writer = RowWriter(out_dir, stream=progress)

    def accept(row: dict[str, Any]) -> None:
        writer.write(row)
        meter.update(row)
        result.ran += 1
        result.errors += row["status"] == STATUS_ERROR
        result.timeouts += row["status"] == STATUS_TIMEOUT

    started_unix_s = time.time()
    completed = False
    try:
        if not todo:
            pass
        elif ray_address is not None:
            run_ray(todo, run_fn=run_fn, address=ray_address, workers=workers, accept=accept)
        elif workers == 0:
            run_inline(todo, run_fn=run_fn, accept=accept)
        else:
            run_pool(todo, run_fn=run_fn, workers=workers, accept=accept)
        completed = True
    finally:
        writer.close()
        result.wall_s = time.monotonic() - started
        # Also on Ctrl-C or SIGTERM (the CLI turns it into an exception): a stopped invocation's wall
        # time still counts towards the sweep's.
        log_invocation(out_dir, {
            "started_unix_s": round(started_unix_s, 1),
            "wall_s": round(result.wall_s, 1),
            "ran": result.ran,
            "skipped": result.skipped,
            "total": result.total,
            "errors": result.errors,
            "timeouts": result.timeouts,
            "workers": workers,
            "ray_address": ray_address,
            "completed": completed,
            "git_revision": revision,
        }, stream=progress)  # fmt: skip
    return result
