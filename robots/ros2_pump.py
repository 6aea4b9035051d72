"""Subscriptions whose messages the calling thread takes itself: one wake-up per lockstep reply.

In lockstep each tick is a request and a reply (``/sim/step`` out, ``/sim/state`` back; a render request
out, the frames back). Through an rclpy executor the reply costs a second thread: the executor thread
wakes, rebuilds its wait set in Python, runs the callback, notifies the waiting thread, which then wakes
too (and the two contend for the GIL). Measured on a whole mission (``scripts/profile_ros2_lockstep.py``,
docs/ros2.md) that was the largest part of a lockstep tick on both sides. A :class:`SubscriptionPump`
instead puts its subscriptions in a callback group no executor runs (:class:`CallerTakes`) and lets the
thread that waits for the reply wait on them itself (one rcl wait set, built once), take what is ready
and run the subscriptions' own callbacks, on that thread.

A wait that blocks costs two thread wake-ups per message (Fast DDS's receive thread, then the waiting
thread), each tens of microseconds on a virtual machine. In lockstep the reply usually comes within a few
hundred microseconds, so :meth:`SubscriptionPump.pump` can first poll the subscriptions the caller expects
the reply on, for ``spin_s`` (yielding the core between polls, so that the receive thread it waits for
runs), and block only if nothing came: the adaptive spinning of glibc's adaptive mutexes, applied to a
message. ``scripts/ros2_round_trip.py --spin-us`` measures both ways (docs/ros2.md).

Imported only where rclpy is (the ROS 2 backend and the bridge build one when they need it).
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
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

    def pump(self, timeout_s: float, *, spin_on: Sequence[Any] = (), spin_s: float = 0.0) -> int:
        """Wait up to ``timeout_s`` for a message on any subscription, then take the oldest message of
        each ready one and run its callback here; how many ran.

        One message per subscription and call: a lockstep reply is one message, and taking until the
        queue is empty costs a second, empty take per reply. What is left keeps its subscription ready,
        so the next call returns at once and takes it (in arrival order per subscription).

        ``spin_on`` (some of this pump's subscriptions) and ``spin_s``: first poll those for a message
        for up to ``spin_s`` (at most ``timeout_s``) without blocking, and return as soon as one ran; the
        blocking wait follows only if none came. The other subscriptions' messages wait for a blocking
        call meanwhile (a lockstep peer has one request or reply in flight at a time)."""
        subscriptions = self._subscriptions
        if not subscriptions:
            return 0
        if spin_on and spin_s > 0.0:
            ran = self._poll(spin_on, min(spin_s, timeout_s))
            if ran:
                return ran
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
        # Ready, yet a take may find nothing: only if the message expired.
        return sum(_take_one(s) for s in subscriptions if s.handle.pointer in ready)

    @staticmethod
    def drain(subscriptions: Sequence[Any]) -> int:
        """Take every message waiting on ``subscriptions`` (some of this pump's) without blocking, running
        each one's callback here; how many ran."""
        ran = 0
        for subscription in subscriptions:
            while _take_one(subscription):
                ran += 1
        return ran

    @staticmethod
    def _poll(subscriptions: Sequence[Any], spin_s: float) -> int:
        """Take from ``subscriptions`` until one yields a message (its callback runs here; 1) or
        ``spin_s`` has passed (0), yielding the core between rounds."""
        end = time.perf_counter() + spin_s
        while True:
            if any(_take_one(subscription) for subscription in subscriptions):
                return 1
            if time.perf_counter() >= end:
                return 0
            os.sched_yield()

    def close(self) -> None:
        """Release the wait set (before the node and the context go; idempotent)."""
        if self._wait_set is not None:
            self._wait_set.destroy_when_not_in_use()
            self._wait_set = None


def _take_one(subscription: Any) -> bool:
    """Take the oldest message waiting on ``subscription`` and run its callback here; whether there was
    one."""
    with subscription.handle:
        taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
    if taken is None:
        return False
    subscription.callback(taken[0])
    return True


__all__ = ["CallerTakes", "SubscriptionPump"]
