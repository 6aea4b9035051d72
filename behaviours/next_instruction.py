"""NextInstruction: take the next instruction of a multi-object mission.

Semantics: pops the first entry of ``instructions_left`` into ``instruction`` (and its object phrase
into ``target_label``) and returns SUCCESS; FAILURE when the list is empty (the mission's loop ends).
The memory is kept: nodes seen while searching for one object help find the next.

Example:
    - type: NextInstruction
      name: Next
"""

from __future__ import annotations

import py_trees

from behaviours.base import SemExpBehaviour
from semexp_bt.core.relevance import instruction_target


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
