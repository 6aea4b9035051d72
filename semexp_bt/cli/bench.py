"""``semexp-bt bench KIND``: benchmarks that write JSON, tables and plots.

Kinds:

- ``core``: arbitration, memory update and decision latency (``semexp_bt.bench.core``).
- ``tree``: per-tick wall time of the paper's mission tree alone (``semexp_bt.bench.tree``).
- ``missions``: a grid of episodes (scenes x seeds x strategies), in parallel, resumable, with a report:
  ``semexp-bt bench missions --scenes office,road --seeds 0-9 --strategies ours,vlm_only --out DIR``.
- ``paper``: the paper's protocol (Tables I-V) into ``DIR`` and ``docs/results.md``:
  ``semexp-bt bench paper --out DIR [--trials 20] [--workers 2] [--smoke]``.
- ``gait``: the RL gait beside the reference trot (``sims.gait_bench``).
- ``report``: (re)write ``DIR/report.md`` and its plots from ``DIR/episodes.jsonl``.
- ``faults``: every fault class x scenes x seeds, with time to a safe stop and an ``unsafe`` count
  (``semexp_bt.bench.faults``): ``semexp-bt bench faults --out DIR [--json OUT]``.
- ``soak``: back-to-back missions in one process for a simulated hour: resident memory, memory size and
  tick p99 at the start and the end (``semexp_bt.bench.soak``).

Exit status: 0 when every episode finished, 1 when some were recorded as ``error`` or ``timeout`` (the
sweep still ran the others), 2 on bad arguments.
"""

from __future__ import annotations

import argparse
import os
import platform
import shlex
import signal
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from semexp_bt.app.components import DEFAULT_RELEVANCE, RELEVANCE_SCORERS
from semexp_bt.cli.arguments import (
    non_negative_int,
    output_file,
    output_folder,
    positive_int,
    positive_seconds,
    scene_name,
    seed,
)

if TYPE_CHECKING:
    from semexp_bt.bench.engine import SweepResult
    from semexp_bt.bench.sweep import SweepSpec

#: The repository's docs folder (results.md and its figures go there).
DOCS_DIR = Path(__file__).resolve().parents[2] / "docs"


