"""The one rule for comparing times on the robot's clock: every deadline, period and timeout.

The mission reads time only from the backend's clock (``Robot.now_s``). In process that clock is a float
sum of 20 ms steps; through ROS 2 it arrives as whole nanoseconds (``/clock``). The two differ in the last
bits, and a comparison without a tolerance (``now - t0 >= period``) flips at a tick where elapsed time
equals the period exactly: the ROS 2 helper measured one episode take 530 s of simulated time instead of
95 s from that alone (docs/ros2.md). So every such comparison goes through :func:`has_elapsed` (or
:func:`is_due`), which count a time within :data:`CLOCK_TOLERANCE_S` of the deadline as reached, and the
periodic work of a rate limiter through :func:`next_due_s`.

Example:
    >>> t = sum([0.02] * 400)  # 8 s of 20 ms ticks: 7.999999999999917 in float arithmetic
    >>> t >= 8.0, has_elapsed(since_s=0.0, now_s=t, duration_s=8.0)
    (False, True)

This is a core module: standard library only.
"""

from __future__ import annotations

#: Times this close to a deadline count as having reached it (s): far above the clock's rounding (float
#: sums of 20 ms steps, whole nanoseconds) and far below a tick (20 ms).
CLOCK_TOLERANCE_S = 1e-6


def is_due(*, now_s: float, due_s: float) -> bool:
    """Whether the clock has reached ``due_s`` (within :data:`CLOCK_TOLERANCE_S`)."""
    return now_s >= due_s - CLOCK_TOLERANCE_S


def has_elapsed(*, since_s: float, now_s: float, duration_s: float) -> bool:
    """Whether ``duration_s`` has passed between ``since_s`` and ``now_s`` (within the tolerance)."""
    return now_s - since_s >= duration_s - CLOCK_TOLERANCE_S


def next_due_s(*, due_s: float | None, now_s: float, period_s: float) -> float:
    """When work due at ``due_s`` and done at ``now_s`` is next due: on the grid ``due_s + k * period_s``
    (so the long-run rate is ``1 / period_s`` even when the caller's tick does not divide it), restarted
    from ``now_s`` after a stall of a whole period (no burst of catch-up). ``due_s`` None: first time.

    Example: a 4 Hz job served by a 12 Hz cycle quantised to 20 ms ticks, due at 0.25 s and run at
    0.26 s, is next due at 0.50 s, not 0.51 s.
    """
    if due_s is None or has_elapsed(since_s=due_s, now_s=now_s, duration_s=period_s):
        return now_s + period_s
    return due_s + period_s
