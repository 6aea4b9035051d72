"""The core benchmark: arbitration, memory update and decision latency on this machine.

Workloads (issue #2), all synthetic and seeded:
- arbitration with 20 scene proposals and 50 detections on a 320x240 depth image;
- one memory update at 100, 1k, 10k and 100k nodes (the memory is first filled with that many nodes
  spread over a square whose area keeps the density of a real exploration, then random observations
  are offered: some merge, some insert, some are rejected);
- one decision at 100, 1k and 10k candidates with a warm relevance cache, reported both for the
  utility argmax alone (``decide``) and with the graph travel costs it needs (``decide+travel``).

Each row reports the median and p95 over ``repeats`` timed calls (``time.perf_counter``).
"""

from __future__ import annotations

import platform
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from semexp_bt.core.config import ArbitrationConfig, DecisionConfig, MemoryConfig
from semexp_bt.core.decision import decide
from semexp_bt.core.evidence import arbitrate
from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.relevance import CachedRelevance, LexicalRelevance
from semexp_bt.core.types import Detection, SceneEvidence, SceneProposal

#: Floors from issue #2 (ms).
FLOORS_MS = {"arbitration": 1.0, "memory_update@10000": 1.0, "decide+travel@1000": 20.0}
_LABELS = ("fire extinguisher", "red trash can", "chair", "open corridor", "doorway", "shelf", "box", "desk")
_WIDTH, _HEIGHT = 320, 240


def _time_calls(fn: Callable[[int], Any], repeats: int) -> dict[str, float]:
    samples = []
    for i in range(repeats):
        t0 = time.perf_counter()
        fn(i)
        samples.append((time.perf_counter() - t0) * 1e3)
    arr = np.asarray(samples)
    return {"median_ms": float(np.median(arr)), "p95_ms": float(np.percentile(arr, 95)), "repeats": repeats}


def bench_arbitration(*, seed: int, repeats: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    depth = rng.uniform(0.5, 8.0, size=(_HEIGHT, _WIDTH)).astype(np.float32)
    inputs = []
    for _ in range(16):
        proposals = tuple(
            SceneProposal(
                point_px=(float(rng.uniform(0, _WIDTH)), float(rng.uniform(0, _HEIGHT))),
                label=str(rng.choice(_LABELS)),
                kind="direction" if rng.random() < 0.3 else "object",
            )
            for _ in range(20)
        )
        detections = []
        for _ in range(50):
            u0, v0 = rng.uniform(0, _WIDTH - 40), rng.uniform(0, _HEIGHT - 40)
            w, h = rng.uniform(5, 40), rng.uniform(5, 40)
            detections.append(
                Detection(
                    (float(u0), float(v0), float(u0 + w), float(v0 + h)),
                    str(rng.choice(_LABELS)),
                    float(rng.uniform(0, 1)),
                )
            )
        inputs.append(
            (
                SceneEvidence(proposals=proposals, scene_confidence=float(rng.uniform(0.3, 1.0))),
                tuple(detections),
            )
        )
    config = ArbitrationConfig()

    def aligned(label: str) -> bool:
        return label in ("fire extinguisher", "red trash can")

    def call(i: int) -> None:
        scene, dets = inputs[i % len(inputs)]
        arbitrate(scene=scene, detections=dets, is_aligned=aligned, config=config, depth_m=depth)

    for i in range(20):
        call(i)
    return _time_calls(call, repeats)


def _filled_memory(n_nodes: int, rng: np.random.Generator) -> tuple[TopologicalMemory, float]:
    config = MemoryConfig(max_nodes=max(2 * n_nodes, 1000), maintenance_every=50)
    memory = TopologicalMemory(config)
    # Nodes on a jittered lattice with spacing just above delta_d, so every one is inserted.
    spacing = config.delta_d * 1.05
    side_count = int(np.ceil(np.sqrt(n_nodes)))
    memory.add_master(position_m=(0.0, 0.0, 0.0), stamp_s=0.0)
    count = 1
    for i in range(side_count):
        for j in range(side_count):
            if count >= n_nodes:
                break
            if i == 0 and j == 0:
                continue
            memory.update(
                position_m=(i * spacing, j * spacing, 0.5),
                label=str(rng.choice(_LABELS)),
                confidence=float(rng.uniform(0.5, 1.0)),
                stamp_s=float(count),
            )
            count += 1
    return memory, side_count * spacing


def bench_memory(*, n_nodes: int, seed: int, repeats: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    memory, side = _filled_memory(n_nodes, rng)
    points = rng.uniform(0.0, side, size=(repeats, 2))
    labels = rng.choice(_LABELS, size=repeats)
    conf = rng.uniform(0.0, 1.0, size=repeats)

    def call(i: int) -> None:
        memory.update(
            position_m=(float(points[i, 0]), float(points[i, 1]), 0.5),
            label=str(labels[i]),
            confidence=float(conf[i]),
            stamp_s=1e6 + i,
        )

    out = _time_calls(call, repeats)
    out["nodes_after"] = len(memory)
    return out


def bench_decision(*, n_candidates: int, seed: int, repeats: int, with_travel: bool) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    memory, side = _filled_memory(n_candidates + 1, rng)
    relevance = CachedRelevance(LexicalRelevance())
    instruction = "find the fire extinguisher"
    config = DecisionConfig()
    nodes = memory.nodes()
    robot = (side / 2, side / 2, 0.0)
    costs = memory.travel_costs(from_position_m=robot, mode="graph")
    decide(
        nodes=nodes, instruction=instruction, relevance=relevance, travel_costs=costs, config=config
    )  # warm

    def call(_: int) -> None:
        c = memory.travel_costs(from_position_m=robot, mode="graph") if with_travel else costs
        decide(nodes=nodes, instruction=instruction, relevance=relevance, travel_costs=c, config=config)

    out = _time_calls(call, repeats)
    out["candidates"] = sum(1 for n in nodes if n.potential >= config.tau_p and not n.is_master)
    return out


def run_core_bench(*, seed: int = 0, quick: bool = False) -> dict[str, Any]:
    """Every row of the core benchmark as a dict (also what ``--json`` writes)."""
    reps = 50 if quick else 300
    rows: dict[str, Any] = {"arbitration": bench_arbitration(seed=seed, repeats=reps)}
    for n in (100, 1000, 10_000) + (() if quick else (100_000,)):
        rows[f"memory_update@{n}"] = bench_memory(n_nodes=n, seed=seed, repeats=reps)
    for n in (100, 1000, 10_000):
        rows[f"decide@{n}"] = bench_decision(
            n_candidates=n, seed=seed, repeats=max(20, reps // 5), with_travel=False
        )
        rows[f"decide+travel@{n}"] = bench_decision(
            n_candidates=n, seed=seed, repeats=max(20, reps // 5), with_travel=True
        )
    return {
        "seed": seed,
        "quick": quick,
        "machine": {
            "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            "python": platform.python_version(),
        },
        "floors_ms": FLOORS_MS,
        "rows": rows,
        "floors_met": {k: rows[k]["median_ms"] < v for k, v in FLOORS_MS.items()},
    }


def format_table(result: dict[str, Any]) -> str:
    lines = ["| workload | median ms | p95 ms |", "|---|---:|---:|"]
    for name, row in result["rows"].items():
        lines.append(f"| {name} | {row['median_ms']:.3f} | {row['p95_ms']:.3f} |")
    met = ", ".join(f"{k}: {'ok' if v else 'MISSED'}" for k, v in result["floors_met"].items())
    lines.append(f"\nfloors: {met}")
    return "\n".join(lines)


__all__ = ["run_core_bench", "format_table"]
