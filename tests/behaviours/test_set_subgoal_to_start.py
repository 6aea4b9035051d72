"""SetSubgoalToStart alone: the master node becomes the subgoal; FAILURE without one."""

from __future__ import annotations

from py_trees.common import Status

from behaviours.set_subgoal_to_start import SetSubgoalToStart
from semexp_bt.core.types import Subgoal
from tests.behaviours.rig import Rig


def test_the_master_node_becomes_the_subgoal(rig: Rig) -> None:
    memory = rig.get("memory")
    master = memory.add_master(position_m=(1.0, 2.0, 0.0), stamp_s=0.0)
    memory.update(position_m=(4.0, 0.0, 0.3), label="chair", confidence=0.8, stamp_s=1.0)
    home = rig.build(SetSubgoalToStart)
    assert rig.tick(home) == [Status.SUCCESS]
    rig.show(home)
    assert rig.get("subgoal") == Subgoal(
        node_id=master, position_m=(1.0, 2.0, 0.0), label="start", utility=1.0
    )
    assert rig.written_by(home) == ["subgoal"]


def test_without_a_master_node_it_fails_and_writes_nothing(rig: Rig) -> None:
    home = rig.build(SetSubgoalToStart)
    assert rig.tick(home) == [Status.FAILURE]
    rig.show(home)
    assert rig.get("subgoal") is None and rig.written_by(home) == []
