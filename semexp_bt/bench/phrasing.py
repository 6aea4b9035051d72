"""The phrasing benchmark: the same episodes with the scene's own instruction and with other wordings.

Per scene, ``phrasings.yaml`` (next to this module, written before any of it was run) holds one
instruction per phrasing class: paraphrase classes (synonym, attribute, question, request, misspelling,
plural, relative clause) must find the goal as the scene's own (``canonical``) instruction does; the
``distractor`` class names the scene's distractor (success counts only at an object of that kind, never
at the goal); the ``absent`` class names something no scene holds (every declared success is false).
Each class runs on the same scenes and seeds, so every comparison is on matched episodes.

Example::

    semexp-bt bench phrasing --scenes all --seeds 0-4 --out runs/phrasing
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from semexp_bt.bench.sweep import SweepSpec
from semexp_bt.core.durable import write_atomic, write_json
from sims.catalogue import build_scene, list_scenes

#: The benchmark's instructions.
PHRASINGS_FILE = Path(__file__).with_name("phrasings.yaml")
#: The scene's own instruction.
CANONICAL = "canonical"
#: Floor: a paraphrase class's SR lies within this many points of the canonical SR on the same episodes.
PARAPHRASE_SR_TOLERANCE_POINTS = 5.0
#: The summary files written into the output folder.
SUMMARY_JSON = "phrasing.json"
SUMMARY_MD = "phrasing.md"


@dataclass(frozen=True)
class Phrasings:
    """The benchmark's instructions: ``instructions[scene][class]``."""

    paraphrase_classes: tuple[str, ...]
    control_classes: tuple[str, ...]
    instructions: Mapping[str, Mapping[str, str]]

    @property
    def classes(self) -> tuple[str, ...]:
        """Every class, the canonical first."""
        return (CANONICAL, *self.paraphrase_classes, *self.control_classes)

    def instruction(self, scene: str, phrasing_class: str) -> str:
        """The instruction of one class in one scene (the canonical one is the scene's own)."""
        if phrasing_class == CANONICAL:
            return build_scene(scene, seed=0).instruction
        return self.instructions[scene][phrasing_class]


@functools.cache
def load_phrasings(path: Path = PHRASINGS_FILE) -> Phrasings:
    """Read and check ``phrasings.yaml``: every scene of the catalogue, every class, a non-empty text.

    Raises:
        ValueError: naming the file, the scene and the class that are missing or malformed.
    """
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    paraphrases = tuple(data.get("paraphrase_classes") or ())
    controls = tuple(data.get("control_classes") or ())
    scenes = data.get("scenes") or {}
    for scene in list_scenes():
        entry = scenes.get(scene)
        if not isinstance(entry, dict):
            raise ValueError(f"{path}: scenes.{scene} is missing")
        for phrasing_class in (*paraphrases, *controls):
            text = entry.get(phrasing_class)
            if not isinstance(text, str) or not text.strip():
                raise ValueError(f"{path}: scenes.{scene}.{phrasing_class} must be a non-empty instruction")
    return Phrasings(paraphrase_classes=paraphrases, control_classes=controls, instructions=scenes)


def phrasing_specs(
    *, scenes: Sequence[str], seeds: Sequence[int], classes: Sequence[str], **options: Any
) -> list[SweepSpec]:
    """One sweep per (scene, class) with the class's instruction, the strategy ``ours``, same seeds."""
    phrasings = load_phrasings()
    unknown = sorted(set(classes) - set(phrasings.classes))
    if unknown:
        raise ValueError(f"unknown phrasing classes {unknown}; known: {list(phrasings.classes)}")
    return [
        SweepSpec(
            scenes=(scene,),
            seeds=tuple(seeds),
            strategies=("ours",),
            instruction=None if phrasing_class == CANONICAL else phrasings.instruction(scene, phrasing_class),
            trajectories_per_cell=0,
            **options,
        )
        for scene in scenes
        for phrasing_class in classes
    ]


def class_of(row: Mapping[str, Any], phrasings: Phrasings) -> str | None:
    """The phrasing class of a row, from its scene and instruction (None for an instruction not in the file)."""
    scene = str(row["scene"])
    for phrasing_class in phrasings.classes:
        if phrasings.instruction(scene, phrasing_class) == row.get("instruction"):
            return phrasing_class
    return None


