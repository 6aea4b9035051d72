"""NextInstruction: take the next instruction of a multi-object mission.

Semantics (it never returns RUNNING and holds no state, so halting it changes nothing):

- SUCCESS: after popping the first entry of ``instructions_left`` into ``instruction`` (and its object
  phrase into ``target_label``) and logging a ``next_instruction`` event.
- FAILURE: when ``instructions_left`` is empty (the mission's loop ends); nothing is written.

Reads and writes ``instructions_left``; writes ``instruction`` and ``target_label``. The memory is kept:
nodes seen while searching for one object help find the next.

Example:
    - type: NextInstruction
      name: Next
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour
from semexp_bt.core.instruction import instruction_target


class NextInstruction(SemExpBehaviour):
    READS = ("instructions_left",)
    WRITES = ("instructions_left", "instruction", "target_label")

    def update(self) -> py_trees.common.Status:
        left = list(self.read("instructions_left", []))
        if not left:
            self.feedback_message = "no instructions left"
            return py_trees.common.Status.FAILURE
        instruction = left.pop(0)
        self.write("instructions_left", left)
        self.write("instruction", instruction)
        self.write("target_label", instruction_target(instruction))
        self.services.log_event("next_instruction", instruction=instruction)
        self.feedback_message = f"now: {instruction!r} ({len(left)} left)"
        return py_trees.common.Status.SUCCESS
