"""Screening model replies at the executive's door: a reply that is not evidence is dropped, not used.

A model adapter turns a reply into :class:`~semexp_bt.perception.interface.PerceptionResult`; whatever it
lets through (a garbled VLM answer, a detector returning NaN) must not reach the arbitration, where it
would raise, nor the memory, where it would sit as a NaN node. :func:`screen_result` checks each
source's reply as a whole with the same rules the arbitration applies (finite points, boxes not inside
out, confidences in [0, 1], known proposal kinds) and replaces a reply that breaks one by "missing"
(``None``), adding the reason to ``errors``, which the behaviours log. A source that is missing is a case
the method already handles (Table I's single-source baselines).

Example:
    >>> from semexp_bt.core.types import SceneEvidence, SceneProposal
    >>> bad = PerceptionResult(SceneEvidence((SceneProposal((float("nan"), 1.0), "chair"),), 0.5), (), 0.0)
    >>> screened = screen_result(bad)
    >>> screened.scene is None, screened.errors
    (True, ('vlm reply rejected: scene.proposals[0].point_px must be finite, got (nan, 1.0)',))
"""

from __future__ import annotations

from dataclasses import replace

from semexp_bt.core.geometry import check_box
from semexp_bt.core.types import Detection, InvalidInputError, SceneEvidence, require_finite
from semexp_bt.perception.interface import PerceptionResult

#: Proposal kinds the arbitration knows.
PROPOSAL_KINDS = ("object", "direction")


def _require_unit_interval(name: str, value: float) -> None:
    require_finite(name, value)
    if not 0.0 <= float(value) <= 1.0:
        raise InvalidInputError(f"{name} must lie in [0, 1], got {value!r}")


def check_scene(scene: SceneEvidence) -> None:
    """Raise :class:`InvalidInputError` naming the field when the VLM reply is not usable evidence."""
    _require_unit_interval("scene.scene_confidence", scene.scene_confidence)
    for i, proposal in enumerate(scene.proposals):
        if not isinstance(proposal.label, str):
            raise InvalidInputError(f"scene.proposals[{i}].label must be text, got {proposal.label!r}")
        if proposal.kind not in PROPOSAL_KINDS:
            raise InvalidInputError(
                f"scene.proposals[{i}].kind must be one of {PROPOSAL_KINDS}, got {proposal.kind!r}"
            )
        if len(proposal.point_px) != 2:
            raise InvalidInputError(
                f"scene.proposals[{i}].point_px must hold 2 numbers, got {proposal.point_px!r}"
            )
        require_finite(f"scene.proposals[{i}].point_px", proposal.point_px)
        if proposal.region_px is not None:
            check_box(f"scene.proposals[{i}].region_px", proposal.region_px)


def check_detections(detections: tuple[Detection, ...]) -> None:
    """Raise :class:`InvalidInputError` naming the field when the detector reply is not usable evidence."""
    for i, detection in enumerate(detections):
        if not isinstance(detection.label, str):
            raise InvalidInputError(f"detections[{i}].label must be text, got {detection.label!r}")
        check_box(f"detections[{i}].box_xyxy_px", detection.box_xyxy_px)
        _require_unit_interval(f"detections[{i}].confidence", detection.confidence)


def screen_result(result: PerceptionResult) -> PerceptionResult:
    """``result`` with each source's reply that is not usable evidence replaced by ``None`` (see above)."""
    errors = list(result.errors)
    if result.scene is not None:
        try:
            check_scene(result.scene)
        except (InvalidInputError, TypeError) as exc:
            errors.append(f"vlm reply rejected: {exc}")
            result = replace(result, scene=None)
    if result.detections is not None:
        try:
            check_detections(tuple(result.detections))
        except (InvalidInputError, TypeError) as exc:
            errors.append(f"detector reply rejected: {exc}")
            result = replace(result, detections=None)
    return result if len(errors) == len(result.errors) else replace(result, errors=tuple(errors))
