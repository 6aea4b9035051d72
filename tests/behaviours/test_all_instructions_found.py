"""AllInstructionsFound alone: SUCCESS only when nothing is left and the current instruction was answered."""

from __future__ import annotations

import pytest
from py_trees.common import Status

from behaviours.all_instructions_found import AllInstructionsFound
from tests.behaviours.rig import INSTRUCTION, Rig


def found(instruction: str) -> dict[str, object]:
    return {
        "label": "x",
        "instruction": instruction,
        "robot_xy": [0, 0],
        "position_m": [0, 0, 0],
        "stamp_s": 0,
    }


@pytest.mark.parametrize(
    ("left", "found_for", "status"),
    [
        ([], [INSTRUCTION], Status.SUCCESS),
        ([], ["find the red trash can", INSTRUCTION], Status.SUCCESS),
        (["find the red trash can"], [INSTRUCTION], Status.FAILURE),
        ([], [], Status.FAILURE),
        ([], ["find the red trash can"], Status.FAILURE),
    ],
    ids=["current-found", "all-found", "one-left", "none-found", "current-not-found"],
)
def test_succeeds_only_with_nothing_left_and_the_current_instruction_found(
    rig: Rig, left: list[str], found_for: list[str], status: Status
) -> None:
    rig.set("instructions_left", left)
    rig.set("found_objects", [found(i) for i in found_for])
    done = rig.build(AllInstructionsFound)
    assert rig.tick(done, ticks=2) == [status, status]  # a condition: the same answer every tick
    rig.show(done)
    assert rig.written_by(done) == []


def test_halting_changes_nothing(rig: Rig) -> None:
    done = rig.build(AllInstructionsFound)
    rig.tick(done)
    rig.halt(done)
    assert done.status == Status.INVALID
    assert rig.get("found_objects") == [] and rig.written_by(done) == []
