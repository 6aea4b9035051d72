"""Where episodes run: in this process, in a pool of local processes, or on a Ray cluster.

Each executor takes the tasks to run and an ``accept`` callback, which the sweep uses to write each
row as soon as it comes back (``bench.engine``); the rows are the same whichever executor ran them.

- :func:`run_inline`: one after the other in this process (``workers=0``, for debugging).
- :func:`run_pool`: a ``ProcessPoolExecutor`` with the ``spawn`` start method (MuJoCo's GL contexts and
  torch's thread pools do not survive ``fork``), at most ``workers`` episodes in flight, so a submit
  time is a start time. A worker that does not answer :data:`HARD_KILL_GRACE_S` after its episode's
  own limit (stuck in native code) is killed with its pool, the pool restarted and the other episodes
  in flight started again; a task whose worker died :data:`MAX_WORKER_DEATHS` times is an error row.
- :func:`run_ray`: one-CPU Ray tasks with no automatic retry, at most ``workers`` in flight (0: the
  cluster's CPUs); a task past its limit is cancelled. Ray is imported lazily (``pip install
  -e '.[cluster]'``).
"""

from __future__ import annotations

import multiprocessing
import os
import socket
import sys
import time
import traceback
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from semexp_bt.bench.rows import STATUS_ERROR, STATUS_TIMEOUT, failure_row, keyed_row
from semexp_bt.bench.sweep import EpisodeTask, HarnessError, RunFunction
from semexp_bt.bench.worker import execute_task, limit_native_threads, prepare_pool_worker

#: Extra wall time the parent grants a worker beyond the episode's own limit before killing the pool
#: (process start and imports, the interrupted episode's clean-up).
HARD_KILL_GRACE_S = 90.0
#: A task in flight while its worker process died this many times is recorded as an error.
MAX_WORKER_DEATHS = 3
#: How often the parent wakes to check deadlines (s).
POLL_S = 1.0
#: Ray's environment switch that keeps a loopback address on loopback (see ``_import_ray_for``).
RAY_LOOPBACK_SWITCH = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"
#: How long the harness waits for a Ray head to accept a TCP connection before refusing the address (s).
RAY_CONNECT_TIMEOUT_S = 10.0

#: What an executor hands each row to, as soon as the row comes back.
Accept = Callable[[dict[str, Any]], None]


def run_inline(todo: list[EpisodeTask], *, run_fn: RunFunction, accept: Accept) -> None:
    """Each episode in this process, one after the other."""
    for task in todo:
        accept(execute_task(task, run_fn))


def new_pool(workers: int) -> ProcessPoolExecutor:
    """A pool of ``workers`` spawned processes, each with one BLAS/torch thread."""
    # A worker's OpenBLAS would otherwise start one thread per core, and with one worker per core the
    # workers' BLAS threads compete for the same cores. Spawned children inherit this environment.
    limit_native_threads()
    # spawn, not fork: MuJoCo's GL contexts and torch's thread pools do not survive a fork.
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=prepare_pool_worker)  # fmt: skip


