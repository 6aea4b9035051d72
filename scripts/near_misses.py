"""Where missions came close to the goal and how their confirmations went there (docs/planner.md, seventh round).

Two inputs, both written by the product:

- a sweep folder (``semexp-bt bench missions ... --trajectories N --out DIR``): per episode, its outcome and
  the nearest its base came to the goal's footprint (``SceneObject.boundary_distance_m`` over the
  trajectory, which the sweep keeps for the first N seeds);
- episode records (``semexp-bt run ... --json FILE``): every ``target_sighted``, ``confirmation_rejected``
  and ``target_confirmed`` event with the robot's distance to the goal at the next decision (decisions
  carry ``robot_xy``) and the event's reason.

Usage::

    .venv/bin/python scripts/near_misses.py --sweep runs/dev-s16
    .venv/bin/python scripts/near_misses.py --records runs/ep-warehouse_b-1001.json runs/ep-garden_sim-1000.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from sims.catalogue import build_scene  # noqa: E402

#: The events that say what perception and confirmation made of the goal.
CONFIRMATION_EVENTS = ("target_sighted", "confirmation_rejected", "target_confirmed")


def sweep_lines(folder: Path) -> list[str]:
    """One line per episode of a sweep: outcome, path, L*, final and nearest distance to the goal."""
    lines = []
    rows = [json.loads(line) for line in (folder / "episodes.jsonl").read_text().splitlines() if line.strip()]
    for row in sorted(rows, key=lambda r: (r["scene"], r["seed"])):
        goal = build_scene(row["scene"], seed=row["seed"]).goal
        nearest = None
        if row.get("trajectory_file"):
            xy = json.loads((folder / row["trajectory_file"]).read_text()).get("trajectory_xy") or []
            nearest = min((goal.boundary_distance_m((p[0], p[1])) for p in xy), default=None)
        near = "-" if nearest is None else f"{nearest:.2f}"
        lines.append(
            f"{row['scene']:12s} {row['seed']:5d} {'success' if row['success'] else row['outcome']:16s} "
            f"path {row['path_length_m']:6.1f} m  L* {row['geodesic_length_m']:5.1f} m  "
            f"end {row['distance_to_goal_m']:.2f} m  nearest {near} m"
        )
    return lines


def record_lines(record: dict[str, Any]) -> list[str]:
    """The confirmation events of one episode record with the robot's distance to the goal."""
    goal = build_scene(record["scene"], seed=record["seed"]).goal
    final = record["final_pose"]
    lines = [f"{record['scene']} {record['seed']}: {record['outcome']}, goal {goal.name}"]
    for event in record["events"]:
        if event["kind"] not in CONFIRMATION_EVENTS:
            continue
        later = [d["robot_xy"] for d in record["decisions"] if d["stamp_s"] >= event["stamp_s"]]
        xy = later[0] if later else [final["x_m"], final["y_m"]]
        what = event.get("reason") or event.get("label")
        lines.append(
            f"  {event['stamp_s']:6.1f} s {event['kind']:22s} robot {goal.boundary_distance_m(tuple(xy)):.2f} m "
            f"from the goal: {what}"
        )
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sweep", type=Path, help="a bench missions output folder")
    parser.add_argument("--records", type=Path, nargs="*", default=[], help="semexp-bt run --json files")
    args = parser.parse_args()
    if args.sweep is None and not args.records:
        parser.error("give --sweep DIR or --records FILE ...")
    lines = sweep_lines(args.sweep) if args.sweep is not None else []
    for path in args.records:
        lines += record_lines(json.loads(path.read_text()))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