def _add_sweep_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--out", type=output_folder, required=True, help="output folder (episodes.jsonl, report.md, plots/)"
    )
    parser.add_argument("--fidelity", choices=("kinematic", "dynamic"), default="kinematic")
    parser.add_argument(
        "--relevance",
        choices=sorted(RELEVANCE_SCORERS),
        default=None,
        help=f"relevance scorer (semexp_bt/app/components.py; default {DEFAULT_RELEVANCE}): embedding "
        "(offline MiniLM), hybrid (MiniLM or the object lexicon, the larger) or lexical (no torch; the "
        "default with --smoke)",
    )
    parser.add_argument(
        "--workers",
        type=non_negative_int,
        default=max(1, (os.cpu_count() or 1)),
        help="local worker processes (default: CPU count; 0 runs in this process)",
    )
    parser.add_argument(
        "--ray-address",
        default=None,
        help="run on a Ray cluster ('auto' or ray://host:10001) instead; needs 'pip install ray'",
    )
    parser.add_argument(
        "--timeout-s", type=positive_seconds, default=None, help="wall-time limit per episode (s)"
    )
    parser.add_argument(
        "--max-sim-s", type=positive_seconds, default=None, help="cap on simulated time per episode (s)"
    )
    parser.add_argument(
        "--mission", type=Path, default=None, help="mission tree (default: trees/object_search.yaml)"
    )
    parser.add_argument(
        "--retry-failed", action="store_true", help="rerun episodes recorded as error or timeout"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress lines")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(
        dest="kind", metavar="{core,tree,gait,missions,phrasing,paper,report,compare,faults,soak}"
    )
    sub.required = True
    core = sub.add_parser("core", help="latency of arbitration, memory update and decision")
    core.add_argument("--json", type=output_file, default=None, help="write the figures here as JSON")
    core.add_argument("--seed", type=seed, default=0)
    core.add_argument("--quick", action="store_true", help="fewer repeats, no 100k-node row (smoke test)")

    tree = sub.add_parser(
        "tree", help="per-tick wall time of the mission tree alone (no physics, no rendering)"
    )
    tree.add_argument("--json", type=output_file, default=None, help="write the figures here as JSON")
    tree.add_argument("--ticks", type=positive_int, default=20_000)
    tree.add_argument("--seed", type=seed, default=0)

    gait = sub.add_parser("gait", help="RL gait vs reference trot: tracking, falls, pushes, CoT, inference")
    gait.add_argument("--json", type=output_file, default=None, help="write the figures here as JSON")
    gait.add_argument("--seeds", type=positive_int, default=10, help="seeds (10 simulated minutes each)")
    gait.add_argument("--seed", type=seed, default=0)
    gait.add_argument("--checkpoint", type=Path, default=None, help="default: robots/gait_checkpoints")
    gait.add_argument("--quick", action="store_true", help="2 seeds x 30 s, small grid (smoke test)")
    gait.add_argument(
        "--contact-only", action="store_true", help="only the policy's contact section (falls under contact)"
    )

    missions = sub.add_parser("missions", help="a grid of episodes, in parallel and resumable, with a report")
    missions.add_argument(
        "--scenes", required=True, help="comma-separated scene names (semexp-bt scene list)"
    )
    missions.add_argument("--seeds", default="0", help="e.g. 0-9 or 0,3,5 (default 0)")
    missions.add_argument(
        "--strategies", default="ours", help="comma-separated strategy names (default ours)"
    )
    missions.add_argument(
        "--trajectories",
        type=non_negative_int,
        default=1,
        help="keep trajectory + memory of the first N seeds per (scene, strategy) for plots",
    )
    missions.add_argument("--no-report", action="store_true", help="skip report.md and plots at the end")
    _add_sweep_options(missions)

    phrasing = sub.add_parser(
        "phrasing",
        help="the same episodes with the scene's own instruction and other wordings (SR per class)",
    )
    phrasing.add_argument("--scenes", default="all", help="comma-separated scene names, or all (default)")
    phrasing.add_argument("--seeds", default="0-4", help="e.g. 0-4 (default) or 0,3,5")
    phrasing.add_argument(
        "--classes",
        default="all",
        help="comma-separated phrasing classes (semexp_bt/bench/phrasings.yaml), or all",
    )
    _add_sweep_options(phrasing)

    paper = sub.add_parser("paper", help="the paper's protocol: Tables I-V into DIR and docs/results.md")
    paper.add_argument(
        "--trials", type=positive_int, default=20, help="trials per scene for Table III (paper: 20)"
    )
    paper.add_argument(
        "--trials-evidence",
        type=non_negative_int,
        default=None,
        help="trials per sim scene, Table I baselines",
    )
    paper.add_argument(
        "--trials-decision",
        type=non_negative_int,
        default=None,
        help="trials per sim scene, Table II baselines",
    )
    paper.add_argument(
        "--trials-ablation",
        type=non_negative_int,
        default=None,
        help="trials per sim scene, Table IV ablations",
    )
    paper.add_argument(
        "--trials-reference",
        type=non_negative_int,
        default=None,
        help="trials per scene for the nearest-frontier and oracle-navigator references",
    )
    paper.add_argument(
        "--smoke",
        action="store_true",
        help="2 scenes x 1 seed x 2 strategies (lexical relevance), results into DIR only",
    )
    paper.add_argument(
        "--results",
        type=Path,
        default=None,
        help="results markdown (default docs/results.md; DIR/results.md with --smoke)",
    )
    _add_sweep_options(paper)

    report = sub.add_parser("report", help="write DIR/report.md and plots from DIR/episodes.jsonl")
    report.add_argument("dir", type=Path, help="a sweep's output folder")
    report.add_argument("--no-plots", action="store_true", help="tables only")

    compare = sub.add_parser(
        "compare", help="two sweeps episode by episode: same results? wall time before and after"
    )
    compare.add_argument("before", type=Path, help="the first sweep's output folder")
    compare.add_argument("after", type=Path, help="the second sweep's output folder")
    compare.add_argument("--json", type=output_file, default=None, help="write the comparison here as JSON")

    faults = sub.add_parser("faults", help="every fault class x scenes x seeds: safe stops, unsafe commands")
    faults.add_argument(
        "--out", type=output_folder, required=True, help="output folder (a sweep folder per case)"
    )
    faults.add_argument("--json", type=output_file, default=None, help="write the table here as JSON")
    faults.add_argument(
        "--scenes",
        type=_scene_list,
        default=None,
        help="comma-separated scenes (default: the benchmark's three)",
    )
    faults.add_argument("--seeds", default=None, help="e.g. 0-1 (default: the benchmark's)")
    faults.add_argument(
        "--cases", default=None, help="comma-separated cases (default: all; docs/reliability.md)"
    )
    faults.add_argument("--fidelity", choices=("kinematic", "dynamic"), default="kinematic")
    faults.add_argument("--relevance", choices=sorted(RELEVANCE_SCORERS), default=DEFAULT_RELEVANCE)
    faults.add_argument(
        "--max-sim-s", type=positive_seconds, default=None, help="cap per episode (s; default 240)"
    )
    faults.add_argument(
        "--workers", type=non_negative_int, default=max(1, (os.cpu_count() or 1)), help="worker processes"
    )
    faults.add_argument(
        "--timeout-s", type=positive_seconds, default=None, help="wall-time limit per episode (s)"
    )
    faults.add_argument("--quiet", action="store_true", help="no progress lines")

    soak = sub.add_parser("soak", help="back-to-back missions for a simulated hour: memory and tick p99")
    soak.add_argument("--json", type=output_file, default=None, help="write the figures here as JSON")
    soak.add_argument(
        "--sim-s", type=positive_seconds, default=None, help="robot time to run (s; default 3600)"
    )
    soak.add_argument(
        "--scenes", type=_scene_list, default=None, help="comma-separated scenes (default: the soak's three)"
    )
    soak.add_argument("--relevance", choices=sorted(RELEVANCE_SCORERS), default=DEFAULT_RELEVANCE)
    soak.add_argument("--max-missions", type=positive_int, default=None, help="stop after this many missions")


