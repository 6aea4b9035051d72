"""How many of a mission's commanded twists the gait's trot prior stands still for.

The trained trot prior (``robots.gait_policy.TrotPrior``) gates its trot by the command's size: below
``TrotConfig.command_deadband`` it stands, above twice that it trots in full. The kinematic base moves at
any command. Since session 26 the run-time controller gates at ``WALKING_DEADBAND`` instead (ten times
lower) and corrects the policy's drift (docs/gait.md), so this script tells what the gait as trained would
have stood through, the measure that led to that change.

Reads a tick record (``semexp-bt run ... --record FILE``), holds the last ``/cmd_twist`` written at each
tick, and prints how many ticks carried a zero command, a non-zero one the prior stands for (gate 0), a
partial and a full trot, and which behaviours wrote the commands it stands for.

Usage:
    MUJOCO_GL=egl .venv/bin/semexp-bt run trees/object_search.yaml --scene road --seed 3 \\
        --fidelity dynamic --record /tmp/road3.jsonl
    .venv/bin/python scripts/command_gate_share.py /tmp/road3.jsonl
"""

from __future__ import annotations

import argparse
import collections
import json
from pathlib import Path

import numpy as np

from robots.gait_policy import TrotPrior


def gate_counts(record: Path) -> tuple[int, collections.Counter[str], collections.Counter[str]]:
    """(ticks, ticks by command class, writers of the commands the prior stands for)."""
    prior = TrotPrior()
    command: tuple[dict[str, float], str] | None = None
    classes: collections.Counter[str] = collections.Counter()
    standing_writers: collections.Counter[str] = collections.Counter()
    ticks = 0
    with record.open(encoding="utf-8") as lines:
        for line in lines:
            ticks += 1
            for write in json.loads(line).get("writes") or []:
                if write["key"] == "/cmd_twist":
                    command = (write["value"], write["client"])
            if command is None:
                continue
            twist, writer = command
            vector = np.array([[twist["linear_x_mps"], twist["linear_y_mps"], twist["angular_z_radps"]]])
            if not np.any(vector):
                classes["zero"] += 1
                continue
            gate = float(prior.gate(vector)[0])
            if gate == 0.0:
                classes["stands (gate 0)"] += 1
                standing_writers[writer] += 1
            else:
                classes["partial trot" if gate < 1.0 else "full trot"] += 1
    return ticks, classes, standing_writers


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("record", type=Path, help="a tick record (semexp-bt run --record FILE)")
    args = parser.parse_args()
    if not args.record.is_file():
        parser.error(f"{args.record}: no such file")
    ticks, classes, writers = gate_counts(args.record)
    moving = sum(n for kind, n in classes.items() if kind != "zero")
    print(f"{ticks} ticks; {moving} with a non-zero command")
    for kind in ("zero", "stands (gate 0)", "partial trot", "full trot"):
        share = (
            f" ({100.0 * classes[kind] / moving:.0f} % of the non-zero)" if kind != "zero" and moving else ""
        )
        print(f"  {kind}: {classes[kind]}{share}")
    print("commands the prior stands for, by writer:", dict(writers.most_common()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
