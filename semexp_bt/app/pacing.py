"""Holding a simulated mission to wall-clock pace, for real models that answer in wall-clock time.

The simulator runs a kinematic mission many times faster than real time. The perception emulator
charges its latency in simulated time, so that is right for it; a real model's worker thread answers
after real seconds, which the simulation would skip past in a blink (every request would look like a
time-out to ``Perceive``, and the mission budget would drain while the models think). With
:class:`WallClockPacer` among the observers, the runner's loop waits after each tick until the wall
clock has caught up with the robot's clock, so a model's latency costs the robot the time it would on
a real robot (``real_time_factor`` > 1 lets the simulation run that many times faster). The wait
happens between ticks, so the tree's tick times are unchanged. A simulation slower than that is not
slowed further.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from semexp_bt.app.runner import MissionRun


class WallClockPacer:
    """A ``TickObserver`` that sleeps between ticks while the robot's clock is ahead of the wall clock.

    Args:
        real_time_factor: at most this many robot seconds per wall second (1: real time).
        clock: wall seconds (injectable for tests).
        sleep: how it waits (injectable for tests).

    Attributes:
        slept_s: total time spent waiting.
    """

    wants_activity_stream = False

    def __init__(
        self,
        *,
        real_time_factor: float = 1.0,
        clock: Callable[[], float] = time.perf_counter,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if not real_time_factor > 0.0:
            raise ValueError(f"real_time_factor must be > 0, got {real_time_factor!r}")
        self.real_time_factor = real_time_factor
        self._clock = clock
        self._sleep = sleep
        self._wall0 = 0.0
        self._robot0 = 0.0
        self.slept_s = 0.0

    def start(self, run: MissionRun) -> None:
        self._wall0 = self._clock()
        self._robot0 = run.now_s()

    def after_tick(self, run: MissionRun) -> None:
        ahead = (run.now_s() - self._robot0) / self.real_time_factor - (self._clock() - self._wall0)
        if ahead > 0.0:
            self._sleep(ahead)
            self.slept_s += ahead

    def finish(self, run: MissionRun, outcome: str) -> None:
        del run, outcome
