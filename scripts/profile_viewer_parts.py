"""Where the browser view's CPU goes: thread CPU time of each part of the view, per simulated second.

Runs the mission of ``scripts/measure_viewer_cost.py`` (same configurations, same ``one_run``) in fresh
processes with a counter of thread CPU time (``time.thread_time``) around each of the functions named in
:data:`PARTS`, and samples the CPU time of every native thread (Rerun's encoder, file writer and gRPC
server are named) from ``/proc``. It prints, for each part, the least CPU time over ``--repeats`` runs
(CPU time on a shared machine only grows with the load) in milliseconds per simulated second. The
parts nest (``record_tick`` holds ``node_entries`` ...); each counter costs about a microsecond a call,
so the small parts called every tick read high. The view's start and end (:data:`WALL_PARTS`) are
counted in wall time, in the same unit: the mission waits for them whole, CPU or not. Rerun's logging
runs in the view's world process (``semexp_bt/app/viewer/world_process.py``), a child whose CPU this
profile does not split into parts (``scripts/measure_viewer_cost.py`` counts it whole).

Usage:
    MUJOCO_GL=egl .venv/bin/python scripts/profile_viewer_parts.py --config view --repeats 3 --sim-s 120
"""

from __future__ import annotations

import argparse
import functools
import importlib
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

from measure_viewer_cost import CONFIGS, ROOT, one_run

#: ``(module, class or "", function, label)``: the parts counted, on whichever thread calls them.
PARTS = (
    (
        "py_trees.blackboard",
        "Client",
        "_generate_activity_item",
        "activity stream: an item per read or write",
    ),
    ("semexp_bt.app.recorder", "TickRecorder", "record_tick", "record: all of it"),
    ("semexp_bt.app.recorder", "TickRecorder", "_drain_activity", "record: writes and their summaries"),
    ("semexp_bt.app.recorder", "TickRecorder", "_node_entries", "record: the nodes' JSON"),
    ("semexp_bt.app.recorder", "TickRecorder", "_stopped_nodes", "record: nodes a parent stopped"),
    (
        "semexp_bt.app.viewer.observer",
        "ViewObserver",
        "_on_tick_record",
        "record: hand-over to feed and file",
    ),
    ("semexp_bt.app.viewer.observer", "ViewObserver", "after_tick", "capture: all of it"),
    ("semexp_bt.app.viewer.capture", "", "map_layer", "capture: the map's copy"),
    ("semexp_bt.app.viewer.observer", "ViewObserver", "_work", "worker: all of it"),
    (
        "semexp_bt.app.viewer.world_process",
        "WorldProcess",
        "flush",
        "worker: batches to the world process",
    ),
    ("semexp_bt.app.viewer.recording", "RecordingWriter", "flush", "worker: ticks.jsonl"),
    ("semexp_bt.app.viewer.observer", "ViewObserver", "_default_sink", "setup: open Rerun's logger"),
    ("semexp_bt.app.viewer.world_process", "WorldProcess", "spawn", "setup: spawn the world process"),
)
#: ``(module, class, function, label)``: parts counted in wall time, not CPU time: the mission waits for
#: them whole, and what they wait for (an import on another thread, the worker's last batch, the page
#: server's shutdown) is no CPU time of theirs.
WALL_PARTS = (
    ("semexp_bt.app.viewer.observer", "ViewObserver", "start", "wall: the view's start (the mission waits)"),
    ("semexp_bt.app.viewer.observer", "ViewObserver", "finish", "wall: the view's end (the mission waits)"),
)
#: How often the native threads' CPU time is read (wall s): they end before the mission returns.
THREAD_SAMPLE_S = 0.2


def _count(
    function: Callable[..., Any], totals: list[float], clock: Callable[[], float] = time.thread_time
) -> Callable[..., Any]:
    @functools.wraps(function)
    def counted(*args: Any, **kwargs: Any) -> Any:
        start = clock()
        try:
            return function(*args, **kwargs)
        finally:
            totals[0] += clock() - start
            totals[1] += 1

    return counted


def _thread_cpu_s() -> dict[int, tuple[str, float]]:
    """CPU time (s) of each of this process's threads by id, with the thread's name."""
    ticks = os.sysconf("SC_CLK_TCK")
    out = {}
    for tid in os.listdir("/proc/self/task"):
        try:
            stat = Path(f"/proc/self/task/{tid}/stat").read_text()
            name = Path(f"/proc/self/task/{tid}/comm").read_text().strip()
        except OSError:
            continue  # the thread ended meanwhile
        fields = stat.rsplit(")", 1)[1].split()
        out[int(tid)] = (name, (int(fields[11]) + int(fields[12])) / ticks)
    return out


def profile_run(config: str, sim_s: float, workdir: Path) -> dict[str, Any]:
    """One mission with the counters in place: each part's CPU s and calls, each native thread's CPU s."""
    totals: dict[str, list[float]] = {}
    for parts, clock in ((PARTS, time.thread_time), (WALL_PARTS, time.perf_counter)):
        for module_name, owner_name, function_name, label in parts:
            module = importlib.import_module(module_name)
            owner = getattr(module, owner_name) if owner_name else module
            totals[label] = [0.0, 0]
            setattr(owner, function_name, _count(getattr(owner, function_name), totals[label], clock))
    seen: dict[int, tuple[str, float]] = {}
    before = _thread_cpu_s()
    stop = threading.Event()

    def sample() -> None:
        while not stop.wait(THREAD_SAMPLE_S):
            seen.update(_thread_cpu_s())

    sampler = threading.Thread(target=sample, name="profile-sampler", daemon=True)
    sampler.start()
    figures = one_run(config, sim_s, workdir)
    stop.set()
    sampler.join()
    seen.update(_thread_cpu_s())
    native: dict[str, float] = defaultdict(float)
    for tid, (name, cpu_s) in seen.items():
        if name != "python":  # Python's threads are all "python"; the parts above count them
            native[name] += cpu_s - before.get(tid, (name, 0.0))[1]
    return {"figures": figures, "parts": totals, "native": dict(native)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default="view", choices=CONFIGS)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sim-s", type=float, default=120.0, help="robot time per mission (s)")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        with tempfile.TemporaryDirectory() as tmp:
            print(json.dumps(profile_run(args.config, args.sim_s, Path(tmp))))
        return 0
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    runs = []
    for _ in range(args.repeats):
        answer = subprocess.run(
            [sys.executable, __file__, "--child", "--config", args.config, "--sim-s", str(args.sim_s)],
            capture_output=True, text=True, env=env, cwd=ROOT, check=True,
        )  # fmt: skip
        runs.append(json.loads(answer.stdout.strip().splitlines()[-1]))
    sim_s = runs[0]["figures"]["sim_s"]
    print(f"{args.config}: {sim_s:.1f} s simulated; least of {args.repeats} runs")
    print("| part | CPU ms per sim s | calls |")
    print("| --- | --- | --- |")
    for _, _, _, label in (*PARTS, *WALL_PARTS):
        cpu_s = min(run["parts"][label][0] for run in runs)
        if cpu_s > 0.0:
            print(f"| {label} | {1e3 * cpu_s / sim_s:.2f} | {runs[0]['parts'][label][1]:.0f} |")
    for name in sorted({name for run in runs for name in run["native"]}):
        cpu_s = min(run["native"].get(name, 0.0) for run in runs)
        if cpu_s > 0.0:
            print(f"| native thread {name} | {1e3 * cpu_s / sim_s:.2f} | |")
    total = min(run["figures"]["cpu_per_sim_s"] for run in runs)
    print(f"| the whole process | {1e3 * total:.2f} | |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
