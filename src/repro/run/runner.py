"""Execute the notebooks with papermill, one process per notebook, and write the report.

- Parameter names are validated against each notebook's ``parameters`` cell before anything
  runs (papermill itself only warns about unknown names).
- Each notebook runs in its own process with torch/BLAS threads limited so that ``--jobs``
  processes share the cores; a per-cell timeout stops a hung cell.
- Quick runs write under ``build/quick`` and never touch a full run's outputs.
- A failing notebook is reported with its cell; the others still run; the command exits
  non-zero and the last good report is kept.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import time
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from repro.claims.registry import CLAIMS
from repro.claims.report import slowest_of, slowest_seconds
from repro.infra import paths

STANDARD_PARAMETERS = ("quick", "seed", "device", "build_dir")


@dataclass
class NotebookResult:
    name: str
    ok: bool
    seconds: float
    output: str
    error: str = ""


def available_notebooks() -> list[str]:
    """Notebook names (without ``.ipynb``) in execution order."""
    return sorted(p.stem for p in paths.notebooks_dir().glob("[0-9][0-9]_*.ipynb"))


def resolve_targets(only: Sequence[str] | None) -> list[str]:
    """Notebook names for ``--only`` items: a notebook name, its number prefix, or a claim ID."""
    notebooks = available_notebooks()
    if not only:
        return notebooks
    chosen: list[str] = []
    for item in only:
        stem = item.removesuffix(".ipynb")
        stem = Path(stem).name
        if item in CLAIMS:
            stem = CLAIMS[item].notebook
            if stem not in notebooks:
                raise ValueError(f"claim {item} is tested by notebook {stem}, which does not "
                                 "exist yet")
        matches = [n for n in notebooks if n == stem or n.split("_", 1)[0] == stem]
        if not matches:
            raise ValueError(f"unknown notebook or claim ID {item!r}; notebooks: "
                             f"{', '.join(notebooks)}; claims: {', '.join(CLAIMS)}")
        chosen.extend(m for m in matches if m not in chosen)
    return [n for n in notebooks if n in chosen]


def notebook_parameters(name: str) -> dict[str, Any]:
    """The parameters a notebook declares (papermill's inspection of its tagged cell)."""
    import papermill

    path = paths.notebooks_dir() / f"{name}.ipynb"
    if not path.is_file():
        raise ValueError(f"no notebook {path}")
    declared = papermill.inspect_notebook(str(path))
    if not declared:
        raise ValueError(f"notebook {name} has no cell tagged 'parameters'")
    return declared


def validate_parameters(name: str, parameters: dict[str, Any]) -> None:
    """Raise ValueError naming every parameter the notebook does not declare."""
    declared = notebook_parameters(name)
    unknown = sorted(set(parameters) - set(declared))
    if unknown:
        raise ValueError(f"notebook {name} has no parameter(s) {unknown}; it declares "
                         f"{sorted(declared)}")
    missing = sorted(set(STANDARD_PARAMETERS) - set(declared))
    if missing:
        raise ValueError(f"notebook {name} must declare the standard parameters {missing}")


def kernel_name() -> str:
    """The venv's kernel ("repro", installed by ``make setup``), else the default python3."""
    from jupyter_client.kernelspec import KernelSpecManager

    specs = KernelSpecManager().find_kernel_specs()
    return "repro" if "repro" in specs else "python3"


def _execute(name: str, parameters: dict[str, Any], output: str, timeout: int,
             threads: int, build_dir: str) -> NotebookResult:
    """Run one notebook (in a worker process)."""
    import papermill
    from papermill.exceptions import PapermillExecutionError

    for variable in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                     "REPRO_TORCH_THREADS"):
        os.environ[variable] = str(threads)
    os.environ["REPRO_BUILD_DIR"] = build_dir
    os.environ.setdefault("MPLBACKEND", "Agg")
    start = time.perf_counter()
    try:
        papermill.execute_notebook(
            str(paths.notebooks_dir() / f"{name}.ipynb"), output, parameters=parameters,
            kernel_name=kernel_name(), progress_bar=False, log_output=False,
            cwd=str(paths.notebooks_dir()), execution_timeout=timeout, start_timeout=120)
    except PapermillExecutionError as error:
        source = error.source.strip().splitlines()
        first = source[0] if source else ""
        message = (f"notebook {name}, cell {error.cell_index} of the executed notebook "
                   f"(starting {first!r}) raised {error.ename}: {error.evalue}")
        return NotebookResult(name, False, time.perf_counter() - start, output, message)
    except Exception as error:  # kernel death, timeout, missing kernel
        return NotebookResult(name, False, time.perf_counter() - start, output,
                              f"notebook {name}: {type(error).__name__}: {error}")
    return NotebookResult(name, True, time.perf_counter() - start, output)


