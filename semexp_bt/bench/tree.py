"""The executive's own cost: per-tick wall time of the paper's mission tree with no physics and no rendering.

The mission (``trees/object_search.yaml``) runs on :class:`robots.null_robot.NullRobot` (a perfect unicycle
with a synthetic open-floor depth image) and :class:`sims.scripted_perception.ScriptedPerception` (a fixed
answer after 2.5 s of backend time: two unexplored directions, and after some views a detection of the
target straight ahead). Two configurations are timed:

- ``tree``: the controller replaced by a pure-pursuit stand-in that costs microseconds, a known empty
  costmap (no depth integration), and a camera that returns one pre-rendered frame, so the figure is
  py_trees plus our behaviours plus the paper's arbitration, memory and decision maths;
- ``tree+navigation``: the real navigation stack (costmap from the NullRobot's ray-cast depth at 6 Hz,
  the global planner, regulated pure pursuit at 12 Hz, costmap frontiers).

For each, per-tick time of ``tree.tick()`` (the robot's ``advance`` is not timed) is reported as median,
p99 and max over ``ticks`` ticks, seeded and deterministic in its sequence of events: wall time, and the
thread's CPU time, which does not count time the scheduler gave to other processes (on a shared 2-core
machine the wall-time tail is mostly preemption: 4 ms is one scheduler slice).
"""

from __future__ import annotations

import math
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np

from behaviours.services import MissionServices
from robots.null_robot import NullRobot
from semexp_bt.app.executive import build_tree, prepare_board
from semexp_bt.core.config import SemExpConfig
from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.relevance import CachedRelevance, LexicalRelevance
from semexp_bt.core.types import Detection, Observation, Pose2D, SceneEvidence, SceneProposal, Twist
from semexp_bt.nav.control_result import ControlResult
from semexp_bt.nav.pure_pursuit import RegulatedPurePursuit
from semexp_bt.perception.interface import PerceptionResult
from sims.scripted_perception import ScriptedPerception

MISSION = Path(__file__).resolve().parents[2] / "trees" / "object_search.yaml"
TICK_PERIOD_S = 0.02
FLOOR_MS = 1.0


class PurePursuitStandIn:
    """A constant-cost controller stand-in: turn toward the plan's end, drive when roughly facing it."""

    name = "stand-in"

    def compute(self, *, plan: Any, pose: Pose2D, **_: Any) -> ControlResult:
        end = plan.path_xy[-1]
        dx, dy = end[0] - pose.x_m, end[1] - pose.y_m
        bearing = math.remainder(math.atan2(dy, dx) - pose.yaw_rad, math.tau)
        v = 0.5 if abs(bearing) < 0.5 else 0.0
        return ControlResult(Twist(v, 0.0, max(-1.0, min(1.0, 1.5 * bearing))), "tracking")

    def reset(self) -> None:
        return None


def _script() -> list[Any]:
    def directions(observation: Observation) -> PerceptionResult:
        return PerceptionResult(
            scene=SceneEvidence(
                (
                    SceneProposal((60.0, 150.0), "open corridor", "direction"),
                    SceneProposal((260.0, 150.0), "doorway", "direction"),
                ),
                0.8,
            ),
            detections=(),
            observation_stamp_s=observation.stamp_s,
        )

    def target_ahead(observation: Observation) -> PerceptionResult:
        box = (140.0, 140.0, 180.0, 200.0)
        return PerceptionResult(
            scene=SceneEvidence((SceneProposal((160.0, 170.0), "fire extinguisher", "object"),), 0.9),
            detections=(Detection(box, "fire extinguisher", 0.9),),
            observation_stamp_s=observation.stamp_s,
        )

    return [directions] * 8 + [target_ahead] * 4


def _empty_known_map(costmap: Any) -> None:
    """Make the costmap a known empty floor (no depth integration, a plan only when the subgoal changes)."""
    costmap.set_known(np.zeros((8, 8), dtype=bool), lower_left_xy=(-50.0, -50.0), resolution_m=12.5)


def time_ticks(*, planner: Any, ticks: int, seed: int, navigation: bool) -> dict[str, float]:
    robot = NullRobot(start_pose=Pose2D(0.0, 0.0, 0.0), render_once=not navigation)
    config = SemExpConfig()
    services = MissionServices(
        robot=robot,
        perception=ScriptedPerception(_script()),
        relevance=CachedRelevance(LexicalRelevance()),
        config=config,
        planner=planner,
        rng=np.random.default_rng(seed),
        budget_s=1e9,
    )
    board = prepare_board(
        instructions=["find the fire extinguisher"],
        start_pose=robot.base_pose(),
        memory=TopologicalMemory(config.memory),
    )
    if not navigation:
        _empty_known_map(board.local_map)
    tree = build_tree(MISSION, services=services)
    tree.setup()
    samples = np.empty(ticks)
    cpu = np.empty(ticks)
    restarts = 0
    for i in range(ticks):
        c0, t0 = time.thread_time(), time.perf_counter()
        tree.tick()
        samples[i] = time.perf_counter() - t0
        cpu[i] = time.thread_time() - c0
        if tree.root.status.name != "RUNNING":  # the mission ended: start it again, as a long run would
            restarts += 1
            board = prepare_board(
                instructions=["find the fire extinguisher"],
                start_pose=robot.base_pose(),
                memory=TopologicalMemory(config.memory),
            )
            if not navigation:
                _empty_known_map(board.local_map)
            tree = build_tree(MISSION, services=services)
            tree.setup()
        robot.advance(TICK_PERIOD_S)
    ms, cpu_ms = samples * 1e3, cpu * 1e3
    return {
        "median_ms": float(np.median(ms)),
        "p99_ms": float(np.percentile(ms, 99)),
        "max_ms": float(ms.max()),
        "cpu_median_ms": float(np.median(cpu_ms)),
        "cpu_p99_ms": float(np.percentile(cpu_ms, 99)),
        "ticks": ticks,
        "missions_completed": restarts,
        "decisions": len(services.decision_log),
    }


def run_tree_bench(*, ticks: int = 20_000, seed: int = 0) -> dict[str, Any]:
    rows = {
        "tree": time_ticks(planner=PurePursuitStandIn(), ticks=ticks, seed=seed, navigation=False),
        "tree+navigation": time_ticks(
            planner=RegulatedPurePursuit(), ticks=ticks, seed=seed, navigation=True
        ),
    }
    return {
        "seed": seed,
        "machine": {"platform": platform.platform(), "python": platform.python_version()},
        "floor_ms": FLOOR_MS,
        "rows": rows,
        "floors_met": {
            "tree median": rows["tree"]["median_ms"] < FLOOR_MS,
            "tree p99 (cpu)": rows["tree"]["cpu_p99_ms"] < FLOOR_MS,
        },
    }


def format_table(result: dict[str, Any]) -> str:
    lines = [
        "| configuration | wall median ms | wall p99 ms | cpu median ms | cpu p99 ms | ticks | decisions |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name, row in result["rows"].items():
        lines.append(
            f"| {name} | {row['median_ms']:.3f} | {row['p99_ms']:.3f} | {row['cpu_median_ms']:.3f} | "
            f"{row['cpu_p99_ms']:.3f} | {row['ticks']} | {row['decisions']} |"
        )
    met = ", ".join(f"{k}: {'ok' if v else 'MISSED'}" for k, v in result["floors_met"].items())
    return "\n".join(lines) + f"\n\nfloors (< {result['floor_ms']} ms): {met}"
