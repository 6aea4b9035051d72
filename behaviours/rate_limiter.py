"""RateLimiter: tick a child at most at a given rate of backend time, holding its last status between.

The tree ticks at the gait rate (50 Hz in lockstep simulation) while some stages should run slower
(the path-following controller at 12 Hz, paper Sec. III-F); this decorator gives a subtree its own rate without a
second tree or a thread.

Semantics (a decorator):

- On a tick when the child is due (the first tick, the first after a halt, then on the grid
  ``first + k / rate_hz``; due by the one clock rule of ``semexp_bt.core.clock``): the child is ticked and its status (SUCCESS, FAILURE or RUNNING) is returned.
- On a tick in between: the child is not touched and its last status is returned again.
- Halted: the held status is dropped, so the next tick reaches the child at once.

Reads and writes no blackboard key (its child may); reads the backend clock (``BuildContext.clock``).

Example:
    - type: RateLimiter
      name: Follow12Hz
      params: {rate_hz: 12}
      children:
        - type: FollowPath
          name: FollowPath
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import ClassVar

import py_trees
from py_trees.common import Status

from behaviours.spec import BuildContext, ParamSpec
from semexp_bt.core.clock import is_due, next_due_s


class RateLimiter(py_trees.decorators.Decorator):
    """Tick the child at most ``rate_hz`` times per robot-clock second; between, repeat its last status.

    Child ticks are due on a fixed grid (``first + k / rate_hz``) so the long-run rate matches
    ``rate_hz`` even when it does not divide the tree's tick rate; after a stall longer than a period
    the grid restarts from now (no burst of catch-up ticks). In ``[t0, t]`` the child is ticked at most
    ``floor((t - t0) * rate_hz) + 1`` times. When the limiter is interrupted (stopped with ``INVALID``)
    the held status is dropped and the next tick reaches the child at once.
    """

    PARAMS: ClassVar[dict[str, ParamSpec]] = {
        "rate_hz": ParamSpec(
            "float", doc="highest rate at which the child is ticked (Hz, robot clock)", gt=0.0
        ),
    }

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, rate_hz: float, context: BuildContext):
        super().__init__(name=name, child=child)
        if not rate_hz > 0.0:
            raise ValueError(f"RateLimiter '{name}': rate_hz must be > 0, got {rate_hz!r}")
        self.rate_hz = float(rate_hz)
        self.period_s = 1.0 / self.rate_hz
        self._clock: Callable[[], float] = context.clock
        self._next_due_s: float | None = None
        self._held_status: Status | None = None
        self.child_ticks = 0
        """How many times the child has been ticked (for tests and the recorder)."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        now_s = self._clock()
        if (
            self._held_status is None
            or self._next_due_s is None
            or is_due(now_s=now_s, due_s=self._next_due_s)
        ):
            self._next_due_s = next_due_s(due_s=self._next_due_s, now_s=now_s, period_s=self.period_s)
            self.child_ticks += 1
            yield from super().tick()
            self._held_status = self.status
            return
        # Between due times: report the last status without touching the child.
        self.status = self._held_status
        self.feedback_message = f"holding {self._held_status.name} until t={self._next_due_s:.3f} s"
        yield self

    def update(self) -> Status:
        return self.decorated.status

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            self._held_status = None