def previous_seconds(quick: bool) -> dict[str, float]:
    """Each notebook's slowest known wall time (``report.slowest_seconds``) in the reports of
    this kind of run: the build's own and the committed ``results/`` snapshot's (full runs
    only); {} if none."""
    candidates = [paths.run_build_dir(quick) / "report" / "claims.json"]
    if not quick:
        candidates.insert(0, paths.results_dir() / "claims.json")
    return slowest_of(*(slowest_seconds(candidate) for candidate in candidates))


def longest_first(targets: Sequence[str], seconds: dict[str, float]) -> list[str]:
    """``targets`` with the slowest known notebooks first (unknown ones before them), so that
    parallel workers do not end on one long notebook started last."""
    return sorted(targets, key=lambda name: -seconds.get(name, float("inf")))


def run_notebooks(targets: Iterable[str], *, quick: bool, seed: int = 0, device: str = "cpu",
                  jobs: int = 1, extra_parameters: dict[str, Any] | None = None,
                  timeout: int | None = None, threads: int | None = None,
                  log=print) -> list[NotebookResult]:
    """Execute ``targets`` with papermill into ``<build>/notebooks``; returns one result each.
    ``threads``: torch/BLAS threads per notebook (default: the cores shared among ``jobs``)."""
    targets = list(targets)
    if jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {jobs}")
    build_dir = paths.run_build_dir(quick)
    out_dir = build_dir / "notebooks"
    out_dir.mkdir(parents=True, exist_ok=True)
    base = {"quick": quick, "seed": seed, "device": device, "build_dir": str(build_dir)}
    parameters = {**base, **(extra_parameters or {})}
    for name in targets:  # validate everything before running anything
        validate_parameters(name, parameters)
    cores = os.cpu_count() or 1
    workers = min(jobs, len(targets)) or 1
    if threads is not None and threads < 1:
        raise ValueError(f"--threads must be at least 1, got {threads}")
    threads = threads or max(1, cores // workers)
    timeout = timeout or (600 if quick else 3600)
    results: list[NotebookResult] = []
    log(f"running {len(targets)} notebook(s) ({'quick' if quick else 'full'} parameters, "
        f"{workers} at a time, {threads} thread(s) each) into {out_dir}")
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        futures = {pool.submit(_execute, name, parameters, str(out_dir / f"{name}.ipynb"),
                               timeout, threads, str(build_dir)): name
                   for name in longest_first(targets, previous_seconds(quick))}
        for done, future in enumerate(as_completed(futures), start=1):
            result = future.result()
            results.append(result)
            status = "ok" if result.ok else "FAILED"
            log(f"[{done}/{len(targets)}] {result.name}: {status} in {result.seconds:.1f} s")
            if not result.ok:
                log(f"    {result.error}\n    executed notebook: {result.output}")
    order = {name: i for i, name in enumerate(targets)}
    return sorted(results, key=lambda r: order[r.name])


def reproduce(*, quick: bool, only: Sequence[str] | None = None, jobs: int = 1, seed: int = 0,
              device: str = "cpu", snapshot: bool = False,
              extra_parameters: dict[str, Any] | None = None, threads: int | None = None) -> int:
    """The ``reproduce`` command: run, then write the report (only when every notebook ran)."""
    from repro.claims.report import write_report, write_snapshot

    targets = resolve_targets(only)
    results = run_notebooks(targets, quick=quick, seed=seed, device=device, jobs=jobs,
                            extra_parameters=extra_parameters, threads=threads)
    failed = [r for r in results if not r.ok]
    build_dir = paths.run_build_dir(quick)
    if failed:
        print(f"{len(failed)} notebook(s) failed: {', '.join(r.name for r in failed)}; the last "
              f"good report in {build_dir / 'report'} is kept.", file=sys.stderr)
        return 1
    report = write_report(build_dir, quick=quick, runs=results)
    print(f"report: {report}")
    if snapshot:
        if quick:
            print("not refreshing results/: a quick run is a test, not a result")
        elif only:
            print("not refreshing results/: only a subset of notebooks ran")
        else:
            print(f"results snapshot: {write_snapshot(build_dir)}")
    return 0
