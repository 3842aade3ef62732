"""Command line: ``python -m repro {list, reproduce, report, stability, validate-dataset, bench,
generate-stubs}``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any


def _parse_parameter(text: str) -> tuple[str, Any]:
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"-p takes name=value, got {text!r}")
    name, raw = text.split("=", 1)
    try:
        value = json.loads(raw)
    except json.JSONDecodeError:
        value = raw  # a bare string
    return name, value


def _cmd_list(_: argparse.Namespace) -> int:
    from repro.claims.registry import CLAIMS
    from repro.run.runner import available_notebooks

    print("notebooks:")
    for name in available_notebooks():
        print(f"  {name}")
    print("claims:")
    for claim in CLAIMS.values():
        print(f"  {claim.id:7s} {claim.notebook:26s} {claim.statement[:70]}")
    return 0


def _scale(args: argparse.Namespace) -> str:
    """The scale a command was given: ``--scale`` (default standard), ``--quick`` for
    ``--scale quick``; both, disagreeing, is an error."""
    if args.quick and args.scale not in (None, "quick"):
        raise ValueError(f"--quick and --scale {args.scale} disagree: give one")
    return "quick" if args.quick else args.scale or "standard"


def _add_scale(parser: argparse.ArgumentParser, what: str) -> None:
    from repro.infra.context import SCALES

    parser.add_argument("--scale", choices=SCALES, help=f"{what}: quick (a test of the code, "
                        "never a result), standard (the default: make reproduce, results/) "
                        "or paper (the papers' settings, for a GPU or a cluster)")
    parser.add_argument("--quick", action="store_true", help="the same as --scale quick")


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from repro.run.params import resolve_device
    from repro.run.runner import reproduce

    extra = dict(args.parameter or [])
    try:
        return reproduce(scale=_scale(args), only=args.only, jobs=args.jobs, seed=args.seed,
                         device=resolve_device(args.device), snapshot=args.snapshot,
                         extra_parameters=extra,
                         threads=args.threads, allow_mixed=args.allow_mixed)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2


def _cmd_report(args: argparse.Namespace) -> int:
    from repro.claims.provenance import ReportError
    from repro.claims.report import write_report, write_snapshot
    from repro.infra import paths
    from repro.infra.storage import write_problem
    from repro.run.runner import refuse_snapshot, report_state

    try:
        scale = _scale(args)
        refuse_snapshot(scale, args.snapshot)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    build = paths.run_build_dir(scale)
    if not (build / "claims").is_dir():
        print(f"error: no claim sidecars in {build / 'claims'}; run notebooks first",
              file=sys.stderr)
        return 2
    try:
        report = write_report(build, scale=scale, provenance=args.note or "",
                              allow_mixed=args.allow_mixed)
        print(f"report: {report}")
        if args.snapshot:
            print(f"results snapshot: {write_snapshot(build)}")
    except ReportError as error:
        print(f"error: {error}; {report_state(build)}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"error: {write_problem(error)}; the report may be partly rewritten: run this "
              "again once it can be written", file=sys.stderr)
        return 2
    return 0


def run_base_seed(seed: int, *, scale: str, jobs: int, threads: int | None,
                  only: list[str] | None = None) -> int:
    """``python -m repro reproduce --seed N`` into :func:`seed_build_dir`'s folder (as its
    ``REPRO_BUILD_ROOT``), on this checkout's model cache (keys hash the seed: sharing is
    safe); returns its exit code."""
    import os
    import subprocess

    from repro.claims.stability import seed_build_dir
    from repro.infra import paths

    root = seed_build_dir(seed)
    command = [sys.executable, "-m", "repro", "reproduce", "--seed", str(seed), "--jobs",
               str(jobs), *(["--threads", str(threads)] if threads else []),
               "--scale", scale, *(["--only", *only] if only else [])]
    print(f"base seed {seed}: REPRO_BUILD_ROOT={root} {' '.join(command[1:])}", flush=True)
    env = {**os.environ, "REPRO_BUILD_ROOT": str(root), "REPRO_CACHE_DIR": str(paths.cache_dir())}
    return subprocess.run(command, env=env, check=False).returncode


def _stability_folders(args: argparse.Namespace) -> tuple[dict[str, Path], dict[str, int]]:
    """label → build folder, and label → base seed (when given by --base-seeds)."""
    from repro.claims.stability import seed_build_dir

    if args.base_seeds:
        if args.build_dirs or args.label:
            raise ValueError("give either --base-seeds or build folders (with --label), not both")
        if len(set(args.base_seeds)) != len(args.base_seeds):
            raise ValueError(f"--base-seeds must differ, got {args.base_seeds}")
        labels = [f"seed {s}" for s in args.base_seeds]
        folders = {label: seed_build_dir(s, scale=_scale(args))
                   for label, s in zip(labels, args.base_seeds, strict=True)}
        return folders, dict(zip(labels, args.base_seeds, strict=True))
    if args.run or args.only:
        raise ValueError("--run and --only need --base-seeds (each base seed runs into its "
                         "folder)")
    labels = args.label or [Path(d).name for d in args.build_dirs]
    if len(labels) != len(args.build_dirs) or len(set(labels)) != len(labels):
        raise ValueError(f"need one distinct --label per build folder, got {labels}")
    return dict(zip(labels, map(Path, args.build_dirs), strict=True)), {}


def _cmd_stability(args: argparse.Namespace) -> int:
    from repro.claims.ledger import load_sidecars
    from repro.claims.stability import write_stability
    from repro.infra import paths

    try:
        scale = _scale(args)
        folders, seeds = _stability_folders(args)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    if args.snapshot and scale != "standard":
        print(f"error: results/STABILITY.md compares standard-scale runs, not {scale} ones",
              file=sys.stderr)
        return 2
    if args.run:
        for label, folder in folders.items():
            try:
                recorded = load_sidecars(folder / "claims")
            except ValueError as error:  # a garbled sidecar (claims.provenance.ReportError)
                print(f"error: {error}", file=sys.stderr)
                return 2
            if recorded:
                print(f"{label}: {folder} holds a run already (delete its claims/ to rerun)")
                continue
            code = run_base_seed(seeds[label], scale=scale, jobs=args.jobs,
                                 threads=args.threads, only=args.only)
            if code:
                print(f"error: the run from {label} failed (exit {code}); nothing compared",
                      file=sys.stderr)
                return 1
    output = (paths.results_dir() / "STABILITY.md" if args.snapshot
              else next(iter(folders.values())) / "report" / "STABILITY.md")
    try:
        written = write_stability(folders, output, base_seeds=seeds, scale=scale)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"seed stability: {written}")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    """The folder's layout (``validate_dataset``), then, notebook by notebook, whether it can
    use the folder at ``--scale`` (the windows it cuts, as ``reproduce`` checks before a kernel
    starts). Exit 0 when the layout has no error and the notebooks asked for (``--notebook``;
    by default: at least one) can use it, 1 otherwise, 2 when the folder cannot be read."""
    from repro.motion.humanml3d import format_problems, validate_dataset
    from repro.run.params import notebook_acceptance
    from repro.run.runner import resolve_targets

    try:
        asked = resolve_targets(args.notebook) if args.notebook else []
        problems = validate_dataset(args.directory)
        errors = [p for p in problems if getattr(p, "severity", "error") == "error"]
        verdicts = {} if errors else notebook_acceptance(args.directory, args.scale,
                                                         asked or resolve_targets(None))
    except (FileNotFoundError, ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    if problems:
        print(format_problems(problems))
    if errors:
        print("the layout has errors: no notebook can use the folder")
        return 1
    print(f"{args.directory}: layout valid" + (f" ({len(problems)} warning(s))" if problems
                                               else "")
          + f"; the notebooks at the {args.scale} scale (-p data_dir={args.directory}):")
    for name, why in verdicts.items():
        print(f"  {'uses it' if not why else 'cannot':8s} {name}"
              + "".join(f"\n             {line}" for line in why))
    usable = [name for name, why in verdicts.items() if not why]
    return 0 if (usable == list(verdicts) if asked else usable) else 1


def _cmd_bench(args: argparse.Namespace) -> int:
    from repro.run.bench import run_bench

    if args.training:
        from repro.run import bench_training

        return bench_training.main((["--quick"] if args.small else [])
                                   + ["--threads", str(args.threads)])
    try:
        return run_bench(full=args.full, venv=args.venv, quick=not args.no_quick,
                         warm_cache=args.warm_cache)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2


def _cmd_stubs(_: argparse.Namespace) -> int:
    from repro.standin.dataset import regenerate_stubs

    print(regenerate_stubs())
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m repro", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="print the notebooks and the claims").set_defaults(func=_cmd_list)

    rep = sub.add_parser("reproduce", help="execute notebooks with papermill and write the report")
    _add_scale(rep, "the settings every notebook runs with")
    rep.add_argument("--only", nargs="+", metavar="NOTEBOOK_OR_CLAIM",
                     help="notebook names, number prefixes (01) or claim IDs (GMD-A1)")
    rep.add_argument("--jobs", type=int, default=1, help="notebooks run in parallel")
    rep.add_argument("--seed", type=int, default=0, help="base seed passed to every notebook")
    rep.add_argument("--threads", type=int, help="torch threads per notebook (default: the "
                     "cores shared among --jobs; 1 when other work shares the cores)")
    rep.add_argument("--device", default="cpu", help="torch device, e.g. cuda; auto: cuda "
                     "when this machine has one, else cpu (what a workflow job passes)")
    rep.add_argument("-p", "--parameter", action="append", type=_parse_parameter,
                     metavar="NAME=VALUE", help="extra notebook parameter (JSON value), "
                     "checked against the notebook's parameters cell before any kernel "
                     "starts; scale, seed, device and build_dir are set by the runner")
    rep.add_argument("--snapshot", action="store_true",
                     help="after a successful standard-scale run of every notebook, refresh "
                     "results/")
    rep.add_argument("--allow-mixed", action="store_true",
                     help="write the report even if its claims come from several runs (the "
                     "provenance then names every run)")
    rep.set_defaults(func=_cmd_reproduce)

    rpt = sub.add_parser("report", help="rewrite the report from the recorded claim sidecars "
                         "(e.g. after running notebooks one at a time with --only)")
    _add_scale(rpt, "the scale whose build folder to report")
    rpt.add_argument("--snapshot", action="store_true", help="also refresh results/")
    rpt.add_argument("--note", help="a provenance note printed at the top of the report")
    rpt.add_argument("--allow-mixed", action="store_true",
                     help="report claims recorded by several runs side by side, naming each")
    rpt.set_defaults(func=_cmd_report)

    stab = sub.add_parser("stability", help="compare the verdicts of runs made from different "
                          "base seeds: --base-seeds 0 3 reads build/ and build/seed3/ (--run: "
                          "runs the missing ones first), or name the build folders")
    stab.add_argument("build_dirs", nargs="*", metavar="BUILD_DIR",
                      help="build folders holding claims/ (instead of --base-seeds)")
    stab.add_argument("--label", action="append", help="a name per build folder, in order")
    stab.add_argument("--base-seeds", nargs="+", type=int, metavar="SEED",
                      help="base seeds whose runs to compare (build/ for 0, build/seed<N>/ else)")
    stab.add_argument("--run", action="store_true",
                      help="with --base-seeds: first run every notebook from each base seed "
                      "whose folder holds no run yet (python -m repro reproduce --seed N)")
    stab.add_argument("--jobs", type=int, default=1, help="with --run: notebooks in parallel")
    stab.add_argument("--threads", type=int, help="with --run: torch threads per notebook")
    stab.add_argument("--only", nargs="+", metavar="NOTEBOOK_OR_CLAIM",
                      help="with --run: only these notebooks (the coverage table then shows "
                      "the others as not executed)")
    _add_scale(stab, "the scale of the runs compared")
    stab.add_argument("--snapshot", action="store_true",
                      help="write results/STABILITY.md instead of <first build>/report/")
    stab.set_defaults(func=_cmd_stability)

    from repro.infra.context import SCALES

    val = sub.add_parser("validate-dataset", help="check a HumanML3D-layout folder")
    val.add_argument("directory")
    val.add_argument("--scale", choices=SCALES, default="standard",
                     help="also check the windows this scale's notebooks cut (default: "
                          "standard, as reproduce)")
    val.add_argument("--notebook", action="append", metavar="NAME",
                     help="require this notebook (a name, its number or a claim ID; "
                          "repeatable) to use the folder; default: any notebook")
    val.set_defaults(func=_cmd_validate)

    bench = sub.add_parser("bench", help="measure the time budgets (writes build/bench)")
    bench.add_argument("--full", action="store_true", help="also time a full cold/warm reproduce")
    bench.add_argument("--venv", action="store_true", help="also time a fresh venv set-up")
    bench.add_argument("--no-quick", action="store_true",
                       help="skip the unit tests, quick notebooks and make test")
    bench.add_argument("--warm-cache", metavar="DIR",
                       help="also time a full reproduce on DIR, an earlier full run's cache")
    bench.add_argument("--training", action="store_true",
                       help="only the training/sampling throughput section (samples/s against "
                            "a plain fp32 eager loop, GFLOP/s against the GEMM peaks)")
    bench.add_argument("--small", action="store_true",
                       help="with --training: tiny sizes (seconds), a test of the bench")
    bench.add_argument("--threads", type=int, default=1,
                       help="with --training: torch threads (default 1: two threads wait on "
                            "each other when other work holds a core)")
    bench.set_defaults(func=_cmd_bench)

    sub.add_parser("generate-stubs", help="regenerate data_stubs/").set_defaults(func=_cmd_stubs)
    args = parser.parse_args(argv)
    return args.func(args)


