"""Time and memory the mission loader spends on the worst files its caps allow, and on the shipped trees.

    .venv/bin/python scripts/measure_loader_limits.py

Each case is written to a temporary folder and checked with ``trees.loader.validate_mission`` (what
``semexp-bt tree check`` runs); the table gives the CPU time of this process (best of three, so that
other load on the machine does not count), the peak of Python allocations (tracemalloc) and the first
error. The figures in docs/reliability.md come from here.
"""

from __future__ import annotations

import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

from semexp_bt.files.yaml_source import MAX_FILE_BYTES, MAX_NESTING_DEPTH
from trees.declarations import MAX_INCLUDE_DEPTH, MAX_REPORTED_ERRORS
from trees.loader import validate_mission

REPO = Path(__file__).resolve().parents[1]


def _padded(head: str, filler: str) -> str:
    """``head`` followed by as many ``filler`` as fit under the size cap."""
    return head + filler * ((MAX_FILE_BYTES - len(head) - 2) // len(filler)) + "\n"


def flat_list(folder: Path) -> Path:
    path = folder / "flat_list.yaml"
    text = _padded("tree: {type: SetBlackboardVariable, params: {variable_name: x, variable_value: [", "1,")
    path.write_text(text[:-3] + "]}}\n")
    return path


def many_keys(folder: Path) -> Path:
    path = folder / "many_keys.yaml"
    lines = "".join(f"k{i}: v\n" for i in range(MAX_FILE_BYTES // 9))
    path.write_text(("tree: {type: Success}\n" + lines)[: MAX_FILE_BYTES - 1].rsplit("\n", 1)[0] + "\n")
    return path


def deep_flow(folder: Path) -> Path:
    path = folder / "deep_flow.yaml"
    path.write_text("tree: " + "[" * (MAX_FILE_BYTES - 10) + "\n")
    return path


def deep_at_cap(folder: Path) -> Path:
    path = folder / "deep_at_cap.yaml"
    depth = MAX_NESTING_DEPTH - 3  # the root mapping, tree and params take three levels
    path.write_text(
        "tree: {type: SetBlackboardVariable, params: {variable_name: x, variable_value: "
        + "[" * depth
        + "]" * depth
        + "}}\n"
    )
    return path


def billion_laughs(folder: Path) -> Path:
    path = folder / "laughs.yaml"
    lines = ["l0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    lines += [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 10)}]" for i in range(1, 9)]
    path.write_text("\n".join(lines) + "\ntree: {type: Success}\n")
    return path


def include_bomb(folder: Path) -> Path:
    for level in range(1, 6):
        child = f"- include: b{level + 1}.yaml" if level < 5 else "- type: Success"
        children = "\n".join(f"    {child}" for _ in range(10))
        (folder / f"b{level}.yaml").write_text(
            f"tree:\n  type: Sequence\n  params: {{memory: true}}\n  children:\n{children}\n"
        )
    return folder / "b1.yaml"


def include_chain(folder: Path) -> Path:
    last = MAX_INCLUDE_DEPTH + 5
    for index in range(last):
        (folder / f"c{index}.yaml").write_text(f"tree:\n  include: c{index + 1}.yaml\n")
    (folder / f"c{last}.yaml").write_text("tree: {type: Success}\n")
    return folder / "c0.yaml"


def many_errors(folder: Path) -> Path:
    path = folder / "many_errors.yaml"
    children = "".join(f"    - type: Nope{i}\n" for i in range(2000))
    path.write_text(f"tree:\n  type: Sequence\n  params: {{memory: true}}\n  children:\n{children}")
    return path


CASES: dict[str, Callable[[Path], Path]] = {
    f"flat list at the size cap ({MAX_FILE_BYTES} B)": flat_list,
    "7k keys at the size cap": many_keys,
    "flow nesting 65k deep": deep_flow,
    f"nesting at the depth cap ({MAX_NESTING_DEPTH})": deep_at_cap,
    "billion laughs (9 levels of 10)": billion_laughs,
    "include bomb (5 levels of 10)": include_bomb,
    f"include chain {MAX_INCLUDE_DEPTH + 5} deep": include_chain,
    f"2000 unknown types (cap {MAX_REPORTED_ERRORS} errors)": many_errors,
}


def measure(path: Path) -> tuple[float, float, str]:
    """Best-of-three CPU time (ms), peak allocation (MiB) and the first error of checking ``path``."""
    times = []
    for _ in range(3):
        started = time.process_time()
        errors = validate_mission(path)
        times.append(time.process_time() - started)
    tracemalloc.start()
    validate_mission(path)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    first = str(errors[0]).split(": ", 1)[1] if errors else "ok"
    return 1000 * min(times), peak / 2**20, first


def main() -> None:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, make in CASES.items():
            folder = Path(tmp) / make.__name__
            folder.mkdir()
            rows.append((name, *measure(make(folder))))
    for mission in sorted((REPO / "trees").glob("*.yaml")):
        rows.append((f"shipped {mission.name}", *measure(mission)))
    print("| case | CPU ms | peak MiB | result |\n| --- | ---: | ---: | --- |")
    for name, cpu_ms, peak_mib, first in rows:
        print(f"| {name} | {cpu_ms:.0f} | {peak_mib:.1f} | {first[:90]} |")


if __name__ == "__main__":
    main()
