"""``semexp-bt bench soak``: back-to-back missions in one process for a simulated hour, watched for growth.

A robot that runs all day runs its missions in one process. The soak runs simulated episodes
(``semexp_bt.app.episode.run_episode``, MuJoCo, the emulator, the embedding scorer) one after another,
cycling through :data:`DEFAULT_SCENES` with rising seeds, until :data:`DEFAULT_SIM_S` of robot time
have passed. After each mission (a garbage collection, then :func:`~semexp_bt.app.process_heap.release_free_heap`) it records the
process's resident memory (and what it was before the trim), the topological memory's size at the
mission's end, the mission's tick median and p99, the py_trees blackboard's size and the live objects of
the kinds a leak would pile up (:func:`watched_types`).

Floors: resident memory after the last mission within :data:`MAX_RSS_GROWTH` of what it was after the first
mission (the first mission loads the models and builds the caches a process keeps), and the tick p99 not
rising: after the hour the soak runs its first mission once more, and that run's p99 must lie within
:data:`P99_TOLERANCE` of the first run's. The same episode at both ends, because a mission's p99 is its
planner's largest replanning tick, which depends on the area that mission explored: the first and last
thirds of the missions (still reported) differ by what their scenes cost, not by what the process
accumulated. The p99 read is the tick's CPU time on the executive's thread (``tick_cpu_ms``): work that
piles up in the process raises it, while the wall-clock p99, also reported, on a shared machine measures
the scheduler as much as the tree. The repeat also says whether the episode ran the same (outcome, ticks,
path) at both ends of the process.
"""

from __future__ import annotations

import gc
import os
import statistics
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TextIO

import py_trees

from semexp_bt.app.components import DEFAULT_RELEVANCE
from semexp_bt.app.process_heap import release_free_heap
from semexp_bt.app.runner import MissionRun

DEFAULT_SCENES = ("office", "living_room", "laboratory")
#: Robot time the soak runs for (s): one simulated hour.
DEFAULT_SIM_S = 3600.0
#: Resident memory may grow this much (a fraction) after the first mission.
MAX_RSS_GROWTH = 0.05
#: The first mission run again at the end may have a tick p99 (CPU) this fraction above its first run.
P99_TOLERANCE = 0.2


