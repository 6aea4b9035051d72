"""Trace one simulated episode: which robot part breaches the clearance, how the memory merges evidence, and
what each view near the goal gave the perception.

Three probes, any of them, printed as the episode runs (one line per event):

- ``--breaches``: each time an object enters the robot's clearance or collision set (the events OASR
  counts), the robot geom nearest to it, the distance, the commanded twist and the base's measured twist.
  Why: in dynamic fidelity a breach can come from a leg while the executive commands a stop.
- ``--merges TEXT``: each merge of an observation into a memory node whose label (before or after)
  contains ``TEXT``: the observation's label and C_f, the node's label, confidence and potential before
  and after (Eq. 6). Why: whether a label switch raised the potential decides whether the node stays a
  candidate.
- ``--views M``: each perceived frame in which the goal object is visible less than ``M`` metres away: its
  depth, pixels, truncation and bearing, the emulated detector's view-quality factors, and what the
  detector and the VLM reported of it. Why: a robot that stands at the goal and is refused confirmation
  lost its votes here.

The probes wrap two private methods (``MujocoRobot._record``, ``TopologicalMemory._merge_observation``)
and the emulator's ``emulate`` for this process only; the episode itself is the one ``semexp-bt run`` runs.

Usage:
    MUJOCO_GL=egl .venv/bin/python scripts/trace_episode.py --scene garden_sim --seed 0 --fidelity dynamic \\
        --max-sim-s 300 --breaches
    MUJOCO_GL=egl .venv/bin/python scripts/trace_episode.py --scene warehouse_b --seed 1 \\
        --instruction "find the extinguisher" --max-sim-s 86 --merges xting
"""

from __future__ import annotations

import argparse
import collections
import math
from typing import Any

#: Robot-to-object distances beyond this are not searched for the nearest geom (m).
GEOM_SEARCH_M = 0.3


def trace_breaches(counts: collections.Counter[str]) -> None:
    """Wrap ``MujocoRobot._record`` to print each new clearance or collision event's nearest robot geom."""
    import mujoco

    from robots import mujoco_backend

    original = mujoco_backend.MujocoRobot._record

    def record(self: Any, distances: dict[int, float]) -> None:
        before = {"clearance": set(self._in_clearance), "collision": set(self._in_collision)}
        original(self, distances)
        after = {"clearance": set(self._in_clearance), "collision": set(self._in_collision)}
        entered = [(kind, oid) for kind in after for oid in sorted(after[kind] - before[kind])]
        for kind, object_id in entered:
            nearest, geom = math.inf, "?"
            for obstacle in self._obstacle_geoms:
                if int(self._object_of_geom[obstacle]) != object_id:
                    continue
                for robot_geom in self._robot_geoms:
                    distance = mujoco.mj_geomDistance(
                        self.model, self.data, int(robot_geom), int(obstacle), GEOM_SEARCH_M, None
                    )
                    if distance < nearest:
                        name = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, int(robot_geom))
                        nearest, geom = distance, name or f"geom {int(robot_geom)}"
            counts[f"{kind} by {geom}"] += 1
            command, twist = self._command, self.base_twist()
            print(
                f"{self.now_s():7.2f} s  {kind}  object {object_id}  {nearest:.3f} m  by {geom}  "
                f"command ({command.linear_x_mps:.2f}, {command.angular_z_radps:.2f})  "
                f"base ({twist.linear_x_mps:.2f}, {twist.linear_y_mps:.2f}, {twist.angular_z_radps:.2f})",
                flush=True,
            )

    mujoco_backend.MujocoRobot._record = record  # type: ignore[method-assign]


