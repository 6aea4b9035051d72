"""NextInstruction alone: pops the next instruction (and its object phrase) until none is left."""

from __future__ import annotations

from collections.abc import Callable

from py_trees.common import Status

from behaviours.next_instruction import NextInstruction
from tests.behaviours.rig import Rig


def test_pops_each_instruction_in_turn_then_fails(make_rig: Callable[..., Rig]) -> None:
    rig = make_rig(
        instructions=("find the fire extinguisher", "find the red trash can", "find a black chair")
    )
    step = rig.build(NextInstruction)
    seen = []
    for _ in range(3):
        status = rig.tick(step)[0]
        seen.append((status, rig.get("instruction"), rig.get("target_label"), rig.get("instructions_left")))
    rig.show(step)
    assert seen == [
        (Status.SUCCESS, "find the red trash can", "red trash can", ["find a black chair"]),
        (Status.SUCCESS, "find a black chair", "black chair", []),
        (Status.FAILURE, "find a black chair", "black chair", []),  # nothing left: nothing written
    ]
    assert rig.written_by(step) == ["instructions_left", "instruction", "target_label"]
    assert [e["instruction"] for e in rig.services.events if e["kind"] == "next_instruction"] == [
        "find the red trash can",
        "find a black chair",
    ]


def test_fails_at_once_on_a_single_instruction_mission(rig: Rig) -> None:
    step = rig.build(NextInstruction)
    assert rig.tick(step) == [Status.FAILURE]
    rig.show(step)
    assert rig.written_by(step) == []