def _kill_pool(pool: ProcessPoolExecutor) -> None:
    """Kill a pool whose worker hangs. ProcessPoolExecutor has no public kill; its process table is a
    CPython detail, so this degrades to a plain shutdown where the table is absent."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        if process.is_alive():
            process.kill()
    pool.shutdown(wait=False, cancel_futures=True)


def run_pool(todo: list[EpisodeTask], *, run_fn: RunFunction, workers: int, accept: Accept) -> None:
    """Local processes, at most ``workers`` episodes in flight (so a submit time is a start time)."""
    queue = list(reversed(todo))  # pop() from the end keeps the grid order
    deaths: dict[str, int] = {}
    pool = new_pool(workers)
    in_flight: dict[Future[dict[str, Any]], tuple[EpisodeTask, float]] = {}
    try:
        while queue or in_flight:
            while queue and len(in_flight) < workers:
                task = queue.pop()
                in_flight[pool.submit(execute_task, task, run_fn)] = (task, time.monotonic())
            done, _ = wait(list(in_flight), timeout=POLL_S, return_when=FIRST_COMPLETED)
            broken = False
            for future in done:
                task, _ = in_flight.pop(future)
                try:
                    accept(future.result())
                except BrokenProcessPool:
                    broken = True
                    deaths[task.key.id] = deaths.get(task.key.id, 0) + 1
                    if deaths[task.key.id] >= MAX_WORKER_DEATHS:
                        accept(keyed_row(failure_row(task, STATUS_ERROR, "worker process died (native crash?) "
                                                     f"{deaths[task.key.id]} times", 0.0), task))  # fmt: skip
                    else:
                        queue.append(task)
            now = time.monotonic()
            overdue = [f for f, (t, t0) in in_flight.items() if now - t0 > t.timeout_s + HARD_KILL_GRACE_S]
            if overdue or broken:
                for future in overdue:
                    task, t0 = in_flight.pop(future)
                    accept(keyed_row(failure_row(task, STATUS_TIMEOUT, "killed by the harness: no answer "
                                                 f"{now - t0:.0f} s after start", now - t0), task))  # fmt: skip
                # Restart the pool; the other episodes in flight start again from scratch.
                queue.extend(t for t, _ in in_flight.values())
                in_flight.clear()
                _kill_pool(pool)
                pool = new_pool(workers)
    finally:
        if in_flight:
            _kill_pool(pool)
        else:
            pool.shutdown(wait=True)


def run_ray(
    todo: list[EpisodeTask], *, run_fn: RunFunction, address: str, workers: int, accept: Accept
) -> None:
    """Ray tasks, one CPU each; ``workers`` caps the episodes in flight (0: the cluster's CPUs).

    Raises:
        HarnessError: when no Ray head answers at ``address`` or Ray is not installed.
    """
    require_ray_head_answers(address)  # seconds cheaper than importing Ray, and it cannot hang
    ray = _import_ray_for(address)
    ray.init(address=address, ignore_reinit_error=True, log_to_driver=False)
    limit = workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
    remote = ray.remote(num_cpus=1, max_retries=0)(execute_task)
    queue = list(reversed(todo))
    in_flight: dict[Any, tuple[EpisodeTask, float]] = {}
    while queue or in_flight:
        while queue and len(in_flight) < limit:
            task = queue.pop()
            in_flight[remote.remote(task, run_fn)] = (task, time.monotonic())
        ready, _ = ray.wait(list(in_flight), num_returns=1, timeout=POLL_S)
        for ref in ready:
            task, t0 = in_flight.pop(ref)
            try:
                accept(ray.get(ref))
            except Exception:  # a dead Ray worker or node: the episode is an error, the sweep goes on
                accept(keyed_row(failure_row(task, STATUS_ERROR, traceback.format_exc(),
                                             time.monotonic() - t0), task))  # fmt: skip
        now = time.monotonic()
        for ref, (task, t0) in list(in_flight.items()):
            if now - t0 > task.timeout_s + HARD_KILL_GRACE_S:
                ray.cancel(ref, force=True)
                in_flight.pop(ref)
                accept(keyed_row(failure_row(task, STATUS_TIMEOUT, f"cancelled by the harness after {now - t0:.0f} s",
                                             now - t0), task))  # fmt: skip


def require_ray_head_answers(address: str, *, timeout_s: float = RAY_CONNECT_TIMEOUT_S) -> None:
    """Refuse a ``host:port`` address where nothing accepts a TCP connection.

    ``ray.init`` retries an unreachable head without end (seen with Ray 2.60), so a mistyped address
    would hang the sweep. ``auto`` and ``ray://`` (Ray Client) addresses are left to Ray.

    Raises:
        HarnessError: naming the address, when the connection is refused or times out.
    """
    if address == "auto" or address.startswith("ray://"):
        return
    host, port = _host_and_port(address)
    if not host or not port.isdigit():
        raise HarnessError(f"--ray-address {address!r}: expected 'auto', 'ray://host:port' or 'host:port'")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout_s):
            pass
    except OSError as exc:
        raise HarnessError(
            f"--ray-address {address}: no Ray head answers there ({exc.strerror or exc}); start one with "
            "'ray start --head' or give the address it printed"
        ) from None


def _host_and_port(address: str) -> tuple[str, str]:
    """``[ray://]host:port`` -> (host without IPv6 brackets, port text)."""
    host, _, port = address.removeprefix("ray://").rpartition(":")
    return host.strip("[]"), port


def _is_loopback(address: str) -> bool:
    return _host_and_port(address)[0] in ("127.0.0.1", "localhost", "::1")


def _import_ray_for(address: str) -> Any:
    """Import Ray so that it can reach ``address``.

    Ray swaps a loopback address for the machine's routable one before it connects, and then waits for a
    head that a loopback-only cluster (docs/harness.md) does not serve there. Its switch for keeping
    loopback, ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``, is read once, when Ray is first imported.
    """
    loopback = _is_loopback(address)
    if loopback and "ray" not in sys.modules:
        os.environ.setdefault(RAY_LOOPBACK_SWITCH, "0")
    try:
        import ray
    except ImportError:
        raise HarnessError(
            "--ray-address needs Ray, which is not installed: pip install -e '.[cluster]'"
        ) from None
    constants = getattr(getattr(ray, "_private", None), "ray_constants", None)
    if loopback and getattr(constants, "ENABLE_RAY_CLUSTER", False):
        raise HarnessError(
            f"--ray-address {address} is on loopback, but Ray was imported before {RAY_LOOPBACK_SWITCH}=0 was "
            "set: set it in the environment, or give the address that 'ray start' printed"
        )
    return ray