def summarize(rows: Sequence[Mapping[str, Any]], phrasings: Phrasings | None = None) -> dict[str, Any]:
    """SR per class (pooled and per scene), successes declared at a distractor and at an absent object,
    and the floors' verdicts, over the finished rows."""
    phrasings = phrasings or load_phrasings()
    cells: dict[str, dict[str, list[Mapping[str, Any]]]] = {}
    for row in rows:
        if row.get("status") != "ok":
            continue
        phrasing_class = class_of(row, phrasings)
        if phrasing_class is not None:
            cells.setdefault(phrasing_class, {}).setdefault(str(row["scene"]), []).append(row)

    def rate(group: Sequence[Mapping[str, Any]], key: str) -> float:
        return 100.0 * sum(bool(r[key]) for r in group) / len(group) if group else math.nan

    per_class: dict[str, Any] = {}
    for phrasing_class in phrasings.classes:
        by_scene = cells.get(phrasing_class, {})
        pooled = [r for group in by_scene.values() for r in group]
        at_distractor = [
            r for r in pooled
            if r["success_declared"] and not r["success"] and (r.get("reached_object") or {}).get("role") == "distractor"
        ]  # fmt: skip
        per_class[phrasing_class] = {
            "episodes": len(pooled),
            "sr_percent": rate(pooled, "success"),
            "declared_percent": rate(pooled, "success_declared"),
            "false_successes": sum(bool(r["success_declared"] and not r["success"]) for r in pooled),
            "declared_at_a_distractor": len(at_distractor),
            "declared_at_the_goal": sum(
                bool(r["success_declared"] and (r.get("reached_object") or {}).get("role") == "goal")
                for r in pooled
            ),
            "by_scene": {scene: rate(group, "success") for scene, group in sorted(by_scene.items())},
        }
    canonical = per_class[CANONICAL]["sr_percent"]
    # Only the classes that ran are judged (a partial run checks what it measured).
    floors = {
        f"{c}: SR within {PARAPHRASE_SR_TOLERANCE_POINTS:g} points of canonical": bool(
            abs(per_class[c]["sr_percent"] - canonical) <= PARAPHRASE_SR_TOLERANCE_POINTS
        )
        for c in phrasings.paraphrase_classes
        if per_class[c]["episodes"] and per_class[CANONICAL]["episodes"]
    }
    goal_classes = (CANONICAL, *phrasings.paraphrase_classes)
    floors["goal asked for: no success declared at a distractor"] = all(
        per_class[c]["declared_at_a_distractor"] == 0 for c in goal_classes
    )
    if per_class["distractor"]["episodes"]:
        floors["distractor named: success never declared at the goal"] = (
            per_class["distractor"]["declared_at_the_goal"] == 0
        )
    if per_class["absent"]["episodes"]:
        floors["absent object: 0 successes declared"] = not any(
            r["success_declared"] for group in cells.get("absent", {}).values() for r in group
        )
    return {"classes": per_class, "floors": floors}


def summary_markdown(summary: Mapping[str, Any], *, header: Mapping[str, str]) -> str:
    """The benchmark's page: SR per class side by side (pooled, then per scene), and the floors."""
    classes = summary["classes"]
    names = list(classes)
    scenes = sorted({s for c in classes.values() for s in c["by_scene"]})

    def pct(value: float) -> str:
        return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.0f} %"

    lines = ["# Phrasing benchmark", ""]
    lines += [f"- {key}: {value}" for key, value in header.items()]
    lines += [
        "",
        "| class | episodes | SR | declared | false successes | at a distractor |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for name in names:
        c = classes[name]
        lines.append(
            f"| {name} | {c['episodes']} | {pct(c['sr_percent'])} | {pct(c['declared_percent'])} | "
            f"{c['false_successes']} | {c['declared_at_a_distractor']} |"
        )
    lines += [
        "",
        "SR per scene:",
        "",
        "| scene | " + " | ".join(names) + " |",
        "| --- |" + " ---: |" * len(names),
    ]
    for scene in scenes:
        lines.append(
            f"| {scene} | "
            + " | ".join(pct(classes[n]["by_scene"].get(scene, math.nan)) for n in names)
            + " |"
        )
    lines += ["", "Floors (issue #18):", ""]
    lines += [f"- {'PASS' if ok else 'FAIL'}: {name}" for name, ok in summary["floors"].items()]
    return "\n".join(lines) + "\n"


def write_summary(out_dir: Path, summary: Mapping[str, Any], *, header: Mapping[str, str]) -> Path:
    """Write ``phrasing.json`` and ``phrasing.md`` into ``out_dir`` (whole or not at all); return the page."""
    write_json(out_dir / SUMMARY_JSON, json.loads(json.dumps(summary, default=str)))
    page = out_dir / SUMMARY_MD
    write_atomic(page, summary_markdown(summary, header=header))
    return page
