"""Compare two phrasing benchmark folders episode by episode, and each wording with the canonical one.

``semexp-bt bench compare`` matches rows by their sweep key, which the wordings of one episode share, so
it cannot pair phrasing rows. This script pairs them by (scene, seed, instruction) and prints:

- BEFORE against AFTER: how many episodes are the same (outcome, and path within 0.01 m), how many
  reached the same outcome on another path, and each that changed outcome;
- within AFTER, per paraphrase class: how many of its episodes ran the canonical episode itself (same
  outcome and path as the canonical wording on that scene and seed).

Two ``semexp-bt bench missions`` folders of one instruction per episode (Table III) pair the same way.

Usage:
    .venv/bin/python scripts/compare_phrasing_runs.py runs/phrasing_s23m runs/phrasing_s24
    .venv/bin/python scripts/compare_phrasing_runs.py runs/table3_s22 runs/table3_s24
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path
from typing import Any

from semexp_bt.bench.phrasing import CANONICAL, class_of, load_phrasings
from semexp_bt.bench.store import load_rows

#: Two paths this close are the same path, m.
SAME_PATH_M = 0.01


def same_episode(a: dict[str, Any], b: dict[str, Any]) -> bool:
    return a["outcome"] == b["outcome"] and abs(a["path_length_m"] - b["path_length_m"]) < SAME_PATH_M


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    args = parser.parse_args()
    phrasings = load_phrasings()
    before = {(r["scene"], r["seed"], r["instruction"]): r for r in load_rows(args.before)}
    after = load_rows(args.after)

    counts: Counter[str] = Counter()
    for row in after:
        old = before.get((row["scene"], row["seed"], row["instruction"]))
        if old is None:
            counts["only in AFTER"] += 1
        elif same_episode(old, row):
            counts["same"] += 1
        elif old["success"] == row["success"]:
            counts["same outcome, another path"] += 1
        else:
            counts["another outcome"] += 1
            print(f"outcome changed: {row['scene']} seed {row['seed']} {class_of(row, phrasings)}: "
                  f"{old['outcome']} -> {row['outcome']}")  # fmt: skip
    print(", ".join(f"{key}: {n}" for key, n in counts.items()), f"(of {len(after)})")

    canonical = {(r["scene"], r["seed"]): r for r in after if class_of(r, phrasings) == CANONICAL}
    for phrasing_class in phrasings.paraphrase_classes:
        rows = [r for r in after if class_of(r, phrasings) == phrasing_class]
        if not rows:
            continue
        same = sum(same_episode(r, canonical[(r["scene"], r["seed"])]) for r in rows)
        print(f"{phrasing_class}: {same} of {len(rows)} ran the canonical episode")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
