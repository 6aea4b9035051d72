"""SimTimeout: fail a child that is still running after a duration of backend (simulated or ROS) time.

py_trees' own ``Timeout`` reads ``time.monotonic()``; in lockstep simulation the wall clock and the
robot's clock disagree (a slow renderer would time out a healthy child, a fast one never would), so
this decorator reads the clock handed over in :class:`~behaviours.spec.BuildContext`.

Semantics (a decorator):

- The deadline is armed on entry (the first tick, or the first after it finished or was halted):
  ``now + duration_s``.
- Before the deadline: the child is ticked and its status (SUCCESS, FAILURE or RUNNING) is passed through.
- FAILURE: on a tick at or after the deadline with the child still RUNNING; the child is halted without
  being ticked again.
- Halted: the child is halted with it.

Reads and writes no blackboard key (its child may).

Example:
    - type: SimTimeout
      name: Execute
      params: {duration_s: 40}
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
from semexp_bt.core.clock import is_due


class SimTimeout(py_trees.decorators.Decorator):
    """Tick the child while less than ``duration_s`` of robot time has passed, then fail it.

    The deadline is armed when the decorator is entered (first tick, or first tick after it finished
    or was interrupted). On a tick at or after the deadline with the child still running, the child
    is stopped (``INVALID``) without being ticked again and the decorator returns ``FAILURE``; a child
    that finishes earlier passes its status through.
    """

    PARAMS: ClassVar[dict[str, ParamSpec]] = {
        "duration_s": ParamSpec("float", doc="time budget of the child in robot-clock seconds", gt=0.0),
    }

    def __init__(
        self, name: str, child: py_trees.behaviour.Behaviour, duration_s: float, context: BuildContext
    ):
        super().__init__(name=name, child=child)
        if not duration_s > 0.0:
            raise ValueError(f"SimTimeout '{name}': duration_s must be > 0, got {duration_s!r}")
        self.duration_s = float(duration_s)
        self._clock: Callable[[], float] = context.clock
        self._deadline_s = 0.0

    def initialise(self) -> None:
        self._deadline_s = self._clock() + self.duration_s
        self.feedback_message = ""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        # Checked before the child ticks: a child past its deadline must not act once more.
        if self.status == Status.RUNNING and is_due(now_s=self._clock(), due_s=self._deadline_s):
            self.feedback_message = f"timed out after {self.duration_s:g} s"
            self.stop(Status.FAILURE)  # Decorator.stop invalidates the running child
            yield self
            return
        yield from super().tick()

    def update(self) -> Status:
        if self.decorated.status == Status.RUNNING:
            self.feedback_message = f"{self._deadline_s - self._clock():.3f} s left"
        return self.decorated.status
