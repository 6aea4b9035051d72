"""NavFailureIs: a condition on why navigation to the subgoal last failed (``nav_failure``).

Semantics (a condition: it never returns RUNNING and holds no state):

- SUCCESS: ``nav_failure`` is one of ``kinds``.
- FAILURE: otherwise (also when nothing failed).

Reads ``nav_failure``; writes nothing. The recovery branch uses it to give an unreachable subgoal up at
once (``no_path``, ``start_blocked``) instead of spinning and backing up first.

Example:
    - type: NavFailureIs
      name: Unreachable
      params: {kinds: [no_path, start_blocked]}
"""

from __future__ import annotations

from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param

#: The values ``nav_failure`` takes (who writes them: ComputePathToSubgoal, FollowPath, StuckGuard,
#: WatchForTarget: ``superseded``, the subgoal handed back because the instructed object came into view;
#: WatchPlaceSeen: ``explored``, a place subgoal handed back because the cameras saw it on the way).
SUPERSEDED = "superseded"
EXPLORED = "explored"
NAV_FAILURES = ("no_path", "start_blocked", "blocked", "stuck", SUPERSEDED, EXPLORED)
#: The kinds that mean no plan reaches the subgoal (the default; each node gets its own checked copy).
UNREACHABLE_KINDS = ["no_path", "start_blocked"]


class NavFailureIs(SemExpBehaviour):
    READS = ("nav_failure",)

    kinds: list[str] = param(
        "list",
        doc=f"failure kinds that make it succeed (of {', '.join(NAV_FAILURES)})",
        items="str",
        default=UNREACHABLE_KINDS,
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        unknown = sorted(set(self.kinds) - set(NAV_FAILURES))
        if unknown:
            raise ValueError(
                f"NavFailureIs '{name}': unknown kinds {unknown}; expected some of {list(NAV_FAILURES)}"
            )

    def update(self) -> py_trees.common.Status:
        failure = self.read("nav_failure")
        self.feedback_message = f"nav_failure = {failure}"
        return py_trees.common.Status.SUCCESS if failure in self.kinds else py_trees.common.Status.FAILURE
