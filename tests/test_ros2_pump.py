"""The lockstep pump (``robots/ros2_pump.py``): the waiting thread takes its subscriptions' messages itself.

Checked on one node in this process (loopback DDS, a fresh domain): a pumped subscription's callback runs
on the thread that pumps, in arrival order, never on an executor that spins the same node (which still
runs the node's other subscriptions), one message per subscription and call, and a pump with nothing to
take returns after its timeout.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import pytest

pytest.importorskip("rclpy", reason="the ROS 2 environment (make ros2-env) provides rclpy")

from robots.ros2_backend import SIM_QOS, import_rclpy, qos_profile, ros_context
from tests.ros2_support import fresh_domain_id, isolate_this_process, wait_for


def test_pumped_messages_run_on_the_pumping_thread_and_never_on_the_executor() -> None:
    isolate_this_process(fresh_domain_id())
    rclpy = import_rclpy()
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import Float64

    from robots.ros2_pump import SubscriptionPump

    context = ros_context(rclpy)
    node = rclpy.create_node("pump_test", context=context, start_parameter_services=False)
    executor = SingleThreadedExecutor(context=context)
    try:
        pumped: list[tuple[float, str]] = []
        spun: list[tuple[float, str]] = []

        def on_pumped(msg: Any) -> None:
            pumped.append((msg.data, threading.current_thread().name))

        def on_spun(msg: Any) -> None:
            spun.append((msg.data, threading.current_thread().name))

        pump = SubscriptionPump(node)
        pump.subscribe(Float64, "/pump_test/pumped", on_pumped, qos_profile(SIM_QOS))
        node.create_subscription(Float64, "/pump_test/spun", on_spun, qos_profile(SIM_QOS))
        to_pumped = node.create_publisher(Float64, "/pump_test/pumped", qos_profile(SIM_QOS))
        to_spun = node.create_publisher(Float64, "/pump_test/spun", qos_profile(SIM_QOS))
        executor.add_node(node)
        spinner = threading.Thread(target=executor.spin, name="spinner", daemon=True)
        spinner.start()
        assert wait_for(
            lambda: to_pumped.get_subscription_count() and to_spun.get_subscription_count(), timeout_s=10
        )

        t0 = time.monotonic()
        assert pump.pump(0.2) == 0  # nothing queued: it waits out its timeout
        assert 0.15 <= time.monotonic() - t0 < 2.0

        for value in (1.0, 2.0, 3.0):
            to_pumped.publish(Float64(data=value))
            to_spun.publish(Float64(data=value))
        assert wait_for(lambda: len(spun) == 3, timeout_s=10)
        time.sleep(0.2)  # the executor had the time to (wrongly) take the pumped ones too
        assert pumped == []
        ran = pump.pump(1.0)
        assert ran == 1  # the oldest of the three: one message per subscription and call
        deadline = time.monotonic() + 10
        while ran < 3 and time.monotonic() < deadline:
            ran += pump.pump(1.0)
        me = threading.current_thread().name
        assert pumped == [(1.0, me), (2.0, me), (3.0, me)]
        assert [thread for _, thread in spun] == ["spinner"] * 3
        pump.close()
    finally:
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        context.try_shutdown()


def test_a_spinning_pump_polls_the_expected_reply_and_blocks_for_the_rest() -> None:
    isolate_this_process(fresh_domain_id())
    rclpy = import_rclpy()
    from std_msgs.msg import Float64

    from robots.ros2_pump import SubscriptionPump

    context = ros_context(rclpy)
    node = rclpy.create_node("spin_test", context=context, start_parameter_services=False)
    try:
        got: list[tuple[str, float, str]] = []
        pump = SubscriptionPump(node)

        def record(topic: str) -> Any:
            return lambda msg: got.append((topic, msg.data, threading.current_thread().name))

        reply = pump.subscribe(Float64, "/spin_test/reply", record("reply"), qos_profile(SIM_QOS))
        pump.subscribe(Float64, "/spin_test/other", record("other"), qos_profile(SIM_QOS))
        to_reply = node.create_publisher(Float64, "/spin_test/reply", qos_profile(SIM_QOS))
        to_other = node.create_publisher(Float64, "/spin_test/other", qos_profile(SIM_QOS))
        assert wait_for(
            lambda: to_reply.get_subscription_count() and to_other.get_subscription_count(), timeout_s=10
        )
        print(pump, "spins on", reply.topic_name)

        t0 = time.monotonic()
        assert pump.pump(0.2, spin_on=(reply,), spin_s=0.05) == 0  # polls 0.05 s, then blocks the rest
        assert 0.15 <= time.monotonic() - t0 < 2.0

        to_reply.publish(Float64(data=1.0))
        assert pump.pump(5.0, spin_on=(reply,), spin_s=5.0) == 1  # taken by the poll
        to_other.publish(Float64(data=2.0))
        ran, deadline = 0, time.monotonic() + 10
        while not ran and time.monotonic() < deadline:  # not polled: the blocking wait takes it
            ran = pump.pump(1.0, spin_on=(reply,), spin_s=0.01)
        me = threading.current_thread().name
        assert got == [("reply", 1.0, me), ("other", 2.0, me)]
        pump.close()
    finally:
        node.destroy_node()
        context.try_shutdown()
