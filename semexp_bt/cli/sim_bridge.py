"""``semexp-bt sim-bridge --scene S --seed N [--fidelity F] [--json RESULT]``: the MuJoCo world on ROS 2.

Publishes what the Go1 driver and realsense-ros publish (the robot profile's topics) plus ``/clock``,
obeys ``/cmd_vel``, and writes the episode's scoring to RESULT when the executive reports the mission's
end, or on SIGINT/SIGTERM (``sims/ros2_bridge.py``; docs/ros2.md). Run the executive beside it with
``semexp-bt run MISSION --backend ros2``. Needs rclpy (the ROS 2 environment, ``make ros2-env``).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path
from types import FrameType

from robots.ros2_sim_protocol import BRIDGE_MODES


def _silence(text: str) -> tuple[str, float]:
    stream, _, after = text.partition("=")
    try:
        return stream, float(after)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected STREAM=SECONDS, got {text!r}") from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scene", required=True, help="scene name (see `semexp-bt scene list`)")
    parser.add_argument("--seed", type=int, default=0, help="seed for layout, start pose and sensor noise")
    parser.add_argument(
        "--fidelity", choices=("kinematic", "dynamic"), default="kinematic", help="robot fidelity"
    )
    parser.add_argument(
        "--mode",
        choices=BRIDGE_MODES,
        default="lockstep",
        help="lockstep: one step per executive tick, renders on request (default); realtime: wall clock",
    )
    parser.add_argument(
        "--robot-profile", type=Path, default=None, help="robot profile (default: robots/go1/ros2.yaml)"
    )
    parser.add_argument(
        "--camera-hz", type=float, default=15.0, help="realtime mode: camera frames per second"
    )
    parser.add_argument("--json", type=Path, default=None, help="write the episode's scoring here")
    parser.add_argument(
        "--max-sim-s", type=float, default=900.0, help="end the episode at this simulated time"
    )
    parser.add_argument("--max-wall-s", type=float, default=None, help="end after this much wall time")
    parser.add_argument(
        "--silence",
        type=_silence,
        action="append",
        default=[],
        metavar="STREAM=SECONDS",
        help="fault injection (tests): stop publishing STREAM (odom, imu, color_image, ...) after SECONDS of "
        "simulated time",
    )
    parser.add_argument(
        "--drop-step-replies",
        type=int,
        default=0,
        metavar="N",
        help="fault injection (tests, lockstep): leave every N-th step unanswered, as if its reply were lost",
    )
    parser.add_argument(
        "--no-speculation",
        dest="speculate",
        action="store_false",
        help="lockstep: step only when the executive asks (by default a kinematic bridge takes the next step "
        "ahead while the executive ticks and takes it back if another is asked for; the same states either way)",
    )


def run(args: argparse.Namespace) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    import torch

    torch.set_num_threads(1)
    from robots.ros2_backend import Ros2Error
    from semexp_bt.cli.process_end import bound_the_teardown, dump_stacks_on_request
    from sims.ros2_bridge import BridgeOptions, SimBridge

    dump_stacks_on_request()

    try:
        bridge = SimBridge(
            BridgeOptions(
                scene=args.scene,
                seed=args.seed,
                fidelity=args.fidelity,
                mode=args.mode,
                profile_path=args.robot_profile,
                result_path=args.json,
                camera_hz=args.camera_hz,
                silence=dict(args.silence),
                drop_step_replies=args.drop_step_replies,
                speculate=args.speculate,
                max_sim_s=args.max_sim_s,
                max_wall_s=args.max_wall_s,
            )
        )
    except (ValueError, Ros2Error) as exc:  # ProfileError, InvalidInputError, unknown scene, no rclpy
        print(f"error: {exc}", file=sys.stderr)
        return 2

    def on_signal(signum: int, frame: FrameType | None) -> None:
        del frame
        bridge.request_stop(signal.Signals(signum).name)

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    print(
        f"sim-bridge: {args.scene} seed {args.seed}, {args.fidelity}, {args.mode}; "
        f"goal hidden from the executive; serving {bridge.profile.source}",
        flush=True,
    )
    try:
        result = bridge.run()  # writes the result file
    finally:
        bound_the_teardown()
        bridge.close()
    reached = result["reached_object"]["label"] if result["reached_object"] else "nothing"
    print(
        f"{result['scene']} seed {result['seed']}: {result['outcome']} | success={result['success']}"
        f" | reached {reached} | goal {result['goal']['label']} | path {result['path_length_m']:.1f} m"
        f" (L* {result['geodesic_length_m']:.1f} m) | collisions {result['collisions']}"
        f" | ended by {result['ended_by']} | sim {result['sim_time_s']:.1f} s in {result['wall_time_s']:.1f} s wall"
    )
    for error in result["errors"]:
        print(f"warning: {error}", file=sys.stderr)
    return 0
