"""Perceive alone: wait for a still base, submit one frame, RUNNING while the models think, then SUCCESS."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import pytest
from py_trees.common import Status

from behaviours.perceive import Perceive
from semexp_bt.core.types import Observation, Twist
from semexp_bt.perception.interface import PerceptionResult
from tests.behaviours.rig import Rig, compact, robot_among
from tests.test_executive import Post, seeing

EXTINGUISHER = Post(1, 2.0, 0.0, vlm_label="fire extinguisher", detector_label="fire extinguisher")


def rig_facing_the_extinguisher(make_rig: Callable[..., Rig], **kwargs: object) -> Rig:
    return make_rig(robot=robot_among(EXTINGUISHER), **kwargs)


def test_it_stops_the_base_then_perceives_once_and_writes_the_answer(make_rig: Callable[..., Rig]) -> None:
    rig = rig_facing_the_extinguisher(make_rig, script=[seeing([EXTINGUISHER])], latency_s=1.0)
    rig.robot.command_twist(Twist(linear_x_mps=0.5))  # still walking when perception is asked for
    perceive = rig.build(Perceive)
    waiting = rig.tick(perceive)
    assert perceive.feedback_message == "waiting for a stable viewpoint"
    assert rig.get("cmd_twist") == Twist.zero() and rig.get("observation") is None
    statuses = waiting + rig.tick_until_done(perceive)
    rig.show(perceive)
    assert compact(statuses) == ["RUNNING", "SUCCESS"]
    assert len(statuses) == 1 + 1 + 50  # waiting, submitting, 1 s of latency in 20 ms ticks
    assert len(rig.perception.requests) == 1
    assert [p.label for p in rig.get("scene_evidence").proposals][0] == "fire extinguisher"
    assert [d.label for d in rig.get("detections")] == ["fire extinguisher"]
    assert rig.get("observation").stamp_s == pytest.approx(0.02)
    assert rig.get("local_map").frames == 1
    assert rig.written_by(perceive) == [
        "cmd_twist",
        "cmd_stamp_s",
        "observation",
        "scene_evidence",
        "detections",
    ]


def test_a_source_that_is_missing_or_failed_is_recorded(make_rig: Callable[..., Rig]) -> None:
    def broken(observation: Observation) -> PerceptionResult:
        answer = seeing([EXTINGUISHER])(observation)
        return dataclasses.replace(answer, detections=None, errors=("detector endpoint refused",))

    rig = rig_facing_the_extinguisher(make_rig, script=[broken])
    perceive = rig.build(Perceive)
    assert rig.tick_until_done(perceive)[-1] == Status.SUCCESS
    rig.show(perceive)
    assert rig.get("detections") is None and rig.get("scene_evidence") is not None
    assert [(e["kind"], e["message"]) for e in rig.services.events] == [
        ("perception_error", "detector endpoint refused")
    ]


def test_no_answer_within_the_timeout_is_a_failure(make_rig: Callable[..., Rig]) -> None:
    rig = rig_facing_the_extinguisher(make_rig, latency_s=5.0)
    perceive = rig.build(Perceive, timeout_s=2.0)
    statuses = rig.tick_until_done(perceive, limit_s=10.0)
    rig.show(perceive)
    assert compact(statuses) == ["RUNNING", "FAILURE"]
    assert rig.robot.now_s() == pytest.approx(2.04, abs=0.021)
    assert [e["kind"] for e in rig.services.events] == ["perception_timeout"]
    assert rig.get("scene_evidence") is None


def test_halting_it_cancels_the_pending_request(make_rig: Callable[..., Rig]) -> None:
    rig = rig_facing_the_extinguisher(make_rig, latency_s=2.0)
    jobs = rig.record_jobs()
    perceive = rig.build(Perceive)
    assert rig.tick(perceive, ticks=5) == [Status.RUNNING] * 5
    rig.halt(perceive)
    assert len(jobs) == 1 and jobs[0].cancelled
    # A restart perceives afresh.
    assert compact(rig.tick_until_done(perceive)) == ["RUNNING", "SUCCESS"]
    assert len(jobs) == 2
