"""Execute the notebooks with papermill, one worker process per notebook, and write the report.

- Parameters are validated (names, types, ranges, folders, the dataset) against each
  notebook's ``parameters`` cell before any kernel starts (``run.params``).
- A run is a transaction (``run.transaction``): notebooks write into the run's staging folder
  and a notebook's outputs are published only when it succeeded.
- Children die with the run: workers by ``PR_SET_PDEATHSIG``, kernels (and their pools) by
  ``run.kernel_guard``; on SIGINT/SIGTERM the runner kills them itself and publishes nothing
  more.
- Each notebook runs with torch/BLAS threads limited so that ``--jobs`` processes share the
  cores; a per-cell timeout stops a hung cell. Progress: ``run.progress_view``.
- Each scale writes into its own folder (``paths.run_build_dir``): a quick (test) run never
  touches the standard run's outputs.
- A failing notebook is reported with its cell; the others still run and publish; the command
  exits non-zero and the last good report is kept.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from repro.claims.budgets import record_timings, run_timing
from repro.claims.registry import CLAIMS
from repro.claims.report import slowest_of, slowest_seconds
from repro.infra import cache, lifetime, paths, progress
from repro.infra.machine import cpu_label
from repro.infra.storage import free_bytes, read_json, write_problem
from repro.run import params, plan, transaction, worker
from repro.run.params import STANDARD_PARAMETERS, validate_parameters
from repro.run.progress_view import ProgressView

__all__ = ["STANDARD_PARAMETERS", "NotebookResult", "RunInterrupted", "available_notebooks",
           "known_seconds", "longest_first", "preflight", "refuse_snapshot", "reproduce",
           "resolve_targets",
           "run_notebooks", "validate_parameters"]


class RunInterrupted(Exception):
    """SIGINT or SIGTERM reached the runner; its children were stopped."""

    def __init__(self, signum: int) -> None:
        super().__init__(f"stopped by {signal.Signals(signum).name}")
        self.signum = signum


@dataclass
class NotebookResult:
    """A notebook's outcome: ``output`` is the published executed notebook, or the staged one
    when it failed."""

    name: str
    ok: bool
    seconds: float
    output: str
    error: str = ""
    claims: tuple[str, ...] = ()
    notices: tuple[str, ...] = ()


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


def known_seconds(scale: str) -> dict[str, float]:
    """Each notebook's expected wall time at ``scale``: the slowest measured
    (``report.slowest_seconds``) in the reports of runs of this scale — the build's own and,
    for the standard scale, the committed ``results/`` snapshot's —, else the compute plan's
    (``plan.planned_seconds``); never a time of another scale's run."""
    candidates = [paths.run_build_dir(scale) / "report" / "claims.json"]
    if scale == "standard":
        candidates.insert(0, paths.results_dir() / "claims.json")
    measured = slowest_of(*(slowest_seconds(c) for c in candidates
                            if c.is_file() and read_json(c).get("scale") == scale))
    return {**plan.planned_seconds(scale), **measured}


def longest_first(targets: Sequence[str], seconds: dict[str, float]) -> list[str]:
    """``targets`` with the slowest known notebooks first (unknown ones before them), so that
    parallel workers do not end on one long notebook started last."""
    return sorted(targets, key=lambda name: -seconds.get(name, float("inf")))




def kernel_name() -> str:
    """The venv's kernel ("repro", installed by ``make setup``), else the default python3."""
    from jupyter_client.kernelspec import KernelSpecManager

    specs = KernelSpecManager().find_kernel_specs()
    return "repro" if "repro" in specs else "python3"


@dataclass
class _Running:
    name: str
    process: subprocess.Popen
    started: float
    log: IO[bytes]


