"""The phrasing benchmark's bookkeeping (semexp_bt.bench.phrasing): specs, classes of rows, floors."""

from __future__ import annotations

from typing import Any

from semexp_bt.bench.phrasing import CANONICAL, load_phrasings, phrasing_specs, summarize
from semexp_bt.bench.sweep import SweepSpec
from sims.catalogue import build_scene, list_scenes


def test_every_scene_has_every_class_and_the_canonical_is_the_scenes_own() -> None:
    phrasings = load_phrasings()
    assert len(phrasings.paraphrase_classes) >= 6
    for scene in list_scenes():
        assert phrasings.instruction(scene, CANONICAL) == build_scene(scene, seed=0).instruction
        texts = {phrasings.instruction(scene, c) for c in phrasings.classes}
        assert len(texts) == len(phrasings.classes), f"{scene}: two classes share an instruction"


def test_specs_share_episodes_and_the_canonical_keeps_the_ordinary_sweep_key() -> None:
    specs = phrasing_specs(
        scenes=["office"], seeds=[0, 1], classes=[CANONICAL, "synonym", "absent"], relevance="lexical"
    )
    keys = [t.key for spec in specs for t in spec.tasks()]
    assert {(k.scene, k.seed) for k in keys} == {("office", 0), ("office", 1)}
    assert len({k.config_hash for k in keys}) == 3  # one per class
    plain = SweepSpec(scenes=("office",), seeds=(0, 1), strategies=("ours",), relevance="lexical")
    assert specs[0].config_hash("ours") == plain.config_hash("ours")


def _row(scene: str, instruction: str, *, success: bool, declared: bool, role: str | None) -> dict[str, Any]:
    return {"status": "ok", "scene": scene, "instruction": instruction, "success": success,
            "success_declared": declared, "reached_object": None if role is None else {"role": role}}  # fmt: skip


def test_summary_counts_classes_and_judges_the_floors() -> None:
    phrasings = load_phrasings()
    scene = "office"
    say = {c: phrasings.instruction(scene, c) for c in phrasings.classes}
    rows = [
        _row(scene, say[CANONICAL], success=True, declared=True, role="goal"),
        _row(scene, say["synonym"], success=True, declared=True, role="goal"),
        _row(scene, say["question"], success=False, declared=True, role="distractor"),  # a false success
        _row(scene, say["distractor"], success=False, declared=True, role="goal"),
        _row(scene, say["absent"], success=False, declared=False, role=None),
    ]
    summary = summarize(rows, phrasings)
    print(summary["floors"])
    classes = summary["classes"]
    assert classes[CANONICAL]["sr_percent"] == 100.0 and classes["synonym"]["sr_percent"] == 100.0
    assert classes["question"]["declared_at_a_distractor"] == 1
    floors = summary["floors"]
    assert floors["synonym: SR within 5 points of canonical"]
    assert not floors["question: SR within 5 points of canonical"]
    assert not floors["goal asked for: no success declared at a distractor"]
    assert not floors["distractor named: success never declared at the goal"]
    assert floors["absent object: 0 successes declared"]
    assert "plural: SR within 5 points of canonical" not in floors  # not run, not judged
