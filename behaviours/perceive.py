"""Perceive: event-triggered, asynchronous scene- and object-level perception at a stable viewpoint.

Semantics:

- RUNNING, waiting: until the base is still (a stable viewpoint: speed below ``stable_speed_mps`` and yaw
  rate below ``stable_yaw_rate_radps``), commanding a zero twist meanwhile.
- RUNNING, thinking: once still, it grabs one RGB-D frame, writes it to ``observation``, adds it to
  ``local_map`` (when there is one) and submits it to the perception service, which runs the VLM and the
  detector in parallel (sim-time latency in MuJoCo, worker threads on a real robot). It never blocks a
  tick.
- SUCCESS: when both sources have answered, after writing ``scene_evidence`` and ``detections`` (and
  logging each source's error as a ``perception_error`` event). A source whose reply is not usable
  evidence (NaN points, inverted boxes: ``semexp_bt.perception.validation``) is written as missing, with
  its error.
- FAILURE: when no answer has arrived ``timeout_s`` after it started (waiting included); a
  ``perception_timeout`` event is logged.
- Halted: the pending request is cancelled.

Reads ``instruction``, ``target_label`` and ``local_map``; writes ``observation``, ``scene_evidence``,
``detections``, ``cmd_twist`` and ``cmd_stamp_s`` (the zero twist while waiting), and ``local_map`` (the
frame added).

Example:
    - type: Perceive
      name: Perceive
      params: {timeout_s: 10}
"""

from __future__ import annotations

from typing import Any

import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.clock import has_elapsed
from semexp_bt.core.types import Twist
from semexp_bt.perception.interface import PerceptionJob
from semexp_bt.perception.validation import screen_result


class Perceive(SemExpBehaviour):
    READS = ("instruction", "target_label", "local_map")
    WRITES = ("observation", "scene_evidence", "detections", "cmd_twist", "cmd_stamp_s", "local_map")

    stable_speed_mps: float = param(
        "float", doc="base speed below which the viewpoint is stable, m/s", default=0.05, gt=0.0
    )
    stable_yaw_rate_radps: float = param(
        "float", doc="yaw rate below which the viewpoint is stable, rad/s", default=0.1, gt=0.0
    )
    timeout_s: float = param(
        "float", doc="FAILURE if the models have not answered after this long, s", default=15.0, gt=0.0
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self._job: PerceptionJob | None = None
        self._started_s = 0.0

    def initialise(self) -> None:
        self._job = None
        self._started_s = self.now_s()

    def _stable(self) -> bool:
        twist = self.services.robot.base_twist()
        speed = (twist.linear_x_mps**2 + twist.linear_y_mps**2) ** 0.5
        return speed < self.stable_speed_mps and abs(twist.angular_z_radps) < self.stable_yaw_rate_radps

    def update(self) -> py_trees.common.Status:
        robot = self.services.robot
        if has_elapsed(since_s=self._started_s, now_s=self.now_s(), duration_s=self.timeout_s):
            self.feedback_message = "perception timed out"
            self.services.log_event("perception_timeout")
            return py_trees.common.Status.FAILURE
        if self._job is None:
            if not self._stable():
                self.command(Twist.zero())
                self.feedback_message = "waiting for a stable viewpoint"
                return py_trees.common.Status.RUNNING
            observation = robot.observe()
            self.write("observation", observation)
            local_map = self.read("local_map")
            if local_map is not None:
                local_map.integrate(observation)
            self._job = self.submit_view(observation)
            self.feedback_message = "models thinking"
            return py_trees.common.Status.RUNNING
        result = self._job.poll(now_s=self.now_s())
        if result is None:
            return py_trees.common.Status.RUNNING
        result = screen_result(result)  # a reply that is not evidence is missing, not used
        self.write("scene_evidence", result.scene)
        self.write("detections", None if result.detections is None else tuple(result.detections))
        for error in result.errors:
            self.services.log_event("perception_error", message=error)
        n_det = "no" if result.detections is None else len(result.detections)
        self.feedback_message = f"{n_det} detections, " + (
            f"{len(result.scene.proposals)} proposals" if result.scene else "no scene evidence"
        )
        return py_trees.common.Status.SUCCESS

    def terminate(self, new_status: py_trees.common.Status) -> None:
        if new_status == py_trees.common.Status.INVALID and self._job is not None:
            self._job.cancel()
        self._job = None
