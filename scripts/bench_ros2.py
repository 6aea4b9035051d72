"""The ROS 2 figures of docs/ros2.md: speed against the in-process run, tick p99, camera pair latency.

Run it in the ROS 2 environment, on loopback only::

    scripts/ros2_isolated.sh .venv-ros2/bin/python scripts/bench_ros2.py --json runs/bench-ros2.json

1. The same episode (default: showroom seed 9, kinematic, lexical relevance) in-process (``semexp-bt run``)
   and over ROS 2 in lockstep (``semexp-bt sim-bridge`` and ``semexp-bt run --backend ros2`` as two
   processes), alternately ``--repeats`` times: outcome of each, mission wall time per simulated second
   (the mission loop only: each record's ``mission_wall_s``, the wall time of ``run_mission``, measured the
   same way by both backends), the executive's tick median and p99. ``--compare-speculation`` adds a
   third run to each repeat, over ROS 2 with the bridge's speculative step off (``sim-bridge
   --no-speculation``), between the other two: a paired before/after on the same machine.
0. Start-up cost of the ROS 2 wheels' bootstrap ``.pth`` (it re-executes every Python start to set
   LD_LIBRARY_PATH): median wall time of the same commands with .venv's interpreter and with
   .venv-ros2's (the same packages plus the ROS 2 wheels), ``--startup-repeats`` runs each.
2. Camera pair latency: the bridge in realtime mode for ``--latency-s`` seconds at 15 Hz; this process
   listens with the ROS 2 backend; latency = the instant a colour + depth pair is complete here minus the
   instant the bridge finished rendering it (``time.monotonic`` is one clock for every process).

For iteration: ``--budget-s 60`` runs both backends on a copy of the mission with its budget cut (the
end-to-end tests' way; a full 600 s pair takes minutes), ``--startup-repeats 0`` and ``--latency-s 0`` skip
parts 0 and 2.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# This checkout's packages (the pair-latency probe imports the backend here; the episodes' subprocesses run
# in ROOT), not whichever checkout the environment's editable install points at.
sys.path.insert(0, str(ROOT))

from tests.ros2_support import MISSION, mission_with_budget, run_bridge_and_executive  # noqa: E402


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "semexp_bt", *args]


def in_process(mission: Path, scene: str, seed: int, out: Path) -> dict[str, Any]:
    """One in-process episode (``semexp-bt run``)."""
    record_path = out / f"inprocess_{scene}_{seed}.json"
    subprocess.run(
        _cli(
            "run",
            str(mission),
            "--scene",
            scene,
            "--seed",
            str(seed),
            "--relevance",
            "lexical",
            "--json",
            str(record_path),
        ),
        check=False,
        capture_output=True,
    )
    record = json.loads(record_path.read_text())
    return {
        "outcome": record["outcome"],
        "success": record["success"],
        "ticks": record["ticks"],
        "sim_time_s": record["sim_time_s"],
        "wall_time_s": record["wall_time_s"],
        "mission_wall_s": record["mission_wall_s"],
        "wall_per_sim_s": record["mission_wall_s"] / record["sim_time_s"],
        "tick_wall_ms": record["tick_wall_ms"],
    }


def over_ros2(mission: Path, scene: str, seed: int, out: Path, *, speculate: bool = True) -> dict[str, Any]:
    """The same episode over ROS 2 in lockstep: bridge and executive as two processes (``speculate``: the
    bridge's speculative step, sims.ros2_bridge.Speculation)."""
    bridge_json, exec_json = out / f"bridge_{scene}_{seed}.json", out / f"executive_{scene}_{seed}.json"
    run_bridge_and_executive(
        _cli("sim-bridge", "--scene", scene, "--seed", str(seed), "--json", str(bridge_json), "--max-wall-s", "900",
             *(() if speculate else ("--no-speculation",))),
        _cli("run", str(mission), "--backend", "ros2", "--seed", str(seed), "--relevance", "lexical",
             "--json", str(exec_json)),
        quiet=True,
    )  # fmt: skip
    executive, scored = json.loads(exec_json.read_text()), json.loads(bridge_json.read_text())
    return {
        "outcome": executive["outcome"],
        "success": scored["success"],
        "ticks": executive["ticks"],
        "sim_time_s": executive["sim_time_s"],
        "wall_time_s": executive["wall_time_s"],
        "mission_wall_s": executive["mission_wall_s"],
        "wall_per_sim_s": executive["mission_wall_s"] / executive["sim_time_s"],
        "tick_wall_ms": executive["tick_wall_ms"],
        "speculative_steps": scored["speculative_steps"],
    }


def pair_latency(scene: str, seed: int, seconds: float, out: Path) -> dict[str, Any]:
    """Camera pair latency bridge -> this process, the bridge in realtime mode at 15 Hz."""
    from robots.ros2_backend import Ros2Robot

    bridge_json = out / "bridge_latency.json"
    bridge = subprocess.Popen(
        _cli(
            "sim-bridge",
            "--scene",
            scene,
            "--seed",
            str(seed),
            "--mode",
            "realtime",
            "--camera-hz",
            "15",
            "--json",
            str(bridge_json),
            "--max-wall-s",
            str(seconds + 60),
        ),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    robot = Ros2Robot(simulation=True, node_name="semexp_latency_probe")
    try:
        robot.wait_until_ready(timeout_s=60)
        time.sleep(seconds)
        arrivals = dict(robot.camera_pair_arrivals())
    finally:
        robot.close()
        bridge.terminate()
        bridge.wait(timeout=30)
    sent = {int(stamp): float(t) for stamp, t in json.loads(bridge_json.read_text())["frame_log"]}
    latency_ms = np.array([(arrivals[s] - sent[s]) * 1e3 for s in arrivals if s in sent])
    return {
        "pairs": int(latency_ms.size),
        "median_ms": float(np.median(latency_ms)),
        "p99_ms": float(np.percentile(latency_ms, 99)),
        "max_ms": float(latency_ms.max()),
        "frames_sent": len(sent),
    }


STARTUP_COMMANDS: dict[str, list[str]] = {
    "python -c pass": ["-c", "pass"],
    "semexp-bt --help": ["-m", "semexp_bt", "--help"],
    "pytest --collect-only tests/test_geometry.py": [
        "-m",
        "pytest",
        "-q",
        "--collect-only",
        "-p",
        "no:cacheprovider",
        "tests/test_geometry.py",
    ],
}


def startup_cost(repeats: int) -> dict[str, dict[str, float]]:
    """Median wall (ms) of each command with .venv's interpreter and with .venv-ros2's."""
    interpreters = {
        "venv": ROOT / ".venv" / "bin" / "python",
        "venv_ros2": ROOT / ".venv-ros2" / "bin" / "python",
    }
    env = {k: v for k, v in os.environ.items() if k != "_ROS_WHEELS_BOOTSTRAP_COMPLETE"}
    out: dict[str, dict[str, float]] = {}
    for name, args in STARTUP_COMMANDS.items():
        out[name] = {}
        for label, python in interpreters.items():
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                subprocess.run([str(python), *args], cwd=ROOT, env=env, capture_output=True, check=True)
                times.append((time.perf_counter() - t0) * 1e3)
            out[name][label] = float(np.median(times))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="showroom")
    parser.add_argument("--seed", type=int, default=9)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--latency-s", type=float, default=20.0, help="0: skip the pair latency")
    parser.add_argument("--startup-repeats", type=int, default=10, help="0: skip the start-up cost")
    parser.add_argument(
        "--budget-s", type=float, default=None, help="cut the mission's budget (s) for a shorter pair of runs"
    )
    parser.add_argument(
        "--compare-speculation",
        action="store_true",
        help="each repeat also runs the ROS 2 pair with the bridge's speculative step off (sim-bridge "
        "--no-speculation), between the other two runs",
    )
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    os.chdir(ROOT)
    startup = startup_cost(args.startup_repeats) if args.startup_repeats > 0 else None
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        mission = MISSION if args.budget_s is None else mission_with_budget(out / "mission", args.budget_s)
        runs: list[dict[str, Any]] = []
        for _ in range(args.repeats):
            run: dict[str, Any] = {"in_process": in_process(mission, args.scene, args.seed, out)}
            if args.compare_speculation:
                run["ros2_no_speculation"] = over_ros2(mission, args.scene, args.seed, out, speculate=False)
            run["ros2"] = over_ros2(mission, args.scene, args.seed, out)
            run["load_average"] = os.getloadavg()
            runs.append(run)
        latency = pair_latency(args.scene, args.seed, args.latency_s, out) if args.latency_s > 0 else None
    ratios = [r["ros2"]["wall_per_sim_s"] / r["in_process"]["wall_per_sim_s"] for r in runs]
    no_speculation = [
        r["ros2_no_speculation"]["wall_per_sim_s"] / r["in_process"]["wall_per_sim_s"]
        for r in runs
        if "ros2_no_speculation" in r
    ]
    report = {
        "episode": {
            "scene": args.scene,
            "seed": args.seed,
            "fidelity": "kinematic",
            "relevance": "lexical",
            "budget_s": args.budget_s,
        },
        "machine": {"cores": os.cpu_count(), "load_average_at_end": os.getloadavg()},
        "startup_ms": startup,
        "runs": runs,
        "ros2_over_in_process_wall_per_sim_s": ratios,
        **({"without_speculation_over_in_process": no_speculation} if no_speculation else {}),
        "camera_pair_latency": latency,
    }
    text = json.dumps(report, indent=1)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
