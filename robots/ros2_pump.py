"""Subscriptions whose messages the calling thread takes itself: one wake-up per lockstep reply.

In lockstep each tick is a request and a reply (``/sim/step`` out, ``/sim/state`` back; a render request
out, the frames back). Through an rclpy executor the reply costs a second thread: the executor thread
wakes, rebuilds its wait set in Python, runs the callback, notifies the waiting thread, which then wakes
too (and the two contend for the GIL). Measured on a whole mission (``scripts/profile_ros2_lockstep.py``,
docs/ros2.md) that was the largest part of a lockstep tick on both sides. A :class:`SubscriptionPump`
instead puts its subscriptions in a callback group no executor runs (:class:`CallerTakes`) and lets the
thread that waits for the reply wait on them itself (one rcl wait set, built once), take what is ready
and run the subscriptions' own callbacks, on that thread.

Imported only where rclpy is (the ROS 2 backend and the bridge build one when they need it).
"""

from __future__ import annotations

from contextlib import ExitStack
from typing import Any

from rclpy.callback_groups import CallbackGroup
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy


class CallerTakes(CallbackGroup):
    """A callback group no executor runs: its entities never enter an executor's wait set, so the
    messages of its subscriptions stay queued until :meth:`SubscriptionPump.pump` takes them."""

    def can_execute(self, entity: Any) -> bool:
        del entity
        return False

    def beginning_execution(self, entity: Any) -> bool:
        del entity
        return False

    def ending_execution(self, entity: Any) -> None:
        del entity


class SubscriptionPump:
    """Subscriptions of ``node`` served by whichever thread calls :meth:`pump` (one thread at a time).

    Args:
        node: the rclpy node the subscriptions belong to (it may also be spun by an executor: the
            executor leaves these alone).
    """

    def __init__(self, node: Any) -> None:
        self._node = node
        self.group = CallerTakes()
        self._subscriptions: list[Any] = []
        self._wait_set: Any = None

    def subscribe(self, msg_type: Any, topic: str, callback: Any, qos: Any) -> Any:
        """Create a subscription whose ``callback`` :meth:`pump` runs."""
        subscription = self._node.create_subscription(
            msg_type, topic, callback, qos, callback_group=self.group
        )
        self._subscriptions.append(subscription)
        self._wait_set = None  # sized to the subscriptions: rebuilt at the next pump
        return subscription

    def pump(self, timeout_s: float) -> int:
        """Wait up to ``timeout_s`` for a message on any subscription, then take the oldest message of
        each ready one and run its callback here; how many ran.

        One message per subscription and call: a lockstep reply is one message, and taking until the
        queue is empty costs a second, empty take per reply. What is left keeps its subscription ready,
        so the next call returns at once and takes it (in arrival order per subscription)."""
        subscriptions = self._subscriptions
        if not subscriptions:
            return 0
        context = self._node.context
        with ExitStack() as in_use:  # the handles may not be destroyed while rcl waits on them
            in_use.enter_context(context.handle)
            for subscription in subscriptions:
                in_use.enter_context(subscription.handle)
            if self._wait_set is None:
                self._wait_set = _rclpy.WaitSet(len(subscriptions), 0, 0, 0, 0, 0, context.handle)
            wait_set = self._wait_set
            wait_set.clear_entities()
            for subscription in subscriptions:
                wait_set.add_subscription(subscription.handle)
            wait_set.wait(max(int(timeout_s * 1e9), 0))
            ready = wait_set.get_ready_entities("subscription")
        ran = 0
        for subscription in subscriptions:
            if subscription.handle.pointer not in ready:
                continue
            with subscription.handle:
                taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
            if taken is not None:  # ready, yet taken by nobody else: None only if the message expired
                subscription.callback(taken[0])
                ran += 1
        return ran

    def close(self) -> None:
        """Release the wait set (before the node and the context go; idempotent)."""
        if self._wait_set is not None:
            self._wait_set.destroy_when_not_in_use()
            self._wait_set = None


__all__ = ["CallerTakes", "SubscriptionPump"]
