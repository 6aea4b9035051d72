"""``semexp-bt bench faults``: every fault class injected into real episodes, and what the executive did.

Each case of :data:`CASES` is a fault list (``sims.faults``) that starts at :data:`FAULT_START_S` of robot
time (after the panoramic start, when the robot is usually on its way) and lasts :data:`TRANSIENT_S`, or to
the end for the cases that test a lasting loss. Every case runs on the same scenes and seeds (fixed here,
before any outcome: :data:`DEFAULT_SCENES` x :data:`DEFAULT_SEEDS`), beside a control case without a
fault, with the sweep machinery (``bench.engine.run_sweep``: parallel, resumable, one folder per case).

A probe (:class:`FaultProbe`) reads the true robot (under the fault decorators) after every tick. Per
episode it reports:

- ``outcome`` and ``success`` (for a transient fault: success after recovery);
- ``speed_at_fault_mps``: the true base speed when the fault began;
- ``time_to_stop_s``: from the fault's start to the moment from which the base stays stopped (speed below
  :data:`STOPPED_SPEED_MPS`, yaw rate below :data:`STOPPED_YAW_RATE_RADPS`) until the fault ends or the
  mission does; the mission's end when it ended first (the runner stops the robot then); None when the
  base did not stop for the fault;
- ``collisions_faulted``: collisions while the fault acted;
- ``unsafe``: while a needed sensor is absent or stale (the case's ``needed``), the ticks after the
  :data:`STOP_FLOOR_S` allowance in which the robot was told to go forward or went forward faster than
  :data:`STOPPED_SPEED_MPS`, plus the collisions in that time.

Floors: ``unsafe`` is 0 in every row, and in every row of a case with a needed sensor lost the base is
stopped within :data:`STOP_FLOOR_S` of the fault.
"""

from __future__ import annotations

import functools
import math
import sys
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from semexp_bt.app.components import DEFAULT_RELEVANCE
from semexp_bt.app.runner import MissionRun
from semexp_bt.bench.rows import STATUS_OK
from semexp_bt.bench.store import load_rows
from semexp_bt.bench.sweep import EpisodeTask, SweepSpec
from semexp_bt.bench.worker import run_real_episode
from sims.faults import FaultyRobot, parse_faults

#: When the faults begin (robot-clock s after the mission's start): the panoramic start takes ~30 s.
FAULT_START_S = 33.0
#: How long a transient fault lasts (s): shorter than the guard's ``lost_after_s`` (5 s), so the robot
#: holds still and then drives on.
TRANSIENT_S = 3.0
#: Model faults last longer: a perception round takes ~2.5 s, so 20 s spans several.
PERCEPTION_FAULT_S = 20.0
#: Scenes and seeds of the default grid (fixed before any outcome was seen).
DEFAULT_SCENES = ("office", "living_room", "laboratory")
DEFAULT_SEEDS = (0, 1)
#: Cap on simulated time per episode (s): enough for most missions in these scenes to end.
DEFAULT_MAX_SIM_S = 240.0
#: The base counts as stopped below these speeds.
STOPPED_SPEED_MPS = 0.05
STOPPED_YAW_RATE_RADPS = 0.1
#: A needed sensor lost must stop the base within this long (s, robot clock): the issue's floor.
STOP_FLOOR_S = 0.5


@dataclass(frozen=True)
class FaultCase:
    """One row group of the benchmark.

    Attributes:
        name: the case's name (its folder).
        faults: the fault list, as a fault file writes it.
        needed: the needed sensor the fault makes absent or stale (``unsafe`` and the stop floor apply),
            or None.
        expected: the documented expectation (``docs/reliability.md``).
    """

    name: str
    faults: tuple[Mapping[str, Any], ...]
    needed: str | None
    expected: str

    def window_s(self) -> tuple[float, float]:
        """When the case's fault acts (the control case: the window a fault would have)."""
        specs = parse_faults(list(self.faults), where=self.name)
        if not specs:
            return FAULT_START_S, FAULT_START_S + TRANSIENT_S
        return min(s.start_s for s in specs), max(s.end_s for s in specs)