@contextlib.contextmanager
def _signals_raise() -> Iterator[None]:
    """SIGINT/SIGTERM raise :class:`RunInterrupted` in the main thread while the run lasts."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, _frame: Any) -> None:
        raise RunInterrupted(signum)

    previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


def _stop_children(running: dict[str, _Running], pids_dir: Path) -> None:
    """Kill every kernel group the run registered and every worker, and wait for them."""
    kernels = []
    for pid_file in pids_dir.glob("kernel-*"):
        with contextlib.suppress(ValueError, OSError):
            kernels.append(int(pid_file.read_text()))
    for pid in kernels:
        lifetime.kill_group(pid)
    for job in running.values():
        with contextlib.suppress(ProcessLookupError):
            job.process.kill()
    deadline = time.monotonic() + 10
    for job in running.values():
        with contextlib.suppress(subprocess.TimeoutExpired):
            job.process.wait(timeout=max(deadline - time.monotonic(), 0.1))
        job.log.close()
    while any(lifetime.pid_alive(pid) for pid in kernels) and time.monotonic() < deadline:
        time.sleep(0.05)


def _start(run: transaction.Run, name: str, parameters: dict[str, Any], *, threads: int,
           timeout: int, kernel: str) -> _Running:
    folder = run.notebook_dir(name)
    folder.mkdir(parents=True)
    spec = worker.WorkerSpec(
        name=name, notebook=str(paths.notebooks_dir() / f"{name}.ipynb"),
        output=str(folder / f"{name}.ipynb"), staging=str(folder),
        parameters={**parameters, "build_dir": str(folder)}, threads=threads, timeout=timeout,
        run_id=run.run_id, runner_pid=os.getpid(), kernel_name=kernel,
        progress_dir=str(run.progress_dir), pids_dir=str(run.pids_dir))
    worker.write_spec(folder / "worker.json", spec)
    log = open(folder / "worker.log", "wb")  # closed when the worker ends
    process = subprocess.Popen([sys.executable, "-m", "repro.run.worker",
                                str(folder / "worker.json")], stdout=log,
                               stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    return _Running(name, process, time.perf_counter(), log)


def _result(run: transaction.Run, job: _Running) -> NotebookResult:
    folder = run.notebook_dir(job.name)
    job.log.close()
    seconds = time.perf_counter() - job.started
    output = str(folder / f"{job.name}.ipynb")
    notices = tuple(progress.notices(run.progress_dir / f"{job.name}.stage.json"))
    try:
        outcome = read_json(folder / "result.json")
    except (OSError, ValueError):
        return NotebookResult(job.name, False, seconds, output, _no_result(job, folder),
                              notices=notices)
    if not outcome["ok"]:
        return NotebookResult(job.name, False, outcome["seconds"], output, outcome["error"],
                              notices=notices)
    try:
        claims = transaction.publish(run, job.name)
    except (OSError, ValueError) as error:
        text = write_problem(error) if isinstance(error, OSError) else str(error)
        return NotebookResult(job.name, False, outcome["seconds"], output,
                              f"notebook {job.name}: {text}", notices=notices)
    published = str(run.build_dir / "notebooks" / f"{job.name}.ipynb")
    return NotebookResult(job.name, True, outcome["seconds"], published, claims=tuple(claims),
                          notices=notices)


#: below this many free bytes, a worker that left no result and no log met a full disk
FULL_DISK_BYTES = 16 * 2**20

#: the least free space a run of each scale needs on the disks of its build folder and of
#: the model cache: about what a cold run writes (the standard scale: two generated data
#: sets of about 120 MB, the models, executed notebooks and figures of about 12 MB)
MIN_FREE_BYTES: dict[str, int] = {"quick": 128 * 2**20, "standard": 512 * 2**20,
                                  "paper": 2048 * 2**20}


def _sidecar_problems(claims_dir: Path, scale: str, rewritten: set[str]) -> list[str]:
    """The claim sidecars in ``claims_dir`` the report after this run would refuse — garbled
    or of another scale — but those this run's notebooks record anew (their files are
    replaced when they publish)."""
    from repro.claims.ledger import read_sidecar
    from repro.claims.provenance import ReportError

    problems = []
    for path in sorted(claims_dir.glob("*.json")) if claims_dir.is_dir() else []:
        if path.stem in rewritten:
            continue
        try:
            sidecar = read_sidecar(path)
        except ReportError as error:
            problems.append(str(error))
            continue
        if sidecar.get("scale") != scale:
            problems.append(f"the claim sidecar {path} is of the {sidecar.get('scale')!r} "
                            f"scale, in the {scale} scale's folder: remove it and rerun its "
                            f"notebook (python -m repro reproduce --only {path.stem} --scale "
                            f"{scale})")
    return problems


def _disk_of(folder: Path) -> int:
    """The device id of the disk holding ``folder`` (its nearest existing folder)."""
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    try:
        return os.stat(folder).st_dev
    except OSError:
        return -1


def _disk_problems(scale: str) -> list[str]:
    """The build folder's and the model cache's disks, each with less free space than a run
    of ``scale`` needs (:data:`MIN_FREE_BYTES`)."""
    need = MIN_FREE_BYTES[scale]
    problems, seen = [], set()
    for what, folder in (("build folder", paths.run_build_dir(scale)),
                         ("model cache", paths.cache_dir())):
        free, disk = free_bytes(folder), _disk_of(folder)
        if 0 <= free < need and disk not in seen:
            seen.add(disk)
            problems.append(f"the disk holding the {what} {folder} has {free / 2**20:.1f} MiB "
                            f"free; a {scale}-scale run needs about {need // 2**20} MiB there: "
                            "free space on it, or point REPRO_BUILD_ROOT (and REPRO_CACHE_DIR) "
                            "at a disk with room")
    return problems


def preflight(targets: Sequence[str], scale: str) -> None:
    """What a run of ``targets`` needs beyond its parameters, checked before any kernel
    starts; raises ValueError naming every problem: a claim sidecar in the scale's
    ``claims/`` that the report would refuse (garbled, or of another scale) and that this
    run does not record anew, and a disk without room for the run."""
    from repro.claims.registry import claims_for_notebook

    rewritten = {claim.id for name in targets for claim in claims_for_notebook(name)}
    problems = _sidecar_problems(paths.run_build_dir(scale) / "claims", scale, rewritten)
    problems += _disk_problems(scale)
    if problems:
        raise ValueError("; ".join(problems) + "; nothing ran")


def _no_result(job: _Running, folder: Path) -> str:
    """Why a worker left no ``result.json``: the last line of its log, else a full disk or
    the signal that killed it (its log is empty then, so pointing at it helps nobody)."""
    code = job.process.returncode
    start = f"notebook {job.name}: its worker ended with exit code {code} and no result"
    log = folder / "worker.log"
    try:
        lines = log.read_text(encoding="utf-8", errors="replace").strip().splitlines()
    except OSError:
        lines = []
    if lines:
        return f"{start}: {lines[-1].strip()} (the whole traceback: {log})"
    free = free_bytes(folder)
    if 0 <= free < FULL_DISK_BYTES:
        return (f"{start} and an empty log: the disk holding {folder} is full ({free} bytes "
                "free); free space on it and rerun")
    killed = f", killed by {signal.Signals(-code).name}" if code and code < 0 else ""
    return f"{start} and an empty log{killed}"


def run_notebooks(targets: Iterable[str], *, scale: str, seed: int = 0, device: str = "cpu",
                  jobs: int = 1, extra_parameters: dict[str, Any] | None = None,
                  timeout: int | None = None, threads: int | None = None,
                  log=print, stream: IO[str] | None = None,
                  status_interval_s: float = 30.0) -> list[NotebookResult]:
    """Execute ``targets`` as one run (see the module docstring); returns one result each.

    ``threads``: torch/BLAS threads per notebook (default: the cores shared among ``jobs``).
    ``stream``: where progress goes (default stdout; redrawn when it is a terminal).
    Raises ValueError before anything runs when a parameter is wrong, and
    :class:`RunInterrupted` after stopping every child on SIGINT/SIGTERM.
    """
    targets = list(targets)
    if jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {jobs}")
    if threads is not None and threads < 1:
        raise ValueError(f"--threads must be at least 1, got {threads}")
    extra = dict(extra_parameters or {})
    params.check_extra_parameters(extra)
    extra = params.absolute_folders(extra)
    parameters = {"scale": scale, "seed": seed, "device": device, "build_dir": None, **extra}
    params.forget_checks()
    for name in targets:  # validate everything before running anything
        validate_parameters(name, parameters)
    preflight(targets, scale)
    workers = min(jobs, len(targets)) or 1
    threads = threads or max(1, (os.cpu_count() or 1) // workers)
    timeout = timeout or (600 if scale == "quick" else 3600 if scale == "standard" else 86400)
    try:
        removed = cache.clean_cache()
        damaged = cache.check_entries()
        run = transaction.new_run(scale=scale, seed=seed, device=device, targets=targets,
                                  parameters=parameters)
    except OSError as error:  # a read-only or full build/ or cache: refused before any kernel
        raise ValueError(f"{write_problem(error)}; nothing ran") from None
    if removed:
        log(f"cache: removed {len(removed)} leftover(s) of failed runs (lock-only folders, "
            "interrupted writes)")
    for message in damaged:
        log(f"warning: {message}")
    log(f"run {run.run_id}: {len(targets)} notebook(s) ({run.scale} scale, {workers} at a "
        f"time, {threads} thread(s) each); staging {run.staging}, publishing into "
        f"{run.build_dir}")
    known = known_seconds(scale)
    pending = longest_first(targets, known)
    view = ProgressView(progress_dir=run.progress_dir, total=len(targets), workers=workers,
                        known_s=known, stream=stream, interval_s=status_interval_s)
    running: dict[str, _Running] = {}
    results: list[NotebookResult] = []
    kernel = kernel_name()
    try:
        with _signals_raise():
            while pending or running:
                while pending and len(running) < workers:
                    name = pending.pop(0)
                    running[name] = _start(run, name, parameters, threads=threads,
                                           timeout=timeout, kernel=kernel)
                    slowest = (f"slowest known {known[name]:.0f} s" if name in known
                               else "no time known yet")
                    view.log(f"[start] {name} ({slowest})")
                for name, job in list(running.items()):
                    if job.process.poll() is None:
                        continue
                    del running[name]
                    result = _result(run, job)
                    results.append(result)
                    status = "ok" if result.ok else "FAILED"
                    view.log(f"[{len(results)}/{len(targets)}] {name}: {status} in "
                             f"{result.seconds:.1f} s")
                    for notice in result.notices:
                        view.log(f"    warning: {notice}")
                    if not result.ok:
                        view.log(f"    {result.error}\n    executed notebook (not published): "
                                 f"{result.output}")
                now = time.perf_counter()
                view.update(pending, {n: now - j.started for n, j in running.items()},
                            len(results))
                time.sleep(0.2 if running else 0)
    except BaseException as stop:
        view.close()
        _stop_children(running, run.pids_dir)
        if isinstance(stop, RunInterrupted):
            log(f"run {run.run_id} {stop}: its kernels and workers are stopped; "
                f"{len(running)} unfinished notebook(s) published nothing "
                f"({', '.join(running) or 'none'}); staging kept in {run.staging}")
        raise
    view.close()
    transaction.finish(run, [r.name for r in results if not r.ok])
    order = {name: i for i, name in enumerate(targets)}
    return sorted(results, key=lambda r: order[r.name])


def report_state(build_dir: Path) -> str:
    """What became of the report in ``build_dir`` when a run or ``report`` wrote none."""
    report = build_dir / "report" / "REPORT.md"
    if report.is_file():
        return f"the last good report ({report}) is kept"
    return f"there is no report in {report.parent} yet"


def _mixed_runs(build_dir: Path, scale: str) -> str:
    """Why the report is not rewritten after this run: its claims now come from several
    runs (e.g. ``--only`` after a complete run); "" when they come from one."""
    from repro.claims.ledger import load_sidecars
    from repro.claims.provenance import runs_of

    runs = runs_of(load_sidecars(build_dir / "claims"))
    if len(runs) < 2:
        return ""
    named = "; ".join(f"run {run} ({', '.join(claims)})" for run, claims in runs.items())
    return (f"the report is not rewritten: the claims in {build_dir / 'claims'} now come from "
            f"{len(runs)} runs: {named}. python -m repro report --scale {scale} "
            "--allow-mixed writes a report over them naming every run; a run of every "
            "notebook together (python -m repro reproduce) makes them one run again")


def _cache_notices(results: Sequence[NotebookResult]) -> str:
    """The run's cache warnings, for the report's provenance ("" when there were none)."""
    notices = [f"{r.name}: {notice}" for r in results for notice in r.notices]
    return f"Warnings of this run: {' | '.join(notices)}." if notices else ""


def refuse_snapshot(scale: str, snapshot: bool) -> None:
    """``--snapshot`` refreshes ``results/``, which holds a standard-scale run only: asked of
    another scale it is refused (ValueError) before any work."""
    if snapshot and scale != "standard":
        raise ValueError(f"--snapshot refreshes results/, which holds the standard scale's run; "
                         f"this is the {scale} scale"
                         + (" (a test, never a result)" if scale == "quick" else "")
                         + ": drop --snapshot")


def reproduce(*, scale: str, only: Sequence[str] | None = None, jobs: int = 1, seed: int = 0,
              device: str = "cpu", snapshot: bool = False,
              extra_parameters: dict[str, Any] | None = None, threads: int | None = None,
              allow_mixed: bool = False) -> int:
    """The ``reproduce`` command: run, then write the report (only when every notebook ran).
    Exit codes: 0 done (also when the notebooks ran but the build's claims now come from
    several runs: the report is then left as it was, and the message says how to write one),
    1 a notebook failed, a file could not be written or the report could not be made,
    130/143 stopped by SIGINT/SIGTERM; a bad argument raises ValueError (the CLI's exit 2)."""
    from repro.claims.provenance import ReportError
    from repro.claims.report import write_report, write_snapshot

    targets = resolve_targets(only)
    refuse_snapshot(scale, snapshot)
    started, cold = time.monotonic(), not cache.holds_models()
    build_dir = paths.run_build_dir(scale)
    try:
        results = run_notebooks(targets, scale=scale, seed=seed, device=device, jobs=jobs,
                                extra_parameters=extra_parameters, threads=threads)
    except RunInterrupted as stop:
        print(f"interrupted ({stop}); {report_state(build_dir)}.", file=sys.stderr)
        return 128 + stop.signum
    except OSError as error:  # during the run: its kernels and workers are stopped
        print(f"error: {write_problem(error)}; the run stopped; notebooks that finished "
              f"before were published; {report_state(build_dir)}.", file=sys.stderr)
        return 1
    failed = [r for r in results if not r.ok]
    if failed:
        print(f"{len(failed)} notebook(s) failed: {', '.join(r.name for r in failed)}; the "
              f"others were published; {report_state(build_dir)}.", file=sys.stderr)
        return 1
    if not any(r.claims for r in results):
        print(f"this run recorded no claim ({', '.join(targets)}): the report in "
              f"{build_dir / 'report'} is not rewritten")
        return 0
    try:
        mixed = "" if allow_mixed else _mixed_runs(build_dir, scale)
        if mixed:
            print(f"the notebooks ran and were published into {build_dir}; {mixed}")
            return 0
        report = write_report(build_dir, scale=scale, runs=results, allow_mixed=allow_mixed,
                              provenance=_cache_notices(results))
        if not only:
            record_timings(report.parent, run_timing(
                scale=scale, seconds=time.monotonic() - started, cold=cold,
                commit=transaction.git_commit(), cpu=cpu_label()))
        print(f"report: {report}")
        if snapshot and only:
            print("not refreshing results/: only a subset of notebooks ran")
        elif snapshot:
            print(f"results snapshot: {write_snapshot(build_dir)}")
    except ReportError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except OSError as error:  # the notebooks were published; the report may be half written
        print(f"error: {write_problem(error)}; the notebooks were published: once it can be "
              f"written, python -m repro report --scale {scale}"
              f"{' --snapshot' if snapshot else ''} writes the report", file=sys.stderr)
        return 1
    return 0
