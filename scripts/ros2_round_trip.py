"""What one lockstep hand-over costs at the least: a DDS round trip between two processes, nothing else.

Run it in the ROS 2 environment, on loopback only::

    scripts/ros2_isolated.sh .venv-ros2/bin/python scripts/ros2_round_trip.py --count 3000

Two processes, as the bridge and the executive: one publishes a ``/sim/state``-sized message
(std_msgs/Float64MultiArray of :data:`robots.ros2_sim_protocol.STATE_FIELDS` values and the Go1's joints) with the lockstep
step's QoS (best effort, ``SIM_STEP_QOS``; ``--reliable`` for the other ``/sim`` topics' ``SIM_QOS``) and
waits for the other's reply, which answers each message with one of its own. Both take their messages
with the lockstep pump (``robots/ros2_pump.py``), polling for ``--spin-us`` first as the lockstep does
(default ``LOCKSTEP_SPIN_S``; ``--spin-us 0``: block at once). It prints the round trip's median, mean
and 90th percentile in microseconds, the asking side's publish (median) and its thread's CPU time per round
trip: the floor under every lockstep step (one round trip per tick), which
no change to the bridge or the executive can go below on this transport (docs/ros2.md).
"""

from __future__ import annotations

import argparse
import array
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from robots.go1 import load_go1_spec  # noqa: E402
from robots.ros2_backend import (  # noqa: E402
    LOCKSTEP_SPIN_S,
    SIM_QOS,
    SIM_STEP_QOS,
    import_rclpy,
    qos_profile,
    ros_context,
)
from robots.ros2_pump import SubscriptionPump  # noqa: E402
from robots.ros2_sim_protocol import STATE_FIELDS  # noqa: E402

PING, PONG = "/round_trip/ping", "/round_trip/pong"
#: The value that tells the answering process to stop.
STOP = -1.0


def serve(role: str, count: int, *, reliable: bool, spin_s: float) -> dict[str, float] | None:
    """``ask``: send ``count`` messages one at a time and time each answer; ``answer``: reply to each."""
    rclpy = import_rclpy()
    from std_msgs.msg import Float64MultiArray

    context = ros_context(rclpy)
    node = rclpy.create_node(f"round_trip_{role}", context=context, start_parameter_services=False)
    pump = SubscriptionPump(node)
    received: list[float] = []
    out_topic, in_topic = (PING, PONG) if role == "ask" else (PONG, PING)
    qos = qos_profile(SIM_QOS if reliable else SIM_STEP_QOS)
    publisher = node.create_publisher(Float64MultiArray, out_topic, qos)
    reply = pump.subscribe(Float64MultiArray, in_topic, lambda msg: received.append(msg.data[0]), qos)
    msg = Float64MultiArray()
    msg.data = array.array("d", [0.5] * (len(STATE_FIELDS) + 2 * len(load_go1_spec().joint_names)))
    try:
        if role == "answer":
            while True:
                pump.pump(1.0, spin_on=(reply,), spin_s=spin_s)
                if received:
                    stop = STOP in received
                    received.clear()
                    if stop:
                        return None
                    publisher.publish(msg)
        while publisher.get_subscription_count() == 0 or node.count_publishers(in_topic) == 0:
            pump.pump(0.05)
        time.sleep(0.5)  # discovery settles
        times, publishes = [], []
        cpu_start = time.thread_time()
        for _ in range(count + 1):  # the first one warms the path up
            start = time.perf_counter()
            publisher.publish(msg)
            publishes.append(time.perf_counter() - start)
            while not received:
                pump.pump(1.0, spin_on=(reply,), spin_s=spin_s)
            received.clear()
            times.append(time.perf_counter() - start)
        cpu_per_round_trip_us = (time.thread_time() - cpu_start) / (count + 1) * 1e6
        msg.data = array.array("d", [STOP])
        publisher.publish(msg)
        time.sleep(0.2)
        us = np.array(times[1:]) * 1e6
        return {
            "round_trips": count,
            "median_us": float(np.median(us)),
            "mean_us": float(us.mean()),
            "p90_us": float(np.percentile(us, 90)),
            # What the asking thread spends of each round trip: its publish (to another process), and its
            # CPU time (publish, wait, take and callback; not the other process's).
            "publish_median_us": float(np.median(publishes[1:]) * 1e6),
            "asker_cpu_per_round_trip_us": cpu_per_round_trip_us,
        }
    finally:
        pump.close()
        node.destroy_node()
        context.try_shutdown()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=3000)
    parser.add_argument("--reliable", action="store_true", help="reliable QoS (SIM_QOS), not best effort")
    parser.add_argument(
        "--spin-us",
        type=float,
        default=LOCKSTEP_SPIN_S * 1e6,
        help="poll this long before blocking (0: never)",
    )
    parser.add_argument("--role", choices=("ask", "answer"), default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role is not None:
        figures = serve(args.role, args.count, reliable=args.reliable, spin_s=args.spin_us * 1e-6)
        if figures is not None:
            print(json.dumps(figures))
        return 0
    link = [*(["--reliable"] if args.reliable else []), "--spin-us", str(args.spin_us)]
    answer = subprocess.Popen([sys.executable, __file__, "--role", "answer", *link], cwd=ROOT)
    try:
        asked = subprocess.run(
            [sys.executable, __file__, "--role", "ask", "--count", str(args.count), *link],
            cwd=ROOT, check=True, capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        print(asked.stdout.strip().splitlines()[-1])
    finally:
        try:
            answer.wait(timeout=10)
        except subprocess.TimeoutExpired:
            answer.kill()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