def trace_merges(text: str) -> None:
    """Wrap ``TopologicalMemory._merge_observation`` to print the merges into nodes labelled with ``text``."""
    from semexp_bt.core.memory import graph

    original = graph.TopologicalMemory._merge_observation

    def merge(self: Any, n: int, p: Any, label: str, c_f: float, stamp: float, *rest: Any) -> Any:
        before = dict(self._attrs[n])
        result = original(self, n, p, label, c_f, stamp, *rest)
        after = self._attrs.get(n, before)
        if text in label or text in before["label"]:
            print(
                f"{stamp:7.2f} s  node {n}  {label!r} C_f={c_f:.2f} into {before['label']!r} "
                f"C={before['confidence']:.2f} P={before['potential']:.3f} -> {after['label']!r} "
                f"C={after['confidence']:.2f} P={after['potential']:.3f}",
                flush=True,
            )
        return result

    graph.TopologicalMemory._merge_observation = merge  # type: ignore[method-assign,assignment]


def trace_views(within_m: float) -> None:
    """Wrap the perception emulator's ``emulate`` to print every view of the goal closer than ``within_m``."""
    from sims import perception_emulator as emulator

    original = emulator.emulate

    def emulate(observation: Any, scene: Any, **options: Any) -> Any:
        result = original(observation, scene, **options)
        goal = scene.goal.object_id
        seen = emulator.analyse_view(observation, scene).get(goal)
        if seen is None or seen.depth_m >= within_m:
            return result
        noise = options.get("noise") or emulator._default_noise()
        motion = options.get("motion") or emulator.Twist.zero()
        profile = getattr(noise, options.get("detector_profile", "detector"))
        q = emulator.quality_factors(
            seen, profile.visibility, motion=motion, fx_px=observation.intrinsics.fx_px
        )
        boxes = [
            f"{report.kind} {result.detections[report.index].confidence:.2f}"
            for report in result.debug
            if report.source == "detector" and report.object_id == goal
        ]
        named = [
            report.kind for report in result.debug if report.source == "vlm" and report.object_id == goal
        ]
        print(
            f"{observation.stamp_s:7.2f} s  goal at {seen.depth_m:.2f} m, {seen.pixel_count} px, "
            f"truncation {seen.truncation:.2f}, off axis {seen.off_axis:.2f}, visible {seen.visible_fraction:.2f}"
            f" | q {q.quality:.2f} (distance {q.distance:.2f} area {q.area:.2f} occlusion {q.occlusion:.2f} "
            f"truncation {q.truncation:.2f} off axis {q.off_axis:.2f} blur {q.blur:.2f})"
            f" | detector {boxes or 'nothing'} | VLM {named or 'nothing'}",
            flush=True,
        )
        return result

    emulator.emulate = emulate


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", required=True)
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--instruction", default=None, help="default: the scene's own")
    parser.add_argument("--fidelity", choices=("kinematic", "dynamic"), default="kinematic")
    parser.add_argument("--max-sim-s", type=float, default=600.0)
    parser.add_argument("--breaches", action="store_true", help="trace clearance and collision events")
    parser.add_argument(
        "--merges", default=None, metavar="TEXT", help="trace merges into nodes labelled TEXT"
    )
    parser.add_argument(
        "--views", type=float, default=None, metavar="M", help="trace the views of the goal closer than M m"
    )
    args = parser.parse_args()
    if not args.breaches and args.merges is None and args.views is None:
        parser.error("choose --breaches, --merges TEXT, --views M, or several")
    import torch

    torch.set_num_threads(1)
    from semexp_bt.app.episode import EpisodeOptions, run_episode
    from semexp_bt.bench.sweep import default_mission_path

    counts: collections.Counter[str] = collections.Counter()
    if args.breaches:
        trace_breaches(counts)
    if args.merges is not None:
        trace_merges(args.merges)
    if args.views is not None:
        trace_views(args.views)
    record = run_episode(
        EpisodeOptions(
            mission_path=default_mission_path(),
            scene=args.scene,
            seed=args.seed,
            instruction=args.instruction,
            fidelity=args.fidelity,
            max_sim_s=args.max_sim_s,
        )
    )
    print(
        f"{record['outcome']} at {record['sim_time_s']:.1f} s, success={record['success']}, "
        f"{record['collisions']} contacts, {record['clearance_breaches']} breaches"
        + (f", nearest geoms {dict(counts)}" if args.breaches else "")
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
