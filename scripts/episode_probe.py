"""Run episodes one after another in one process and print what each did (a reproducibility probe).

Each episode is ``STRATEGY:SCENE:SEED[:MAX_SIM_S]``; all but the last are warm-ups in the same process.
The last one's outcome, path, ticks and tick p99 (thread CPU and wall) are printed, and with ``--json`` its
trajectory, decisions and events are written, so that two processes can be compared with ``--compare``::

    MUJOCO_GL=egl .venv/bin/python scripts/episode_probe.py ours:garden_sim:1000 --json /tmp/a.json
    MUJOCO_GL=egl .venv/bin/python scripts/episode_probe.py oracle_nav:garden_sim:1000 ours:garden_sim:1000 --json /tmp/b.json
    .venv/bin/python scripts/episode_probe.py --compare /tmp/a.json /tmp/b.json

docs/planner.md (reproducibility) and docs/reliability.md (the soak's missions alone) quote it.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

KEPT = ("outcome", "path_length_m", "ticks", "sim_time_s", "trajectory_xy", "decisions", "events")


def run(specs: list[str], relevance: str) -> dict[str, Any]:
    import torch

    torch.set_num_threads(1)
    from semexp_bt.app.episode import EpisodeOptions, run_episode
    from semexp_bt.bench.sweep import default_mission_path

    record: dict[str, Any] = {}
    for index, spec in enumerate(specs):
        strategy, scene, seed, *cap = spec.split(":")
        record = run_episode(
            EpisodeOptions(
                mission_path=default_mission_path(),
                scene=scene,
                seed=int(seed),
                strategy=strategy,
                relevance=relevance,
                max_sim_s=float(cap[0]) if cap else 900.0,
                keep_trajectory=index == len(specs) - 1,
                measure_tick_cpu=True,
            )
        )
        print(
            f"{'target' if index == len(specs) - 1 else 'warm-up'} {spec}: {record['outcome']}, "
            f"path {record['path_length_m']!r} m, {record['ticks']} ticks, tick p99 "
            f"{record['tick_cpu_ms']['p99']:.2f} ms CPU ({record['tick_wall_ms']['p99']:.2f} ms wall)",
            flush=True,
        )
    return {key: record[key] for key in KEPT}


def compare(first: dict[str, Any], second: dict[str, Any]) -> bool:
    """Print where two probes' records part; True when they do not."""
    same = True
    for key in ("outcome", "path_length_m", "ticks", "sim_time_s"):
        if first[key] != second[key]:
            print(f"{key}: {first[key]!r} != {second[key]!r}")
            same = False
    for key in ("trajectory_xy", "decisions", "events"):
        for index, (a, b) in enumerate(zip(first[key], second[key], strict=False)):
            if a != b:
                print(f"{key}[{index}] differs: {a!r} != {b!r}"[:400])
                same = False
                break
    print("the same episode" if same else "different episodes")
    return same


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("episodes", nargs="*", help="STRATEGY:SCENE:SEED[:MAX_SIM_S], the last one measured")
    parser.add_argument("--relevance", default="lexical")
    parser.add_argument("--json", type=Path, help="write the last episode's record here")
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("A", "B"), help="compare two --json files")
    args = parser.parse_args(argv)
    if args.compare:
        a, b = (json.loads(path.read_text()) for path in args.compare)
        return 0 if compare(a, b) else 1
    if not args.episodes:
        parser.error("give at least one episode, or --compare A B")
    record = run(args.episodes, args.relevance)
    if args.json:
        args.json.write_text(json.dumps(record, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
