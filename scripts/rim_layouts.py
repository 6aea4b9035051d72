"""Which scene layouts a goal-approach margin would reject: the table of docs/scenes.md, "A goal the robot can
stand beside".

For each scene and seed it builds the layout the rule before session 31 accepted (``GOAL_APPROACH_MARGIN_M``
set to 0 for this process only) and prints, for each margin, the layouts whose goal has no free cell of the
largest free region within the success radius less that margin.

Usage:
    .venv/bin/python scripts/rim_layouts.py --seeds 0-19,1000-1003
"""

from __future__ import annotations

import argparse

from semexp_bt.bench.sweep import parse_seeds
from sims.catalogue import build_scene, list_scenes
from sims.scenes import placement

MARGINS_M = (0.05, 0.1, 0.15, 0.2, 0.25, 0.3)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0-19,1000-1003", help="e.g. 0-19,1000-1003")
    args = parser.parse_args()
    placement.GOAL_APPROACH_MARGIN_M = 0.0  # the layouts the rim rule was written against
    rejected: dict[float, list[str]] = {margin: [] for margin in MARGINS_M}
    for name in list_scenes():
        for seed in parse_seeds(args.seeds):
            to_goal_m, region, _ = placement.goal_approach(build_scene(name, seed=seed))
            for margin in MARGINS_M:
                if not ((to_goal_m <= placement.GOAL_SUCCESS_RADIUS_M - margin) & region).any():
                    rejected[margin].append(f"{name}/{seed}")
    for margin, layouts in rejected.items():
        print(f"margin {margin:.2f} m: {len(layouts)} layouts rejected: {' '.join(layouts)}")


if __name__ == "__main__":
    main()
