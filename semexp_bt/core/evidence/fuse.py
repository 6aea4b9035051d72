"""Fusion of the candidates: where each lies (paper Eq. 4) and which one wins, with what confidence (Eq. 3).

This is a core module: standard library, numpy and ``semexp_bt`` core modules only.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from semexp_bt.core.evidence.candidates import CandidateTable
from semexp_bt.core.types import FloatArray

#: Scores within this relative distance of the maximum are a tie (broken by candidate order, see
#: :func:`select`), so that two candidates whose scores differ only by float rounding are treated alike.
TIE_RELATIVE_TOLERANCE = 1e-9

#: Location weight w of Eq. 4 when both calibrated terms are 0 (the 0/0 case): the midpoint, since
#: neither source is preferred. Such a candidate has S = 0 and can only be reported, never selected.
ZERO_CONFIDENCE_OBJECT_WEIGHT = 0.5


def fuse_locations(
    table: CandidateTable, terms: tuple[FloatArray, FloatArray]
) -> tuple[FloatArray, FloatArray]:
    """Eq. 4: ``p_t = w p_o + (1 - w) p_s`` with ``w = C~_o^beta_o / (C~_o^beta_o + C~_s^beta_s)``.

    Args:
        table: the candidates.
        terms: their confidence terms (``score.confidence_terms``, the same powers as in Eq. 2).

    Returns:
        ``(weights, pixels)``: ``(K,)`` w (:data:`ZERO_CONFIDENCE_OBJECT_WEIGHT` where both terms are 0;
        meaningful for fused candidates only) and ``(K, 2)`` p_t: the fused location of a fused candidate,
        else the location of its one source.
    """
    term_o, term_s = terms
    denom = term_o + term_s
    weight = np.where(denom > 0.0, term_o / np.where(denom > 0.0, denom, 1.0), ZERO_CONFIDENCE_OBJECT_WEIGHT)
    p_o, p_s = table.object_pixels, table.scene_pixels
    fused_px = weight[:, None] * p_o + (1.0 - weight[:, None]) * p_s
    pixels = np.where(table.fused[:, None], fused_px, np.where(table.has_object[:, None], p_o, p_s))
    return weight, pixels


class Selection(NamedTuple):
    """Eq. 3's outcome.

    Attributes:
        normalised: ``(K,)`` S(t) / sum S, all 0 when every S is 0.
        winner: index of the selected candidate, None when every S is 0.
        best_score: the largest S.
    """

    normalised: FloatArray
    winner: int | None
    best_score: float


def select(score: FloatArray) -> Selection:
    """Eq. 3: the candidate of largest S, with ``C_f = S / sum S``.

    Scores within :data:`TIE_RELATIVE_TOLERANCE` of the maximum are tied, and the first tied candidate in
    table order (detection-derived before scene-only, then by input index) wins.
    """
    total = float(score.sum())
    best_score = float(score.max())
    if not total > 0.0:  # every S is 0: no winner
        return Selection(normalised=np.zeros(len(score)), winner=None, best_score=best_score)
    winner = int(np.argmax(score >= best_score * (1.0 - TIE_RELATIVE_TOLERANCE)))
    return Selection(normalised=score / total, winner=winner, best_score=best_score)
