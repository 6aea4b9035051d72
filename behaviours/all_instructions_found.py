"""AllInstructionsFound: did the mission confirm an object for every instruction?

Semantics (a condition: it never returns RUNNING and holds no state, so halting it changes nothing):

- SUCCESS: ``instructions_left`` is empty and ``found_objects`` holds a confirmed object for the current
  ``instruction`` (ConfirmTarget records each object under the instruction it answered).
- FAILURE: otherwise.

Reads ``instructions_left``, ``found_objects`` and ``instruction``; writes nothing. It ends a
multi-object mission's loop with the right outcome.

Example:
    - type: AllInstructionsFound
      name: AllFound
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour


class AllInstructionsFound(SemExpBehaviour):
    READS = ("instructions_left", "found_objects", "instruction")

    def update(self) -> py_trees.common.Status:
        left = self.read("instructions_left", [])
        found = self.read("found_objects", [])
        found_for = {entry["instruction"] for entry in found}
        done = not left and self.read("instruction") in found_for
        self.feedback_message = f"{len(found_for)} found, {len(left)} left"
        return py_trees.common.Status.SUCCESS if done else py_trees.common.Status.FAILURE