def resident_bytes() -> int:
    """This process's resident set size (Linux ``/proc/self/statm``; 0 where it cannot be read)."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
    except (OSError, IndexError, ValueError):
        return 0
    return pages * os.sysconf("SC_PAGE_SIZE")


def watched_types() -> dict[str, type]:
    """What a leak would pile up, by name: behaviours, memories, cameras, simulated robots (each robot
    holds its MuJoCo model and data, which the garbage collector does not track itself)."""
    from robots.camera import RgbdCamera
    from robots.mujoco_backend import MujocoRobot
    from semexp_bt.core.memory import TopologicalMemory

    return {
        "behaviours": py_trees.behaviour.Behaviour,
        "topological memories": TopologicalMemory,
        "cameras": RgbdCamera,
        "MuJoCo robots": MujocoRobot,
    }


def live_objects() -> dict[str, int]:
    """How many objects of each :func:`watched_types` kind (or a subclass) are alive.

    It reads each object's real type (``type(obj)``), never ``isinstance``: ``isinstance`` asks an object
    for its ``__class__``, which lazy modules and proxies answer by importing (torch's deprecated
    attributes, transformers' lazy modules), so the count itself loaded some 30 MB of modules into the
    process and showed up as the soak's resident-memory step after the first mission.
    """
    kinds = watched_types()
    counts = dict.fromkeys(kinds, 0)
    classes = tuple(kinds.values())
    for obj in gc.get_objects():
        kind = type(obj)
        if issubclass(kind, classes):
            for name, klass in kinds.items():
                if issubclass(kind, klass):
                    counts[name] += 1
    return counts


class MemoryProbe:
    """A tick observer that keeps the size of the topological memory when the mission ends."""

    wants_activity_stream = False

    def __init__(self) -> None:
        self.nodes = 0
        self.edges = 0

    def start(self, run: MissionRun) -> None:
        pass

    def after_tick(self, run: MissionRun) -> None:
        pass

    def finish(self, run: MissionRun, outcome: str) -> None:
        memory = run.board.memory
        self.nodes, self.edges = len(memory), memory.graph.number_of_edges()


def run_soak(
    *,
    sim_s: float = DEFAULT_SIM_S,
    scenes: Sequence[str] = DEFAULT_SCENES,
    relevance: str = DEFAULT_RELEVANCE,
    mission_path: Path | None = None,
    max_missions: int | None = None,
    progress: TextIO | None = sys.stderr,
) -> dict[str, Any]:
    """Run missions back to back until ``sim_s`` of robot time (or ``max_missions``) and measure.

    Returns:
        ``missions`` (one entry per mission), ``start`` and ``end`` (the first and last mission's
        figures), ``floors`` and ``floors_met``.
    """
    from semexp_bt.bench.sweep import default_mission_path

    if relevance in ("embedding", "hybrid"):
        import torch

        torch.set_num_threads(1)
    mission = mission_path or default_mission_path()
    missions: list[dict[str, Any]] = []
    elapsed_s = 0.0
    started = time.perf_counter()
    index = 0
    # The soak's missions, then the first one again: the same episode at the start and at the end of the
    # process is the tick p99 a growth would raise, whatever the scenes in between cost.
    while elapsed_s < sim_s and (max_missions is None or index < max_missions):
        episode = (scenes[index % len(scenes)], index // len(scenes), None)
        elapsed_s += _run_one(episode, index, missions, mission, relevance, started, progress)
        index += 1
    if missions:
        first = missions[0]
        _run_one((first["scene"], first["seed"], 0), index, missions, mission, relevance, started, progress)
    return summarise(missions)


def _run_one(
    episode: tuple[str, int, int | None],
    index: int,
    missions: list[dict[str, Any]],
    mission: Path,
    relevance: str,
    started: float,
    progress: TextIO | None,
) -> float:
    """Run one soak mission (``(scene, seed, repeat_of)``), append its entry; the robot time it took."""
    from semexp_bt.app.episode import EpisodeOptions, run_episode

    scene, seed, repeat_of = episode
    probe = MemoryProbe()
    record = run_episode(
        EpisodeOptions(
            mission_path=mission,
            scene=scene,
            seed=seed,
            relevance=relevance,
            observers=[probe],
            measure_tick_cpu=True,
        )
    )
    del record["events"], record["decisions"]
    gc.collect()
    # Counted before the memory is read, so the count's own footprint (gc.get_objects' list of every
    # object) is in every mission's figure from the first on, not a step after it.
    alive = live_objects()
    held_mb = round(resident_bytes() / 2**20, 1)
    release_free_heap()
    sim_total_s = (missions[-1]["sim_total_s"] if missions else 0.0) + float(record["sim_time_s"])
    entry = {
        "mission": index,
        "scene": scene,
        "seed": seed,
        "repeat_of": repeat_of,
        "outcome": record["outcome"],
        "sim_time_s": round(float(record["sim_time_s"]), 1),
        "sim_total_s": round(sim_total_s, 1),
        "ticks": record["ticks"],
        "path_length_m": record["path_length_m"],
        "tick_median_ms": round(record["tick_wall_ms"]["median"], 3),
        "tick_p99_ms": round(record["tick_wall_ms"]["p99"], 3),
        "tick_cpu_median_ms": round(record["tick_cpu_ms"]["median"], 3),
        "tick_cpu_p99_ms": round(record["tick_cpu_ms"]["p99"], 3),
        "memory_nodes": probe.nodes,
        "memory_edges": probe.edges,
        "rss_mb": round(resident_bytes() / 2**20, 1),
        "rss_before_trim_mb": held_mb,
        "blackboard_keys": len(py_trees.blackboard.Blackboard.storage),
        "live_objects": alive,
        "wall_s": round(time.perf_counter() - started, 1),
    }
    missions.append(entry)
    if progress is not None:
        again = "" if repeat_of is None else f" (mission {repeat_of} again)"
        print(f"[soak] mission {index + 1}{again}: {scene}/{seed} {entry['outcome']}, sim {sim_total_s / 60:.1f} min, "
              f"rss {entry['rss_mb']} MB ({held_mb} MB before the trim), tick p99 {entry['tick_cpu_p99_ms']} ms CPU "
              f"({entry['tick_p99_ms']} ms wall), memory {probe.nodes} nodes",
              file=progress, flush=True)  # fmt: skip
    return float(record["sim_time_s"])


def summarise(missions: list[dict[str, Any]]) -> dict[str, Any]:
    """Start and end figures and the floors (see the module docstring)."""
    if not missions:
        return {"missions": [], "floors": {}, "floors_met": False}
    first, last = missions[0], missions[-1]
    repeat = next((m for m in missions if m.get("repeat_of") == 0), None)
    third = max(1, len(missions) // 3)
    p99_start = statistics.median(m["tick_cpu_p99_ms"] for m in missions[:third])
    p99_end = statistics.median(m["tick_cpu_p99_ms"] for m in missions[-third:])
    wall_p99_start = statistics.median(m["tick_p99_ms"] for m in missions[:third])
    wall_p99_end = statistics.median(m["tick_p99_ms"] for m in missions[-third:])
    growth = last["rss_mb"] / first["rss_mb"] - 1.0 if first["rss_mb"] > 0 else float("nan")
    # Each scene's first mission builds what that scene needs for the first time (its MuJoCo model, its
    # maps at that scene's size); growth after every scene has run once is the figure a leak would show.
    round_end = missions[min(len({m["scene"] for m in missions}), len(missions)) - 1]
    round_growth = last["rss_mb"] / round_end["rss_mb"] - 1.0 if round_end["rss_mb"] > 0 else float("nan")
    floors = {
        f"resident memory grows under {MAX_RSS_GROWTH:.0%} after the first mission": bool(
            growth < MAX_RSS_GROWTH
        ),
        f"tick p99 (CPU) not rising (the first mission run again within {P99_TOLERANCE:.0%} of its first run)": bool(
            repeat is not None
            and repeat["tick_cpu_p99_ms"] <= first["tick_cpu_p99_ms"] * (1.0 + P99_TOLERANCE)
        ),
    }
    return {
        "missions": missions,
        "sim_hours": round(last["sim_total_s"] / 3600.0, 3),
        "start": {
            "rss_mb": first["rss_mb"],
            "tick_cpu_p99_ms": p99_start,
            "tick_p99_ms": wall_p99_start,
            "memory_nodes": first["memory_nodes"],
        },
        "end": {
            "rss_mb": last["rss_mb"],
            "tick_cpu_p99_ms": p99_end,
            "tick_p99_ms": wall_p99_end,
            "memory_nodes": last["memory_nodes"],
        },
        "repeat": None
        if repeat is None
        else {
            "tick_cpu_p99_ms": repeat["tick_cpu_p99_ms"],
            "first_tick_cpu_p99_ms": first["tick_cpu_p99_ms"],
            "same_episode": (repeat["outcome"], repeat["ticks"], repeat.get("path_length_m"))
            == (first["outcome"], first["ticks"], first.get("path_length_m")),
        },
        "rss_growth": round(growth, 4),
        "rss_growth_after_first_round": round(round_growth, 4),
        "floors": floors,
        "floors_met": all(floors.values()),
    }


def format_table(result: dict[str, Any]) -> str:
    """Each mission's figures and the floors, as markdown."""
    lines = [
        "| mission | scene/seed | outcome | sim total min | tick p99 ms CPU (wall) | memory nodes | RSS MB | behaviours alive |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for m in result["missions"]:
        lines.append(
            f"| {m['mission']} | {m['scene']}/{m['seed']} | {m['outcome']} | {m['sim_total_s'] / 60:.1f} | "
            f"{m['tick_cpu_p99_ms']:.2f} ({m['tick_p99_ms']:.2f}) | {m['memory_nodes']} | {m['rss_mb']:.1f} | "
            f"{m['live_objects']['behaviours']} |"
        )
    if result["missions"]:
        lines += ["", f"- resident memory growth after the first mission: {100 * result['rss_growth']:.1f} %"]
        lines.append(
            "- resident memory growth after every scene's first mission: "
            f"{100 * result['rss_growth_after_first_round']:.1f} %"
        )
        if result.get("repeat"):
            again = result["repeat"]
            lines.append(
                f"- tick p99, CPU, the first mission and the same mission at the end: "
                f"{again['first_tick_cpu_p99_ms']:.2f} ms -> {again['tick_cpu_p99_ms']:.2f} ms "
                f"(the same episode again: {'yes' if again['same_episode'] else 'NO'})"
            )
        lines.append(
            f"- tick p99, CPU: {result['start']['tick_cpu_p99_ms']:.2f} ms (first third) -> "
            f"{result['end']['tick_cpu_p99_ms']:.2f} ms (last third); wall: "
            f"{result['start']['tick_p99_ms']:.2f} ms -> {result['end']['tick_p99_ms']:.2f} ms"
        )
    lines += [f"- {name}: {'met' if ok else 'NOT met'}" for name, ok in result["floors"].items()]
    return "\n".join(lines)