def run(args: argparse.Namespace) -> int:
    if args.kind == "core":
        from semexp_bt.bench.core import format_table, run_core_bench
        from semexp_bt.core.durable import write_json

        result = run_core_bench(seed=args.seed, quick=args.quick)
        print(format_table(result))
        if args.json is not None:
            write_json(args.json, result)
        return 0 if all(result["floors_met"].values()) else 1
    if args.kind == "tree":
        from semexp_bt.bench.tree import format_table as tree_table
        from semexp_bt.bench.tree import run_tree_bench
        from semexp_bt.core.durable import write_json as write_tree_json

        tree_result = run_tree_bench(ticks=args.ticks, seed=args.seed)
        print(tree_table(tree_result))
        if args.json is not None:
            write_tree_json(args.json, tree_result)
        return 0 if all(tree_result["floors_met"].values()) else 1
    if args.kind == "gait":
        from sims.gait_bench import format_table as gait_table
        from sims.gait_bench import run_gait_bench
        from sims.gait_bench import write_json as gait_json

        seeds = min(args.seeds, 2) if args.quick else args.seeds
        gait_result = run_gait_bench(
            checkpoint=args.checkpoint,
            seeds=seeds,
            quick=args.quick,
            seed=args.seed,
            contact_only=args.contact_only,
        )
        print(gait_table(gait_result))
        if args.json is not None:
            gait_json(gait_result, args.json)
        return 0 if all(gait_result["floors_met"].values()) else 1

    from semexp_bt.bench.sweep import HarnessError

    if (
        args.kind in ("missions", "paper")
        and args.mission is not None
        and not _mission_is_valid(args.mission)
    ):
        return 2
    try:
        if args.kind == "missions":
            return _missions(args)
        if args.kind == "phrasing":
            return _phrasing(args)
        if args.kind == "paper":
            return _paper(args)
        if args.kind == "report":
            return _report(args)
        if args.kind == "compare":
            return _compare(args)
        if args.kind == "faults":
            return _faults(args)
        if args.kind == "soak":
            return _soak(args)
    except (HarnessError, FileNotFoundError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 2


def _mission_is_valid(path: Path) -> bool:
    """Check ``--mission`` before any episode starts; print its problems (one line each) when it has any."""
    from trees.loader import validate_mission

    errors = validate_mission(path)
    for error in errors:
        print(error, file=sys.stderr)
    return not errors


def _spec_options(args: argparse.Namespace) -> dict[str, Any]:
    relevance = args.relevance or ("lexical" if getattr(args, "smoke", False) else DEFAULT_RELEVANCE)
    options: dict[str, Any] = {"fidelity": args.fidelity, "relevance": relevance}
    if args.timeout_s is not None:
        options["timeout_s"] = args.timeout_s
    if args.max_sim_s is not None:
        options["max_sim_s"] = args.max_sim_s
    if args.mission is not None:
        options["mission_path"] = args.mission
    return options


def _scene_list(text: str) -> tuple[str, ...]:
    """Comma-separated scenes of the catalogue, each checked."""
    return tuple(scene_name(name) for name in _split(text))


def _split(text: str) -> tuple[str, ...]:
    return tuple(part.strip() for part in text.split(",") if part.strip())


def _sweep(args: argparse.Namespace, specs: list[SweepSpec]) -> SweepResult:
    from semexp_bt.bench.engine import run_sweep

    def _stop(signum: int, frame: Any) -> None:
        raise SystemExit(128 + signum)

    # SIGTERM (kill PID) unwinds like Ctrl-C: the workers are stopped and the invocation is logged.
    previous = signal.signal(signal.SIGTERM, _stop)
    try:
        return run_sweep(specs, args.out, workers=args.workers, ray_address=args.ray_address,
                         retry_failed=args.retry_failed, progress=None if args.quiet else sys.stderr)  # fmt: skip
    finally:
        signal.signal(signal.SIGTERM, previous)


def _missions(args: argparse.Namespace) -> int:
    from semexp_bt.bench.sweep import SweepSpec, parse_seeds

    spec = SweepSpec(scenes=_split(args.scenes), seeds=parse_seeds(args.seeds), strategies=_split(args.strategies),
                     trajectories_per_cell=args.trajectories, **_spec_options(args))  # fmt: skip
    result = _sweep(args, [spec])
    print(f"{result.ran} episodes run, {result.skipped} already done, {result.errors} errors, "
          f"{result.timeouts} timeouts in {result.wall_s:.0f} s -> {args.out}")  # fmt: skip
    if not args.no_report:
        from semexp_bt.bench.report import write_report

        print(f"report: {write_report(args.out)}")
    return 1 if result.errors or result.timeouts else 0


def _phrasing(args: argparse.Namespace) -> int:
    from semexp_bt.bench.phrasing import load_phrasings, phrasing_specs, summarize, write_summary
    from semexp_bt.bench.store import load_rows
    from semexp_bt.bench.sweep import parse_seeds
    from sims.catalogue import list_scenes

    scenes = list_scenes() if args.scenes == "all" else list(_split(args.scenes))
    classes = list(load_phrasings().classes) if args.classes == "all" else list(_split(args.classes))
    specs = phrasing_specs(
        scenes=scenes, seeds=parse_seeds(args.seeds), classes=classes, **_spec_options(args)
    )
    result = _sweep(args, specs)
    summary = summarize(load_rows(args.out))
    header = {
        "machine": _machine(),
        "command": "semexp-bt " + shlex.join(sys.argv[1:])
        if sys.argv[0].endswith("semexp-bt")
        else shlex.join(sys.argv),
        "episodes": f"{result.ran} run by this invocation, {result.skipped} already done, {result.errors} errors",
        "relevance": _spec_options(args)["relevance"],
    }
    page = write_summary(args.out, summary, header=header)
    print(page.read_text())
    return 1 if result.errors or result.timeouts or not all(summary["floors"].values()) else 0


def _paper(args: argparse.Namespace) -> int:
    from semexp_bt.bench.paper_results import write_paper_results
    from semexp_bt.bench.protocol import PaperProtocol, smoke_specs
    from semexp_bt.bench.report import write_report
    from semexp_bt.bench.store import load_rows

    options = _spec_options(args)
    if args.smoke:
        specs = smoke_specs(**options)
        protocol_text = "smoke: 2 scenes x 1 seed x 2 strategies"
    else:
        defaults = PaperProtocol()
        protocol = PaperProtocol(
            trials_table_iii=args.trials,
            trials_evidence=_or(args.trials_evidence, defaults.trials_evidence),
            trials_decision=_or(args.trials_decision, defaults.trials_decision),
            trials_ablation=_or(args.trials_ablation, defaults.trials_ablation),
            trials_reference=_or(args.trials_reference, defaults.trials_reference),
        )
        specs = protocol.specs(**options)
        protocol_text = (f"Table III {protocol.trials_table_iii} trials/scene; Tables I/II/IV {protocol.trials_evidence}/"
                         f"{protocol.trials_decision}/{protocol.trials_ablation} trials per sim scene; references "
                         f"{protocol.trials_reference} trials/scene")  # fmt: skip
    result = _sweep(args, specs)
    rows = load_rows(args.out)
    busy_s = sum(float(r.get("harness_wall_s") or 0.0) for r in rows)
    per_core_h = 3600.0 * len(rows) / busy_s if busy_s > 0 else float("nan")
    header = {
        "machine": _machine(),
        "command": "semexp-bt " + shlex.join(sys.argv[1:])
        if sys.argv[0].endswith("semexp-bt")
        else shlex.join(sys.argv),
        "protocol": protocol_text,
        "fidelity / relevance": f"{options['fidelity']} / {options['relevance']}",
        "episodes": f"{len(rows)} in {args.out} ({result.ran} run by this invocation, "
        f"{result.errors} errors, {result.timeouts} timeouts)",
        "wall time of this invocation": f"{result.wall_s / 60:.1f} min with {args.workers} worker(s)",
        "wall time of all invocations": _all_invocations(args.out),
        "episodes per hour per core": f"{per_core_h:.0f} ({options['fidelity']}; from the episodes' own wall times)",
    }
    results_path = args.results or (args.out / "results.md" if args.smoke else DOCS_DIR / "results.md")
    figures = (args.out / "figures") if args.smoke else DOCS_DIR / "figures" / "results"
    write_paper_results(rows, results_path, header=header, figures_dir=figures)
    print(f"results: {results_path}")
    print(f"report: {write_report(args.out, rows=rows)}")
    return 1 if result.errors or result.timeouts else 0


def _report(args: argparse.Namespace) -> int:
    from semexp_bt.bench.report import write_report

    print(f"report: {write_report(args.dir, plots=not args.no_plots)}")
    return 0


def _compare(args: argparse.Namespace) -> int:
    from semexp_bt.bench.compare import compare_sweeps, format_comparison
    from semexp_bt.bench.store import EPISODES_FILE, load_rows
    from semexp_bt.bench.sweep import HarnessError
    from semexp_bt.core.durable import write_json

    for folder in (args.before, args.after):
        if not (folder / EPISODES_FILE).is_file():
            raise HarnessError(f"compare: {folder / EPISODES_FILE} does not exist")
    comparison = compare_sweeps(load_rows(args.before), load_rows(args.after))
    print(format_comparison(comparison, before=args.before, after=args.after))
    if args.json is not None:
        write_json(args.json, comparison.to_dict())
        print(f"json: {args.json}")
    if comparison.matched == 0:
        print("error: the two sweeps share no finished episode", file=sys.stderr)
        return 2
    return 1 if comparison.differing else 0


def _faults(args: argparse.Namespace) -> int:
    from semexp_bt.bench.faults import CASES_BY_NAME, format_table, run_fault_bench
    from semexp_bt.bench.sweep import HarnessError, parse_seeds
    from semexp_bt.core.durable import write_json

    cases = None if args.cases is None else list(_split(args.cases))
    unknown = [c for c in cases or () if c not in CASES_BY_NAME]
    if unknown:
        raise HarnessError(f"unknown fault cases {unknown}; known: {sorted(CASES_BY_NAME)}")
    chosen: dict[str, Any] = {"cases": cases}
    if args.scenes is not None:
        chosen["scenes"] = args.scenes
    if args.seeds is not None:
        chosen["seeds"] = parse_seeds(args.seeds)
    if args.max_sim_s is not None:
        chosen["max_sim_s"] = args.max_sim_s
    result = run_fault_bench(args.out, fidelity=args.fidelity, relevance=args.relevance, workers=args.workers,
                             timeout_s=args.timeout_s, progress=None if args.quiet else sys.stderr,
                             **chosen)  # fmt: skip
    result["machine"] = _machine()
    result["command"] = "semexp-bt " + shlex.join(sys.argv[1:])
    print(format_table(result))
    if args.json is not None:
        write_json(args.json, result)
    return 0 if result["floors_met"] and not result["settings"]["errors"] else 1


def _soak(args: argparse.Namespace) -> int:
    from semexp_bt.bench.soak import format_table, run_soak
    from semexp_bt.core.durable import write_json

    chosen: dict[str, Any] = {"max_missions": args.max_missions}
    if args.sim_s is not None:
        chosen["sim_s"] = args.sim_s
    if args.scenes is not None:
        chosen["scenes"] = args.scenes
    result = run_soak(relevance=args.relevance, **chosen)
    result["machine"] = _machine()
    result["command"] = "semexp-bt " + shlex.join(sys.argv[1:])
    print(format_table(result))
    if args.json is not None:
        write_json(args.json, result)
    return 0 if result["floors_met"] else 1


def _all_invocations(out_dir: Path) -> str:
    """The sweep's total wall time, from ``DIR/invocations.jsonl`` (a resumed sweep has several lines)."""
    from semexp_bt.bench.store import INVOCATIONS_FILE, load_invocations
    from semexp_bt.bench.sweep import HarnessError

    try:
        invocations = load_invocations(out_dir)
    except HarnessError as exc:
        # The episodes are what matters: a damaged log must not fail the report written after them.
        print(f"warning: {exc}", file=sys.stderr)
        return f"unknown ({exc})"
    total_s = sum(float(one["wall_s"]) for one in invocations)
    ran = sum(int(one.get("ran") or 0) for one in invocations)
    stopped = sum(not one.get("completed", True) for one in invocations)
    return (f"{total_s / 60:.1f} min in {len(invocations)} invocation(s) ({stopped} stopped) that ran {ran} "
            f"episodes ({out_dir / INVOCATIONS_FILE})")  # fmt: skip


def _or(value: int | None, default: int) -> int:
    return default if value is None else value


def _machine() -> str:
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} logical CPUs, {platform.system()} {platform.release()}, Python {platform.python_version()}"
