"""Confidence-calibrated semantic evidence arbitration (paper Sec. III-C, Eq. 1-4).

Scene-level evidence (a VLM's proposals with one scene confidence C_s) and object-level evidence
(open-vocabulary detections with confidences C_o) are calibrated onto one scale (Eq. 1), associated by
maximum spatial overlap, scored by a posterior-like product (Eq. 2), and the best candidate is selected
with a normalised fused confidence C_f (Eq. 3); its image location fuses both sources (Eq. 4).

One module per step, composed by :func:`arbitrate`:

* :mod:`.candidates`: calibration (Eq. 1), the two sources read and checked, scene regions and candidate
  boxes, association by overlap, and the candidate table;
* :mod:`.score`: Eq. 2 and the depth-feasibility term kappa;
* :mod:`.fuse`: location fusion (Eq. 4) and selection with normalisation (Eq. 3);
* :mod:`.arbitration`: :func:`arbitrate` and its report; :mod:`.result`: what it returns.

Callers import from this package (``from semexp_bt.core.evidence import arbitrate``). Every choice the
paper leaves open is documented in ``docs/arbitration.md``.

This is a core package: standard library, numpy and ``semexp_bt`` core modules only.
"""

from semexp_bt.core.evidence.arbitration import arbitrate
from semexp_bt.core.evidence.candidates import calibrate, calibrate_array, candidate_box, scene_region
from semexp_bt.core.evidence.fuse import TIE_RELATIVE_TOLERANCE, ZERO_CONFIDENCE_OBJECT_WEIGHT
from semexp_bt.core.evidence.result import ArbitrationResult, CandidateSource, ScoredCandidate, TargetKind
from semexp_bt.core.evidence.score import depth_feasibility

__all__ = [
    "TIE_RELATIVE_TOLERANCE",
    "ZERO_CONFIDENCE_OBJECT_WEIGHT",
    "ArbitrationResult",
    "CandidateSource",
    "ScoredCandidate",
    "TargetKind",
    "arbitrate",
    "calibrate",
    "calibrate_array",
    "candidate_box",
    "depth_feasibility",
    "scene_region",
]
