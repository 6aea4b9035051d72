"""NavFailureIs ticked alone: a condition on nav_failure."""

import py_trees
import pytest

from behaviours.nav_failure_is import NavFailureIs
from tests.behaviours.nav_rig import make_rig

S = py_trees.common.Status


@pytest.mark.parametrize(
    ("failure", "status"), [("no_path", S.SUCCESS), ("blocked", S.FAILURE), (None, S.FAILURE)]
)
def test_it_succeeds_only_on_the_listed_kinds(failure: str | None, status: py_trees.common.Status) -> None:
    rig = make_rig()
    rig.set("nav_failure", failure)
    node = rig.build(NavFailureIs, kinds=["no_path", "start_blocked"])
    assert rig.tick(node) == [status]
    rig.show(node)


def test_an_unknown_kind_is_refused_at_build_time() -> None:
    with pytest.raises(ValueError, match="unknown kinds"):
        make_rig().build(NavFailureIs, kinds=["lost"])