def _fault(cls: str, *, duration_s: float | None = TRANSIENT_S, **params: Any) -> dict[str, Any]:
    return {"class": cls, "start_s": FAULT_START_S, "duration_s": duration_s, "params": params}


HOLD = "hold still, then drive on"
CASES: tuple[FaultCase, ...] = (
    FaultCase("none", (), None, "the control: no fault"),
    FaultCase("camera_drop", (_fault("camera_drop"),), "camera", HOLD),
    FaultCase(
        "camera_lost", (_fault("camera_drop", duration_s=None),), "camera", "stop: sensor_lost: camera"
    ),
    FaultCase("camera_freeze", (_fault("camera_freeze"),), "camera", HOLD),
    FaultCase("depth_nan", (_fault("depth_corrupt", value="nan"),), "camera", HOLD),
    FaultCase(
        "depth_holes", (_fault("depth_corrupt", value="zero"),), None, "degraded: holes read as unknown"
    ),
    FaultCase("odometry_drop", (_fault("odometry_drop"),), "odometry", HOLD),
    FaultCase(
        "odometry_jump", (_fault("odometry_jump", duration_s=None),), None, "stop: sensor_fault: odometry"
    ),
    FaultCase(
        "odometry_drift", (_fault("odometry_drift", duration_s=10.0),), None, "degraded: below detection"
    ),
    FaultCase(
        "odometry_slip",
        (_fault("odometry_drift", duration_s=10.0, vx_mps=0.3, yaw_degps=0.0),),
        None,
        "stop: sensor_fault: odometry",
    ),
    FaultCase("imu_drop", (_fault("imu_drop"),), None, "degraded: no IMU reader in kinematic fidelity"),
    FaultCase("imu_spike", (_fault("imu_spike"),), None, "degraded: no IMU reader in kinematic fidelity"),
    FaultCase(
        "commands_ignored", (_fault("commands_ignored"),), None, "the robot's watchdog stops it; drive on"
    ),
    FaultCase("clock_jump", (_fault("clock_jump", duration_s=None),), None, "stop: sensor_fault: clock"),
    FaultCase(
        "perception_garbage",
        (_fault("perception_garbage", duration_s=PERCEPTION_FAULT_S),),
        None,
        "degraded: replies rejected",
    ),
    FaultCase(
        "perception_late",
        (_fault("perception_late", duration_s=PERCEPTION_FAULT_S),),
        None,
        "degraded: timeouts",
    ),
    FaultCase(
        "perception_error",
        (_fault("perception_error", duration_s=PERCEPTION_FAULT_S),),
        None,
        "degraded: errors",
    ),
)
CASES_BY_NAME = {case.name: case for case in CASES}


class FaultProbe:
    """A tick observer that samples the true robot (below the fault decorators) after every tick."""

    wants_activity_stream = False

    def __init__(self) -> None:
        #: ``(elapsed s, v_x, v_y, w_z, commanded v_x)`` per tick, true values.
        self.samples: list[tuple[float, float, float, float, float]] = []
        self._faulty: FaultyRobot | None = None
        self._t0 = 0.0
        self.end_s = 0.0

    def start(self, run: MissionRun) -> None:
        robot = run.robot
        self._faulty = robot if isinstance(robot, FaultyRobot) else None
        self.truth = robot.inner if isinstance(robot, FaultyRobot) else robot
        self._t0 = self.truth.now_s()

    def after_tick(self, run: MissionRun) -> None:
        twist = self.truth.base_twist()
        commanded = self._faulty.last_twist_received.linear_x_mps if self._faulty is not None else math.nan
        self.samples.append(
            (
                self.truth.now_s() - self._t0,
                twist.linear_x_mps,
                twist.linear_y_mps,
                twist.angular_z_radps,
                commanded,
            )
        )

    def finish(self, run: MissionRun, outcome: str) -> None:
        self.end_s = self.truth.now_s() - self._t0

    def collisions_s(self) -> list[float]:
        """When (elapsed s) each collision began, from the true robot's contact log."""
        return [e.stamp_s - self._t0 for e in self.truth.safety().events if e.kind == "collision"]


