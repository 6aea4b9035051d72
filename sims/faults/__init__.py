"""Fault injection in simulation: fault lists as data (:mod:`sims.faults.spec`), and the decorators that
inject them between the executive and a robot (:mod:`sims.faults.robot`) or a perception source
(:mod:`sims.faults.perception`).

Example:
    >>> from sims.faults import parse_faults
    >>> [f.fault_class for f in parse_faults([{"class": "camera_drop", "start_s": 20, "duration_s": 5}], where="x")]
    ['camera_drop']
"""

from __future__ import annotations

from collections.abc import Sequence

from robots.interface import Robot
from semexp_bt.perception.interface import PerceptionSource
from sims.faults.perception import FaultyPerception
from sims.faults.robot import FaultyRobot
from sims.faults.spec import (
    FAULT_CLASSES,
    FaultClass,
    FaultSpec,
    FaultSpecError,
    load_faults_file,
    parse_fault,
    parse_faults,
)

__all__ = [
    "FAULT_CLASSES",
    "FaultClass",
    "FaultSpec",
    "FaultSpecError",
    "FaultyPerception",
    "FaultyRobot",
    "inject_faults",
    "load_faults_file",
    "parse_fault",
    "parse_faults",
]


def inject_faults(
    robot: Robot, perception: PerceptionSource, faults: Sequence[FaultSpec], *, seed: int
) -> tuple[Robot, PerceptionSource]:
    """The robot and the perception source behind the decorators that inject ``faults``.

    With no fault for a side, that side is returned as it is (a fault-free run pays nothing).
    """
    faulty_robot = (
        FaultyRobot(robot, faults, seed=seed) if any(f.kind.target == "robot" for f in faults) else None
    )
    if any(f.kind.target == "perception" for f in faults):
        start = robot.now_s()
        perception = FaultyPerception(perception, faults, elapsed_s=lambda: robot.now_s() - start, seed=seed)
    return (faulty_robot or robot), perception
