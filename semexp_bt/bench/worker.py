"""Running one episode inside a worker: per-process settings, the wall-time limit, the row it returns.

:func:`execute_task` is what every executor calls (in this process, in a pool worker, in a Ray task):
it runs the task's run function under the episode's wall-time limit and turns whatever happens into a
row; it never raises for a failing episode. The limit is ``SIGALRM``: :class:`EpisodeTimeout` derives
from ``BaseException``, so a broad ``except Exception`` inside an episode cannot swallow it. Code that
ignores the alarm (native code, a blocked signal) is the parent's to kill (``bench.executors``).
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from semexp_bt.app.process_heap import keep_freed_memory
from semexp_bt.bench.rows import STATUS_ERROR, STATUS_TIMEOUT, failure_row, finished_row, keyed_row
from semexp_bt.bench.sweep import EpisodeTask, RunFunction

#: Thread-pool sizes of native libraries, read once when each library loads.
ONE_THREAD_ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
#: How often a pool worker checks that the sweep that started it is still alive (s).
PARENT_CHECK_S = 1.0


class EpisodeTimeout(BaseException):
    """Raised inside a worker when the episode exceeds its wall-time limit."""


def limit_native_threads() -> None:
    """One thread per native library in this process and those it spawns, unless the user chose."""
    for var, value in ONE_THREAD_ENV.items():
        os.environ.setdefault(var, value)


def prepare_worker() -> None:
    """Per-process settings: headless MuJoCo and one BLAS/torch thread (the cores belong to the pool).

    The BLAS variables only take effect in a process that has not loaded numpy yet: a spawned pool worker
    imports numpy before it runs this initializer, so the pool sets them before spawning.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")
    limit_native_threads()
    keep_freed_memory()
    # Model-loading progress bars would interleave with the sweep's own progress lines.
    for var, value in (
        ("TQDM_DISABLE", "1"),
        ("HF_HUB_DISABLE_PROGRESS_BARS", "1"),
        ("TRANSFORMERS_VERBOSITY", "error"),
    ):
        os.environ.setdefault(var, value)
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(1)


def _exit_when_orphaned(parent_pid: int) -> None:
    while True:
        time.sleep(PARENT_CHECK_S)
        if os.getppid() != parent_pid:
            os._exit(1)


def prepare_pool_worker() -> None:
    """:func:`prepare_worker`, and exit when the sweep's process is gone.

    A pool worker whose parent was killed (``kill -9``, the OOM killer) would otherwise finish its
    episode, and one more queued, for nobody: its row can only be written by the parent. It would also
    compete for the cores with the sweep resumed after the kill.
    """
    prepare_worker()
    watcher = threading.Thread(target=_exit_when_orphaned, args=(os.getppid(),), daemon=True,
                               name="exit-when-orphaned")  # fmt: skip
    watcher.start()


def run_real_episode(task: EpisodeTask, **options: Any) -> dict[str, Any]:
    """Run one episode with :func:`semexp_bt.app.episode.run_episode` (the default run function).

    ``options`` are further ``EpisodeOptions`` fields (a benchmark's faults and probes).
    """
    if task.relevance in ("embedding", "hybrid"):
        import torch

        torch.set_num_threads(1)
    from semexp_bt.app.episode import EpisodeOptions, run_episode

    return run_episode(
        EpisodeOptions(
            mission_path=Path(task.mission_path),
            scene=task.key.scene,
            seed=task.key.seed,
            fidelity=task.key.fidelity,
            strategy=task.key.strategy,
            relevance=task.relevance,
            config_overrides=dict(task.config_overrides) or None,
            success_radius_m=task.success_radius_m,
            clearance_m=task.clearance_m,
            max_sim_s=task.max_sim_s,
            keep_trajectory=task.keep_trajectory,
            instruction=task.instruction,
            **options,
        )
    )


@contextmanager
def wall_time_limit(seconds: float) -> Iterator[None]:
    """Raise :class:`EpisodeTimeout` in this thread after ``seconds`` (main thread on POSIX only)."""
    usable = hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()
    if not usable:
        yield
        return

    def _expire(signum: int, frame: Any) -> None:
        raise EpisodeTimeout(f"episode exceeded its wall-time limit of {seconds:.0f} s")

    previous = signal.signal(signal.SIGALRM, _expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def execute_task(task: EpisodeTask, run_fn: RunFunction) -> dict[str, Any]:
    """Run one episode and return its row (never raises for a failing episode)."""
    prepare_worker()
    start = time.perf_counter()
    try:
        with wall_time_limit(task.timeout_s):
            record = run_fn(task)
        row = finished_row(record)
    except EpisodeTimeout as exc:
        row = failure_row(task, STATUS_TIMEOUT, str(exc), time.perf_counter() - start)
    except Exception:
        row = failure_row(task, STATUS_ERROR, traceback.format_exc(), time.perf_counter() - start)
    row["harness_wall_s"] = round(time.perf_counter() - start, 3)
    return keyed_row(row, task)
