"""NavFailureIs alone: SUCCESS when ``nav_failure`` is one of the kinds, FAILURE otherwise."""

from __future__ import annotations

import pytest
from py_trees.common import Status

from behaviours.nav_failure_is import NavFailureIs
from tests.behaviours.rig import Rig


@pytest.mark.parametrize(
    ("failure", "status"), [("no_path", Status.SUCCESS), ("blocked", Status.FAILURE), (None, Status.FAILURE)]
)
def test_it_succeeds_only_on_the_listed_kinds(rig: Rig, failure: str | None, status: Status) -> None:
    rig.set("nav_failure", failure)
    condition = rig.build(NavFailureIs, kinds=["no_path", "start_blocked"])
    assert rig.tick(condition) == [status]
    rig.show(condition)
    assert rig.written_by(condition) == []


def test_an_unknown_kind_is_refused_at_build_time(rig: Rig) -> None:
    with pytest.raises(ValueError, match="unknown kinds"):
        rig.build(NavFailureIs, kinds=["lost"])
