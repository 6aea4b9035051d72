"""The soak benchmark's bookkeeping (the benchmark itself is a command: ``semexp-bt bench soak``)."""

from __future__ import annotations

import py_trees

from semexp_bt.bench.soak import MAX_RSS_GROWTH, live_objects, resident_bytes, summarise
from semexp_bt.core.config import SemExpConfig
from semexp_bt.core.memory import TopologicalMemory


def mission(
    index: int,
    *,
    rss_mb: float,
    p99_ms: float,
    scene: str = "office",
    wall_p99_ms: float | None = None,
    repeat_of: int | None = None,
) -> dict:
    """A soak entry whose tick p99 is ``p99_ms`` of CPU (and ``wall_p99_ms``, by default three times it, of wall)."""
    return {"mission": index, "scene": scene, "seed": 0 if repeat_of is not None else index, "repeat_of": repeat_of,
            "outcome": "success", "ticks": 100, "path_length_m": 5.0, "sim_total_s": 600.0 * (index + 1),
            "tick_cpu_p99_ms": p99_ms, "tick_p99_ms": 3 * p99_ms if wall_p99_ms is None else wall_p99_ms,
            "memory_nodes": 10, "rss_mb": rss_mb, "live_objects": {"behaviours": 0}}  # fmt: skip


def soak(entries: list[dict], *, repeat_p99_ms: float, rss_mb: float | None = None) -> list[dict]:
    """``entries`` then the first mission run again with a p99 of ``repeat_p99_ms``."""
    last_rss = entries[-1]["rss_mb"] if rss_mb is None else rss_mb
    return [*entries, mission(len(entries), rss_mb=last_rss, p99_ms=repeat_p99_ms, repeat_of=0)]


def test_the_floors_compare_the_end_with_the_first_mission_and_its_repeat_with_its_first_run() -> None:
    steady = summarise(
        soak([mission(i, rss_mb=500.0 + i, p99_ms=20.0 + (i % 2)) for i in range(6)], repeat_p99_ms=21.0)
    )
    assert steady["floors_met"] and steady["rss_growth"] == 0.01
    assert steady["start"]["tick_cpu_p99_ms"] == 20.5 and steady["repeat"]["same_episode"]
    leaking = summarise(
        soak(
            [mission(i, rss_mb=500.0 * (1 + MAX_RSS_GROWTH * i), p99_ms=20.0) for i in range(3)],
            repeat_p99_ms=20.0,
        )
    )
    slowing = summarise(soak([mission(i, rss_mb=500.0, p99_ms=20.0) for i in range(6)], repeat_p99_ms=25.0))
    assert list(leaking["floors"].values()) == [False, True]
    assert list(slowing["floors"].values()) == [True, False]


def test_dearer_scenes_late_in_the_soak_are_not_a_rising_p99_but_no_repeat_is_no_evidence() -> None:
    dear_end = [mission(i, rss_mb=500.0, p99_ms=10.0 if i < 4 else 15.0) for i in range(6)]
    assert summarise(soak(dear_end, repeat_p99_ms=10.5))["floors_met"]
    assert not summarise(dear_end)["floors_met"]


def test_the_p99_floor_reads_cpu_time_so_a_loaded_machine_s_wall_clock_does_not_fail_it() -> None:
    entries = [mission(i, rss_mb=500.0, p99_ms=20.0, wall_p99_ms=60.0 * (1 + i)) for i in range(6)]
    loaded = summarise([*entries, mission(6, rss_mb=500.0, p99_ms=20.0, wall_p99_ms=400.0, repeat_of=0)])
    assert loaded["floors_met"]


def test_growth_after_the_first_round_is_measured_from_the_last_scene_s_first_mission() -> None:
    scenes = ("office", "living_room", "laboratory")
    sizes = [500.0, 540.0, 550.0, 550.0, 551.0, 561.0]
    result = summarise(
        soak(
            [mission(i, rss_mb=rss, p99_ms=20.0, scene=scenes[i % 3]) for i, rss in enumerate(sizes)],
            repeat_p99_ms=20.0,
        )
    )
    assert result["rss_growth"] == 0.122 and result["rss_growth_after_first_round"] == 0.02
    assert not result["floors_met"]  # the floor still counts from the first mission


def test_live_objects_count_what_is_alive() -> None:
    before = live_objects()
    kept = [py_trees.behaviours.Success("x"), TopologicalMemory(SemExpConfig().memory)]
    after = live_objects()
    assert after["behaviours"] == before["behaviours"] + 1
    assert after["topological memories"] == before["topological memories"] + 1
    del kept
    assert resident_bytes() > 10 * 2**20


class _LazyProxy:
    """An object that, like a lazy module's attribute, does work when asked for its ``__class__``."""

    asked = 0

    @property
    def __class__(self) -> type:  # type: ignore[override]
        _LazyProxy.asked += 1
        return _LazyProxy


def test_counting_live_objects_asks_no_object_for_its_class() -> None:
    proxy = _LazyProxy()
    live_objects()
    assert _LazyProxy.asked == 0, "isinstance on every live object runs lazy imports and grows the process"
    del proxy
