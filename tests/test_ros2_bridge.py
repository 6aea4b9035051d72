"""The lockstep bridge's order of asks (``sims/ros2_bridge.py``), its handlers called directly.

The executive takes a state the bridge sent ahead without waiting for the bridge to take its ask
(``Speculation``), so a render request or the outcome, on other topics that DDS does not order with
``/sim/step``, can reach the bridge before the step they follow. Each test drives one bridge with the
messages in that order and checks the render (or the end) is of the executive's instant, and the world
afterwards is a twin's that got them in order.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest

pytest.importorskip("rclpy", reason="the ROS 2 environment (make ros2-env) provides rclpy")

from robots.ros2_messages import fill_stamp, fill_twist
from robots.ros2_sim_protocol import CameraRequest, Outcome, encode_camera_request, encode_outcome
from semexp_bt.core.types import Twist
from sims.ros2_bridge import CONTROL_PERIOD_S, SPECULATION_DEPTH, BridgeOptions, SimBridge
from tests.ros2_support import fresh_domain_id, isolate_this_process

PERIOD_NS = int(round(CONTROL_PERIOD_S * 1e9))
TURN = Twist(0.3, 0.0, 0.4)


@pytest.fixture(scope="module")
def bridges() -> Iterator[tuple[SimBridge, SimBridge]]:
    """Two bridges of the same episode: one that speculates, one that steps only when asked."""
    isolate_this_process(fresh_domain_id())
    made = [
        SimBridge(BridgeOptions(scene="showroom", seed=9, speculate=speculate)) for speculate in (True, False)
    ]
    yield made[0], made[1]
    for bridge in made:
        bridge.close()


def _step(bridge: SimBridge, target_ns: int, twist: Twist) -> None:
    from geometry_msgs.msg import TwistStamped

    msg = TwistStamped()
    fill_stamp(msg.header.stamp, target_ns * 1e-9)
    fill_twist(msg.twist, twist)
    bridge._on_step(msg)


def _text(payload: str) -> Any:
    from std_msgs.msg import String

    msg = String()
    msg.data = payload
    return msg


def _pose_bits(bridge: SimBridge) -> tuple[tuple[float, ...], tuple[float, ...]]:
    position, orientation = bridge.robot.base_odometry()
    return tuple(position), tuple(orientation)


def test_a_render_asked_before_its_step_arrives_is_of_the_executives_instant(
    bridges: tuple[SimBridge, SimBridge],
) -> None:
    ahead, in_order = bridges
    start = ahead._asked_ns
    assert start == in_order._asked_ns == 0
    first, second = start + PERIOD_NS, start + 2 * PERIOD_NS
    for bridge in bridges:
        _step(bridge, first, TURN)
    # The states of the steps ahead went out.
    assert [s.from_ns for s in ahead._speculations] == [
        first + k * PERIOD_NS for k in range(SPECULATION_DEPTH)
    ]
    assert not in_order._speculations
    # The executive took the first one and then asked for a depth render at `second`, whose step ask is
    # still on its way: the bridge keeps that speculative step and renders there, leaving the steps
    # ahead of it in place (their states went out already).
    request = _text(encode_camera_request(CameraRequest(kind="depth", at_ns=second)))
    kept = ahead._speculated["kept"]
    ahead._on_camera_request(request)
    print({"asked_ns": ahead._asked_ns, "frames": ahead._frame_log[-1:], "speculated": ahead._speculated})
    assert ahead._asked_ns == second and ahead._speculated["kept"] == kept + 1
    assert ahead._frame_log[-1][0] == second
    assert ahead._speculated["taken_back"] == 0 and ahead._speculations[0].from_ns == second
    # Without a step ahead nothing reaches `second` until its ask comes: the render waits for it.
    in_order._on_camera_request(request)
    assert in_order._pending_renders and in_order._frame_log == []
    _step(in_order, second, TURN)
    assert not in_order._pending_renders and in_order._frame_log[-1][0] == second
    # The late ask is answered again, and both worlds are the same at `second` and after the next step.
    _step(ahead, second, TURN)
    assert ahead._asked_ns == second
    ahead._take_back_speculation()
    assert _pose_bits(ahead) == _pose_bits(in_order)
    third = start + 3 * PERIOD_NS
    for bridge in bridges:
        _step(bridge, third, TURN)
    ahead._take_back_speculation()
    assert _pose_bits(ahead) == _pose_bits(in_order)
    assert ahead.robot.now_s() == in_order.robot.now_s()


def test_an_outcome_before_the_last_steps_ask_ends_the_episode_at_the_executives_instant(
    bridges: tuple[SimBridge, SimBridge],
) -> None:
    ahead, _ = bridges
    last = ahead._asked_ns + PERIOD_NS
    _step(ahead, last, TURN)
    # The executive took every state sent ahead, then ended the mission.
    end = last + SPECULATION_DEPTH * PERIOD_NS
    ahead._on_outcome(_text(encode_outcome(Outcome("budget_exceeded", [], at_ns=end))))
    print({"asked_ns": ahead._asked_ns, "errors": ahead._errors, "stop": ahead._stop_reason})
    assert ahead._stop_reason == "mission_end" and ahead._outcome is not None
    assert ahead._asked_ns == end and ahead._now_ns() == end and not ahead._speculations
    assert not ahead._errors
    result = ahead.result(wall_s=1.0)
    assert json.dumps(result)  # the scoring is written as JSON
    assert result["outcome"] == "budget_exceeded"


def test_nothing_is_taken_ahead_of_the_first_step(bridges: tuple[SimBridge, SimBridge]) -> None:
    # A render's wait resends the last step ask; a bridge asked for its start instant before any step (an
    # empty ask) answers with the start and takes no step ahead: the executive takes every state it gets
    # before its first step as its start.
    del bridges  # only for the process's isolation
    fresh = SimBridge(BridgeOptions(scene="showroom", seed=9))
    try:
        _step(fresh, 0, Twist.zero())
        assert not fresh._speculations and fresh._step_replies["sent"] == 1  # the start, and nothing ahead
        fresh._on_camera_request(_text(encode_camera_request(CameraRequest(kind="depth", at_ns=0))))
        print({"asked_ns": fresh._asked_ns, "speculations": len(fresh._speculations), "steps": fresh._steps})
        assert fresh._asked_ns == 0 and fresh._steps == 0 and not fresh._speculations
        assert fresh._step_replies["repeated"] == 1 and fresh._frame_log[-1][0] == 0
        _step(fresh, PERIOD_NS, TURN)  # the first step: from here on it steps ahead
        assert len(fresh._speculations) == SPECULATION_DEPTH
    finally:
        fresh.close()
