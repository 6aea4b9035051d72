"""Named strategies: the paper's method and its baselines as configurations of the same tree.

A strategy changes which perception sources run, hyperparameter overrides of the method, and named
switches a behaviour reads (``services.strategy``); it never forks the tree. The evidence strategies
follow the paper's Table I, the decision strategies its Table II, the ablation its Table IV.

Example:
    >>> resolve_strategy("detector_only").switches["evidence"]
    'detector_only'
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from semexp_bt.relevance import RelevanceScorer


@dataclass(frozen=True)
class Strategy:
    """One strategy.

    Attributes:
        name: its key.
        description: one line for reports.
        enable_vlm: run the scene-level source.
        enable_detector: run the object-level source.
        detector_profile: which emulated detector (``detector`` = GroundingDINO-like,
            ``detector_yolo_world``).
        config_overrides: SemExpConfig overrides (nested mapping).
        switches: named switches for behaviours (``evidence``, ``decision``).
    """

    name: str
    description: str
    enable_vlm: bool = True
    enable_detector: bool = True
    detector_profile: str = "detector"
    config_overrides: dict[str, Any] = field(default_factory=dict)
    switches: dict[str, str] = field(default_factory=dict)

    def make_perception(self, *, scene: Any, seed: int) -> Any:
        """The perception emulator for this strategy (simulation)."""
        from sims.perception_emulator import PerceptionEmulator

        return PerceptionEmulator(
            scene,
            seed=seed,
            detector_profile=self.detector_profile,  # type: ignore[arg-type]
            enable_vlm=self.enable_vlm,
            enable_detector=self.enable_detector,
        )

    def make_relevance(self, name: str) -> RelevanceScorer:
        """The relevance scorer (``embedding`` or ``lexical``), cached per (instruction, label)."""
        from semexp_bt.embedding_relevance import make_relevance_scorer

        return make_relevance_scorer(name)  # type: ignore[arg-type]


#: Naive fusion: no calibration (tau = 0) and no spatial or depth consistency terms.
_NAIVE = {"arbitration": {"tau": 0.0, "lambda_iou": 0.0, "mu": 0.0}}
#: Confidence-only ranking (the paper's "Bayesian probability" decision): only C_f counts.
_CONFIDENCE_ONLY = {"decision": {"alpha": 0.0, "beta": 1.0, "eta": 0.0, "gamma": 0.0}}
#: Relevance-only ranking (the paper's "GPT-4" decision): only S counts.
_RELEVANCE_ONLY = {"decision": {"alpha": 1.0, "beta": 0.0, "eta": 0.0, "gamma": 0.0}}
#: VLFM-style value frontier: value = relevance x confidence, highest value wins, no travel cost.
_VALUE_FRONTIER = {"decision": {"alpha": 1.0, "beta": 1.0, "eta": 0.0, "gamma": 0.0}}

STRATEGIES: dict[str, Strategy] = {
    s.name: s
    for s in (
        Strategy(
            "ours",
            "confidence-calibrated arbitration + utility decision (the paper's method)",
            switches={"evidence": "calibrated", "decision": "utility"},
        ),
        Strategy(
            "vlm_only",
            "scene-level VLM evidence only",
            enable_detector=False,
            switches={"evidence": "vlm_only", "decision": "utility"},
        ),
        Strategy(
            "detector_only",
            "object-level detector evidence only (GroundingDINO-like)",
            enable_vlm=False,
            switches={"evidence": "detector_only", "decision": "utility"},
        ),
        Strategy(
            "yolo_world",
            "object-level evidence only, YOLO-World-like detector profile",
            enable_vlm=False,
            detector_profile="detector_yolo_world",
            switches={"evidence": "yolo_world", "decision": "utility"},
        ),
        Strategy(
            "naive_fusion",
            "both sources, no calibration and no spatial consistency",
            config_overrides=_NAIVE,
            switches={"evidence": "naive_fusion", "decision": "utility"},
        ),
        Strategy(
            "bayesian",
            "rank nodes by fused confidence only",
            config_overrides=_CONFIDENCE_ONLY,
            switches={"evidence": "calibrated", "decision": "bayesian"},
        ),
        Strategy(
            "llm_relevance",
            "rank nodes by instruction relevance only",
            config_overrides=_RELEVANCE_ONLY,
            switches={"evidence": "calibrated", "decision": "llm_relevance"},
        ),
        Strategy(
            "vlfm",
            "VLFM-style value frontier: relevance x confidence, no travel cost",
            config_overrides=_VALUE_FRONTIER,
            switches={"evidence": "calibrated", "decision": "vlfm"},
        ),
        Strategy(
            "hovsg",
            "HOV-SG-style hierarchical choice: best region by mean relevance, then best node in it",
            switches={"evidence": "calibrated", "decision": "hovsg"},
        ),
        Strategy(
            "nearest_frontier",
            "geometry only: nearest node with high exploration potential",
            switches={"evidence": "calibrated", "decision": "nearest_frontier"},
        ),
        Strategy(
            "oracle",
            "PRIVILEGED reference: knows the goal position (GNSA's oracle as a policy)",
            switches={"evidence": "calibrated", "decision": "oracle"},
        ),
        Strategy(
            "ablation_baseline",
            "Table IV baseline: scene-level perception + confidence ranking",
            enable_detector=False,
            config_overrides=_CONFIDENCE_ONLY,
            switches={"evidence": "vlm_only", "decision": "bayesian"},
        ),
        Strategy(
            "ablation_arbitration",
            "Table IV: + evidence arbitration, confidence ranking",
            config_overrides=_CONFIDENCE_ONLY,
            switches={"evidence": "calibrated", "decision": "bayesian"},
        ),
    )
}


def resolve_strategy(name: str) -> Strategy:
    """The strategy called ``name``; a clear error listing the known ones otherwise."""
    try:
        return STRATEGIES[name]
    except KeyError:
        raise ValueError(f"unknown strategy {name!r}; expected one of {sorted(STRATEGIES)}") from None
