"""What the shipped gait realises of small commands on flat ground, with and without command tracking.

Runs the gait bench's controller loop (``sims.gait_bench._run``: ramp, walking deadband, command tracking,
stance hold, near-fall recovery, as ``GaitController`` in a mission) on the nominal Go1, one robot per
command, and prints the body's mean forward speed (along the arc it walked) and yaw rate from ``--settle-s`` to ``--settle-s +
--measure-s``. ``--as-trained`` runs the controller as it was before command tracking: the trained prior's
deadband (0.05) and no correction.

Usage:
    .venv/bin/python scripts/measure_small_commands.py
    .venv/bin/python scripts/measure_small_commands.py --as-trained
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import numpy.typing as npt

import sims.gait_bench as gait_bench
from robots.gait_policy import CONTROL_DT_S, CommandTracking, TrotPrior, load_policy
from semexp_bt.core.types import FloatArray
from sims.gait_env import GaitEnv, _yaw_of

#: (vx m/s, yaw rate rad/s): creeps and slow turns a navigation controller asks for, and larger ones.
COMMANDS = (
    [(v, 0.0) for v in (0.03, 0.05, 0.07, 0.1, 0.15, 0.3)]
    + [(0.0, w) for w in (0.1, 0.15, 0.2, 0.3, 0.4, 0.6, -0.1, -0.15, -0.2, -0.3, -0.4)]
    + [(0.05, 0.1), (0.05, -0.3), (0.1, 0.3), (-0.1, 0.0)]
)


def _as_trained(
    prior: TrotPrior,
    tracking: CommandTracking,
    ramped: FloatArray,
    measured: FloatArray,
    recovering: npt.NDArray[np.bool_],
) -> tuple[FloatArray, FloatArray]:
    """The controller's walking rule before command tracking: the trained prior's gate, no correction."""
    return np.asarray(ramped, dtype=float), prior.gate(ramped)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--as-trained", action="store_true", help="trained deadband, no command tracking")
    parser.add_argument("--settle-s", type=float, default=3.0)
    parser.add_argument("--measure-s", type=float, default=5.0)
    args = parser.parse_args()
    policy = load_policy()
    if args.as_trained:
        gait_bench.walking_command = _as_trained
    commands = np.array([(v, 0.0, w) for v, w in COMMANDS])
    env = gait_bench._nominal_env(len(commands), trot_policy=policy, seed=0)
    settle = int(round(args.settle_s / CONTROL_DT_S))
    start: dict[str, FloatArray] = {}

    def hold(k: int, env: GaitEnv) -> None:
        env.commands[:] = commands
        if k == settle:
            start["xy"] = env.qpos[:, :2].copy()
            start["yaw"] = np.array([_yaw_of(q) for q in env.qpos[:, 3:7]])

    falls, _, _ = gait_bench._run(env, policy, settle + int(round(args.measure_s / CONTROL_DT_S)), hold)
    yaw = np.array([_yaw_of(q) for q in env.qpos[:, 3:7]])
    print(f"{'asked vx':>9} {'asked wz':>9} | {'walked vx':>9} {'walked wz':>9}")
    errors = []
    ends = zip(commands, start["xy"], env.qpos[:, :2], start["yaw"], yaw, strict=True)
    for command, xy0, xy1, yaw0, yaw1 in ends:
        turned = math.remainder(yaw1 - yaw0, math.tau)
        rate = turned / args.measure_s
        # A constant twist walks an arc: its length is the chord's times (half angle / sin(half angle)).
        half = 0.5 * turned
        arc_per_chord = half / math.sin(half) if abs(half) > 1e-6 else 1.0
        mid_heading = yaw0 + half
        forward = (
            (xy1 - xy0) @ [math.cos(mid_heading), math.sin(mid_heading)] * arc_per_chord / args.measure_s
        )
        errors.append((forward - command[0], rate - command[2]))
        print(f"{command[0]:>+9.2f} {command[2]:>+9.2f} | {forward:>+9.3f} {rate:>+9.3f}")
    rms = np.sqrt(np.mean(np.square(errors), axis=0))
    print(f"RMS error: vx {rms[0]:.3f} m/s, yaw rate {rms[1]:.3f} rad/s; falls {falls}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
