"""A ROS 2 listener the safety tests run as a process of its own: it logs ``/cmd_vel`` and ``/odom`` as a
driver's log would, one line per message, stamped with the steady clock (``time.monotonic``, which every
process of the machine shares) at receipt.

Usage: ``python -m tests.ros2_spy LOG`` (from the repository root) in the environment of :func:`tests.ros2_support.isolated_env`;
it writes ``ready`` once subscribed, then ``cmd T VX WZ`` and ``odom T SPEED`` lines, and ends on
SIGTERM. It is a process of its own because the tests time another process's exit: a listener in the
test's process would spin rclpy in a thread that shares the interpreter lock with the thread that
times, and a loaded 2-core machine once measured that contention (about 2 s) as the executive's.
"""

from __future__ import annotations

import math
import signal
import sys
import time


def main(log_path: str) -> int:
    import rclpy
    from geometry_msgs.msg import Twist
    from nav_msgs.msg import Odometry
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from robots.ros2_backend import ros_context

    context = ros_context(rclpy)
    node = rclpy.create_node("test_spy", context=context, start_parameter_services=False)
    log = open(log_path, "a", buffering=1)

    def on_twist(message: Twist) -> None:
        log.write(f"cmd {time.monotonic():.6f} {message.linear.x!r} {message.angular.z!r}\n")

    def on_odometry(message: Odometry) -> None:
        twist = message.twist.twist
        speed = math.hypot(twist.linear.x, twist.linear.y) + abs(twist.angular.z)
        log.write(f"odom {time.monotonic():.6f} {speed!r}\n")

    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    node.create_subscription(Twist, "/cmd_vel", on_twist, best_effort)
    node.create_subscription(Odometry, "/odom", on_odometry, best_effort)
    stopping = []
    signal.signal(signal.SIGTERM, lambda *_: stopping.append(True))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    log.write("ready\n")
    while not stopping:
        executor.spin_once(timeout_sec=0.05)
    log.close()
    executor.shutdown(timeout_sec=1.0)
    node.destroy_node()
    context.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
