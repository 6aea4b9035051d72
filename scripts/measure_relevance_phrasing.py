"""How each relevance scorer reads the phrasing benchmark's instructions, without running a mission.

For every scene (seed 0) and phrasing class of ``semexp_bt/bench/phrasings.yaml`` it scores the
instruction against every name a model may give each object that is not a wall (its label and aliases,
``sims.naming.own_names``), and asks the question the executive's confirmation asks
(``NAMES_OBJECT_RELEVANCE``): does a name of the object name the instructed object?

- paraphrase classes and the canonical one: right when the goal's label names it and no distractor's does;
- ``distractor``: right when a distractor's label names it and the goal's does not;
- ``absent``: right when no label names it.

Deterministic and cheap (no simulation): it is how the default scorer was chosen (docs/decision.md).

    .venv/bin/python scripts/measure_relevance_phrasing.py [--scorers embedding,hybrid,lexical]
"""

from __future__ import annotations

import argparse
from collections import defaultdict

from semexp_bt.app.components import build_relevance
from semexp_bt.bench.phrasing import load_phrasings
from semexp_bt.core.relevance import NAMES_OBJECT_RELEVANCE, RelevanceScorer
from sims.catalogue import build_scene, list_scenes
from sims.naming import own_names


def _names(scorer: RelevanceScorer, instruction: str, label: str) -> bool:
    return scorer.score(instruction=instruction, label=label) >= NAMES_OBJECT_RELEVANCE


def _right(phrasing_class: str, goal_names: bool, distractor_names: bool) -> bool:
    if phrasing_class == "distractor":
        return distractor_names and not goal_names
    if phrasing_class == "absent":
        return not goal_names and not distractor_names
    return goal_names and not distractor_names


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scorers", default="embedding,hybrid,lexical")
    args = parser.parse_args()
    phrasings = load_phrasings()
    scorers = {name: build_relevance(name) for name in args.scorers.split(",")}
    right: dict[tuple[str, str], int] = defaultdict(int)
    misses: dict[str, list[str]] = defaultdict(list)
    scenes = list_scenes()
    for scene in scenes:
        spec = build_scene(scene, seed=0)
        goal = next(o for o in spec.objects if o.object_id == spec.goal_object_id)
        distractors = [o for o in spec.objects if o.role == "distractor"]
        others = [o for o in spec.objects if o.role not in ("goal", "distractor", "wall")]
        for phrasing_class in phrasings.classes:
            instruction = phrasings.instruction(scene, phrasing_class)
            for name, scorer in scorers.items():
                goal_names = any(_names(scorer, instruction, n) for n in own_names(goal))
                # For the absent class any object that is named is a false success.
                pool = distractors + others if phrasing_class == "absent" else distractors
                distractor_names = any(_names(scorer, instruction, n) for o in pool for n in own_names(o))
                ok = _right(phrasing_class, goal_names, distractor_names)
                right[(name, phrasing_class)] += ok
                if not ok:
                    misses[name].append(f"{scene}/{phrasing_class}: {instruction!r}")
    header = f"{'class':16s}" + "".join(f"{name:>11s}" for name in scorers)
    print(
        f"a name of the object named at relevance >= {NAMES_OBJECT_RELEVANCE} (right / {len(scenes)} scenes)"
    )
    print(header)
    for phrasing_class in phrasings.classes:
        print(f"{phrasing_class:16s}" + "".join(f"{right[(n, phrasing_class)]:>11d}" for n in scorers))
    total = len(scenes) * len(phrasings.classes)
    print(
        f"{'all':16s}"
        + "".join(f"{sum(right[(n, c)] for c in phrasings.classes):>8d}/{total}" for n in scorers)
    )
    for name, items in misses.items():
        print(f"\n{name} wrong on:")
        for item in items:
            print(f"  {item}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