def _stopped(sample: tuple[float, float, float, float, float]) -> bool:
    _, vx, vy, wz, _ = sample
    return math.hypot(vx, vy) < STOPPED_SPEED_MPS and abs(wz) < STOPPED_YAW_RATE_RADPS


def fault_metrics(probe: FaultProbe, case: FaultCase) -> dict[str, Any]:
    """The per-episode figures of the module docstring, from the probe's samples."""
    start, end = case.window_s()
    window_end = min(end, probe.end_s)
    reached = probe.end_s >= start
    inside = [s for s in probe.samples if start <= s[0] <= window_end]
    collisions = [t for t in probe.collisions_s() if start <= t <= window_end]
    time_to_stop: float | None = None
    stopped_by = None
    if reached and inside:
        moving = [i for i, s in enumerate(inside) if not _stopped(s)]
        if not moving:
            time_to_stop, stopped_by = 0.0, "already stopped"
        elif moving[-1] + 1 < len(inside):
            time_to_stop, stopped_by = inside[moving[-1] + 1][0] - start, "stopped"
        elif probe.end_s < end:
            time_to_stop, stopped_by = probe.end_s - start, "mission end"
    unsafe = 0
    if case.needed is not None and reached:
        late = [s for s in inside if s[0] >= start + STOP_FLOOR_S]
        unsafe = sum(1 for s in late if s[1] > STOPPED_SPEED_MPS or s[4] > STOPPED_SPEED_MPS) + len(
            collisions
        )
    return {
        "fault_reached": reached,
        "speed_at_fault_mps": round(math.hypot(inside[0][1], inside[0][2]), 3) if inside else None,
        "time_to_stop_s": None if time_to_stop is None else round(time_to_stop, 3),
        "stopped_by": stopped_by,
        "collisions_faulted": len(collisions),
        "unsafe": unsafe,
    }


def run_fault_episode(task: EpisodeTask, *, case: str) -> dict[str, Any]:
    """Run one episode of ``case`` (the sweep's run function, bound to a case with ``functools.partial``)."""
    fault_case = CASES_BY_NAME[case]
    probe = FaultProbe()
    faults = parse_faults(list(fault_case.faults), where=f"fault case {case}")
    record = run_real_episode(task, faults=faults, observers=[probe])
    record["fault_case"] = case
    record["fault_metrics"] = fault_metrics(probe, fault_case)
    record["sensor_events"] = [e for e in record["events"] if str(e.get("kind", "")).startswith("sensor_")]
    return record


def run_fault_bench(
    out_dir: Path,
    *,
    scenes: Sequence[str] = DEFAULT_SCENES,
    seeds: Sequence[int] = DEFAULT_SEEDS,
    cases: Sequence[str] | None = None,
    fidelity: str = "kinematic",
    relevance: str = DEFAULT_RELEVANCE,
    max_sim_s: float = DEFAULT_MAX_SIM_S,
    workers: int = 1,
    timeout_s: float | None = None,
    progress: TextIO | None = sys.stderr,
) -> dict[str, Any]:
    """Run every case on every scene and seed (resuming what ``out_dir`` holds) and gather the table.

    Raises:
        HarnessError: on an unknown scene or a damaged folder (from the sweep).
        KeyError: on an unknown case name.
    """
    from semexp_bt.bench.engine import run_sweep

    chosen = [CASES_BY_NAME[name] for name in (cases or [c.name for c in CASES])]
    extra: dict[str, Any] = {} if timeout_s is None else {"timeout_s": timeout_s}
    errors = 0
    for case in chosen:
        spec = SweepSpec(scenes=tuple(scenes), seeds=tuple(seeds), strategies=("ours",), fidelity=fidelity,
                         relevance=relevance, max_sim_s=max_sim_s, trajectories_per_cell=0, **extra)  # fmt: skip
        result = run_sweep(spec, out_dir / case.name, workers=workers,
                           run_fn=functools.partial(run_fault_episode, case=case.name), progress=progress)  # fmt: skip
        errors += result.errors + result.timeouts
    return summarise(out_dir, chosen, scenes=scenes, seeds=seeds, settings={
        "fidelity": fidelity, "relevance": relevance, "max_sim_s": max_sim_s, "fault_start_s": FAULT_START_S,
        "transient_s": TRANSIENT_S, "perception_fault_s": PERCEPTION_FAULT_S, "errors": errors})  # fmt: skip


def summarise(
    out_dir: Path,
    cases: Sequence[FaultCase],
    *,
    scenes: Sequence[str],
    seeds: Sequence[int],
    settings: dict[str, Any],
) -> dict[str, Any]:
    """The benchmark's table (one row per episode), a summary per case and the floors."""
    rows: list[dict[str, Any]] = []
    for case in cases:
        for row in load_rows(out_dir / case.name):
            if (
                row.get("status") != STATUS_OK
                or row.get("scene") not in scenes
                or row.get("seed") not in seeds
            ):
                continue
            metrics = row["fault_metrics"]
            rows.append({
                "case": case.name, "scene": row["scene"], "seed": row["seed"], "outcome": row["outcome"],
                "success": row["success"], "needed": case.needed, **metrics,
                "sim_time_s": round(float(row["sim_time_s"]), 1)})  # fmt: skip
    control = {(r["scene"], r["seed"]): r for r in rows if r["case"] == "none"}
    summary = []
    for case in cases:
        mine = [r for r in rows if r["case"] == case.name]
        reached = [r for r in mine if r["fault_reached"]]
        stops = [r["time_to_stop_s"] for r in reached if r["time_to_stop_s"] is not None]
        summary.append({
            "case": case.name, "expected": case.expected, "needed": case.needed, "episodes": len(mine),
            "fault_reached": len(reached), "outcomes": dict(Counter(r["outcome"] for r in mine)),
            "success": sum(r["success"] for r in mine),
            "control_success": sum(control[(r["scene"], r["seed"])]["success"] for r in mine
                                   if (r["scene"], r["seed"]) in control),
            "max_time_to_stop_s": max(stops) if stops else None,
            "collisions_faulted": sum(r["collisions_faulted"] for r in mine),
            "unsafe": sum(r["unsafe"] for r in mine)})  # fmt: skip
    stop_rows = [r for r in rows if r["needed"] is not None and r["fault_reached"]]
    floors = {
        "unsafe is 0 in every row": all(r["unsafe"] == 0 for r in rows),
        f"a needed sensor lost stops the base within {STOP_FLOOR_S} s": all(
            r["time_to_stop_s"] is not None and r["time_to_stop_s"] <= STOP_FLOOR_S for r in stop_rows
        ),
    }
    return {"settings": settings, "scenes": list(scenes), "seeds": list(seeds), "rows": rows,
            "summary": summary, "floors": floors, "floors_met": all(floors.values())}  # fmt: skip


def format_table(result: Mapping[str, Any]) -> str:
    """The summary per case and the floors, as markdown."""
    lines = [
        "| case | expected | episodes (fault reached) | outcomes | success (control) | max time to stop s "
        "| collisions while faulted | unsafe |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for s in result["summary"]:
        outcomes = ", ".join(f"{k} {v}" for k, v in sorted(s["outcomes"].items()))
        stop = "-" if s["max_time_to_stop_s"] is None else f"{s['max_time_to_stop_s']:.2f}"
        lines.append(
            f"| {s['case']} | {s['expected']} | {s['episodes']} ({s['fault_reached']}) | {outcomes} | "
            f"{s['success']} ({s['control_success']}) | {stop} | {s['collisions_faulted']} | {s['unsafe']} |"
        )
    lines.append("")
    lines += [f"- {name}: {'met' if ok else 'NOT met'}" for name, ok in result["floors"].items()]
    return "\n".join(lines)
