"""The package's side of the Snakemake workflow (``workflow/Snakefile``, docs/WORKFLOW.md).

One job is one notebook at one scale and base seed, run as ``python -m repro reproduce --only
NOTEBOOK --scale S --seed K`` (the package's run transaction stays the unit of work) with its
own build root: ``<out>/seed<K>/<notebook>/`` as ``REPRO_BUILD_ROOT``, so that jobs never
share a staging folder, a ``claims/`` folder or a report (:func:`job_root`). Every job reads
and writes one model cache (``REPRO_CACHE_DIR``, default ``<out>/cache``): its entries are
content-keyed (the seed and scale are in every key) and locked while trained
(``infra.cache.artifact_lock``), so jobs that need the same model train it once, as notebooks
of one ``reproduce --jobs N`` do.

This module gives the Snakefile what it must not type in itself: each job's folders, its
command line, and its resource request (:func:`job_resources`, from ``run.plan``'s tables:
the standard scale's measured minutes, the paper scale's counted CPU-hours); and the gather
(:func:`gather`, ``python -m repro.run.workflow gather``): the jobs of one base seed
merged into one build folder and reported with ``claims.report.write_report``, whose
provenance names every run.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import shutil
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from repro.infra.context import SCALES, check_scale
from repro.run import plan

__all__ = ["DEFAULTS", "JobResources", "WorkflowConfig", "executed_notebook", "gather",
           "gather_root", "job_device", "job_resources", "job_root", "report_path",
           "reproduce_arguments", "scale_folder"]

#: the workflow's settings when ``--config`` does not give them (workflow/config.yaml repeats
#: them for the reader): every notebook, base seed 0, the paper scale
DEFAULTS: dict[str, Any] = {
    "scale": "paper",
    "seeds": [0],
    "notebooks": None,        # None: every notebook; else names, number prefixes or claim IDs
    "device": "auto",         # auto: cuda at the paper scale, cpu at the others
    "threads": None,          # None: THREADS[scale]
    "data_dir": None,         # None: the generated stand-in set
    "out": "build/workflow",  # every job's build root, the gathered reports
    "cache_dir": None,        # None: <out>/cache, shared by every job
    "gpu_model": "",          # e.g. "a100": the SLURM executor's gpu_model resource
}

#: torch threads per job: one at the quick and standard scales (docs/COMPUTE.md §3a: one
#: thread per process, parallelism across processes); four at the paper scale, whose jobs
#: run alone on a GPU or a cluster node (an allowance, not a measurement)
THREADS: dict[str, int] = {"quick": 1, "standard": 1, "paper": 4}

#: docs/COMPUTE.md §3b: a plan is the measured (or counted) cost × 1.3
RUNTIME_MARGIN = 1.3
#: the smallest runtime a job asks for: a notebook's worker, kernel and imports take seconds,
#: a scheduler's clock minutes
MIN_RUNTIME_MIN = 10
#: quick jobs: no plan exists; the slowest quick notebook took 134–152 s on a busy 2-core
#: machine (docs/TIMINGS.md), so 15 minutes is ample on any node
QUICK_RUNTIME_MIN = 15

#: peak resident memory (MB) of a notebook's worker, kernel and training pools at the standard
#: scale: their summed RSS sampled every 20 s during the standard run of 2026-12-04 (a fresh
#: clone at commit 4aebdd2, cold cache, two notebooks at a time, one thread each; 42 min 39 s
#: wall; docs/WORKFLOW.md). Notebook 00 ran for one sample only
STANDARD_PEAK_RSS_MB: dict[str, float] = {
    "00_stand_in_data": 542.0,
    "01_x0_vs_eps": 2009.0,
    "02_root_representation": 1544.0,
    "03_emphasis_projection": 1458.0,
    "04_energy_contour_maps": 1338.0,
    "05_sef_ablation": 1183.0,
    "06_guidance_schedule": 1155.0,
    "07_latent_count": 1413.0,
    "08_composed_augmentation": 1732.0,
}
#: the least memory a job asks for: a kernel that imported torch holds about 0.5 GB before
#: any work, and a peak between two samples is not seen
MIN_MEM_MB = 2048
#: memory asked for, over that peak: × 1.5 at the standard and quick scales (quick jobs use
#: less: tiny data and models); at the paper scale twice the standard request, for its wider
#: models and their optimiser state — an allowance until a paper job's benchmark file
#: (``benchmark.tsv``'s max_rss) measures it
MEMORY_FACTOR: dict[str, float] = {"quick": 1.5, "standard": 1.5, "paper": 3.0}


@dataclass(frozen=True)
class JobResources:
    """What one job asks of the scheduler: wall minutes, memory (MB), threads (cores) and GPUs
    (Snakemake's ``runtime``, ``mem_mb``, ``threads`` and the SLURM executor's ``gpu``)."""

    runtime: int
    mem_mb: int
    threads: int
    gpu: int


def _cpu_minutes(notebook: str, scale: str) -> float:
    """One thread's minutes for ``notebook`` at ``scale``, with the models it reads from other
    notebooks' shares (it may train them, or wait for the lender to): ``run.plan``."""
    if scale == "quick":
        return float(QUICK_RUNTIME_MIN)
    if scale == "standard":
        minutes = plan.STANDARD_PLAN_MINUTES
        return minutes[notebook] + sum(minutes[lender]
                                       for lender in plan.STANDARD_READS.get(notebook, ()))
    shared = plan.PAPER_SHARED_CPU_HOURS.get(notebook, {})
    return 60.0 * (plan.PAPER_CPU_HOURS[notebook] + sum(shared.values()))


def job_device(notebook: str, scale: str, device: str = "auto") -> str:
    """The device a job passes to ``reproduce``: ``auto`` stays ``auto`` at the paper scale —
    ``reproduce --device auto`` takes cuda where the job runs on a GPU, cpu on a machine
    without one (``run.params.resolve_device``) — and is cpu at the others; notebook 00 (no
    model: its ``device`` is unused) always runs on cpu, so it never asks for a GPU."""
    if notebook.startswith("00_"):
        return "cpu"
    if device == "auto":
        return "auto" if check_scale(scale) == "paper" else "cpu"
    return device


def job_resources(notebook: str, scale: str, *, device: str = "auto",
                  threads: int | None = None) -> JobResources:
    """The request of the job running ``notebook`` at ``scale``.

    runtime: one thread's minutes (``run.plan``: the standard scale's measured shares, the
    paper scale's counted CPU-hours, each with the models it reads from other notebooks) ×
    :data:`RUNTIME_MARGIN`, at least :data:`MIN_RUNTIME_MIN`; an upper bound on a GPU or with
    more threads, whose speed-up no run has measured yet. mem_mb: the standard scale's peak
    × :data:`MEMORY_FACTOR`, in steps of 512, at least :data:`MIN_MEM_MB`. gpu: 1 when the
    job's device is cuda or auto (a GPU is asked for; where none is, the job runs on cpu).
    threads: the cores asked for; the job runs with what Snakemake grants (the local
    profile's cores cap it), :meth:`WorkflowConfig.arguments`.
    """
    check_scale(scale)
    if notebook not in plan.STANDARD_PLAN_MINUTES:
        raise ValueError(f"no plan for notebook {notebook!r}; planned: "
                         f"{', '.join(plan.STANDARD_PLAN_MINUTES)}")
    runtime = max(MIN_RUNTIME_MIN, math.ceil(_cpu_minutes(notebook, scale) * RUNTIME_MARGIN))
    mem_mb = max(MIN_MEM_MB, 512 * math.ceil(STANDARD_PEAK_RSS_MB[notebook]
                                             * MEMORY_FACTOR[scale] / 512))
    threads = THREADS[scale] if threads is None else threads
    if threads < 1:
        raise ValueError(f"threads must be at least 1, got {threads}")
    gpu = int(job_device(notebook, scale, device).startswith(("cuda", "auto")))
    return JobResources(runtime=runtime, mem_mb=mem_mb, threads=threads, gpu=gpu)


# --- where each job writes -----------------------------------------------------------------

def scale_folder(root: str | Path, scale: str) -> Path:
    """The build folder a run of ``scale`` publishes into under build root ``root``: the root
    itself for the standard scale, ``root/quick`` and ``root/paper`` for the others
    (``infra.paths.run_build_dir`` with ``REPRO_BUILD_ROOT=root``)."""
    return Path(root) if check_scale(scale) == "standard" else Path(root) / scale


def job_root(out: str | Path, notebook: str, seed: int | str) -> Path:
    """The build root (``REPRO_BUILD_ROOT``) of the job running ``notebook`` from base seed
    ``seed``: ``<out>/seed<K>/<notebook>``."""
    return Path(out) / f"seed{seed}" / notebook


def executed_notebook(out: str | Path, notebook: str, seed: int | str, scale: str) -> Path:
    """The job's output: its executed notebook, which the runner publishes only when the
    notebook succeeded (``run.transaction.publish``)."""
    return scale_folder(job_root(out, notebook, seed), scale) / "notebooks" / f"{notebook}.ipynb"


def gather_root(out: str | Path, seed: int | str) -> Path:
    """The build root the jobs of base seed ``seed`` are gathered into: ``<out>/seed<K>/all``
    (no notebook is called ``all``: their names start with two digits)."""
    return Path(out) / f"seed{seed}" / "all"


def report_path(out: str | Path, seed: int | str, scale: str) -> Path:
    """The gathered report of base seed ``seed``."""
    return scale_folder(gather_root(out, seed), scale) / "report" / "REPORT.md"


def reproduce_arguments(notebook: str, scale: str, seed: int, *, device: str = "auto",
                        threads: int | None = None, data_dir: str | None = None) -> str:
    """``reproduce``'s arguments for one job, shell-quoted: one notebook, one worker, the
    job's threads (those Snakemake granted, else its request) and device, and ``-p
    data_dir=...`` when a data folder is given."""
    resources = job_resources(notebook, scale, device=device, threads=threads)
    arguments = ["reproduce", "--only", notebook, "--scale", scale, "--seed", str(seed),
                 "--jobs", "1", "--threads", str(resources.threads),
                 "--device", job_device(notebook, scale, device)]
    if data_dir is not None:
        arguments += ["-p", f"data_dir={json.dumps(str(data_dir))}"]
    return shlex.join(arguments)


# --- the workflow's configuration ----------------------------------------------------------

@dataclass(frozen=True)
class WorkflowConfig:
    """The Snakefile's ``config`` checked: scale, base seeds, notebooks (resolved to names),
    device, threads, data folder, output and cache folders, GPU model."""

    scale: str
    seeds: tuple[int, ...]
    notebooks: tuple[str, ...]
    device: str
    threads: int | None
    data_dir: str | None
    out: Path
    cache_dir: Path
    gpu_model: str

    @classmethod
    def from_config(cls, config: Mapping[str, Any]) -> WorkflowConfig:
        """Check Snakemake's ``config`` (defaults: :data:`DEFAULTS`); raises ValueError saying
        which key is wrong. Folders are made absolute against the working directory."""
        from repro.run.runner import resolve_targets

        unknown = sorted(set(config) - set(DEFAULTS))
        if unknown:
            raise ValueError(f"unknown workflow config key(s) {unknown}; known: "
                             f"{', '.join(DEFAULTS)}")
        merged = {**DEFAULTS, **{k: v for k, v in config.items() if v is not None}}
        scale = merged["scale"]
        if scale not in SCALES:
            raise ValueError(f"scale must be one of {', '.join(SCALES)}, got {scale!r}")
        seeds = merged["seeds"]
        seeds = [seeds] if isinstance(seeds, int | str) else list(seeds)
        try:
            seeds = [int(s) for s in seeds]
        except (TypeError, ValueError):
            raise ValueError(f"seeds must be base seeds (integers ≥ 0), got {seeds}") from None
        if not seeds or min(seeds) < 0 or len(set(seeds)) != len(seeds):
            raise ValueError(f"seeds must be distinct integers ≥ 0, got {seeds}")
        notebooks = merged["notebooks"]
        if isinstance(notebooks, str):
            notebooks = notebooks.split(",")
        names = resolve_targets([str(n) for n in notebooks] if notebooks else None)
        device = str(merged["device"])
        if device != "auto" and device.split(":")[0] not in ("cpu", "cuda"):
            raise ValueError(f"device must be auto, cpu or cuda[:N], got {device!r}")
        threads = merged["threads"]
        if threads is not None and (not isinstance(threads, int) or threads < 1):
            raise ValueError(f"threads must be an integer ≥ 1, got {threads!r}")
        out = Path(merged["out"]).resolve()
        cache = Path(merged["cache_dir"]).resolve() if merged["cache_dir"] else out / "cache"
        data_dir = merged["data_dir"]
        return cls(scale=scale, seeds=tuple(seeds), notebooks=tuple(names), device=device,
                   threads=threads, data_dir=None if data_dir is None else str(data_dir),
                   out=out, cache_dir=cache, gpu_model=str(merged["gpu_model"] or ""))

    def resources(self, notebook: str) -> JobResources:
        """:func:`job_resources` of ``notebook`` under this configuration."""
        return job_resources(notebook, self.scale, device=self.device, threads=self.threads)

    def arguments(self, notebook: str, seed: int | str, threads: int | None = None) -> str:
        """:func:`reproduce_arguments` of one job under this configuration, with the
        ``threads`` Snakemake granted it (its request constrained by the profile's cores);
        None: its request."""
        return reproduce_arguments(notebook, self.scale, int(seed), device=self.device,
                                   threads=threads or self.threads, data_dir=self.data_dir)

    def claim_notebooks(self) -> tuple[str, ...]:
        """The chosen notebooks that record claims (what a report can be written from)."""
        from repro.claims.registry import claims_for_notebook

        return tuple(n for n in self.notebooks if claims_for_notebook(n))


# --- the gather ----------------------------------------------------------------------------

def _job_runs(build: Path) -> list[dict[str, Any]]:
    """The ``run.json`` records in a job's build folder, oldest first (run IDs start with
    their UTC start time)."""
    from repro.infra.storage import read_json

    return [read_json(p) for p in sorted((build / "runs").glob("*/run.json"))]


def gather(job_roots: Sequence[str | Path], into: str | Path, *, scale: str,
           seed: int) -> Path:
    """Merge the jobs of base seed ``seed`` (their build roots) into build root ``into`` and
    write its report; returns REPORT.md.

    The merged build folder gets every job's claim sidecars (``claims/``, figures stay where
    the sidecars name them) and executed notebooks (``notebooks/``, what ``stability``'s
    coverage table reads), replacing what an earlier gather left there and in ``report/``
    (its run times included: the jobs' own reports keep theirs). The report is
    ``claims.report.write_report`` with ``allow_mixed`` (each job is its own run), so its
    provenance names every run and its claims; the note before it names every job, its run
    and its build folder, also those that record no claim (notebook 00). Raises ValueError
    when a job holds no run, a claim is recorded by two jobs, or a sidecar is of another
    base seed or scale.
    """
    from repro.claims.ledger import load_sidecars
    from repro.claims.report import recorded_runs, write_report
    from repro.claims.stability import check_base_seed

    target = scale_folder(into, scale)
    for folder in ("claims", "notebooks", "report"):
        shutil.rmtree(target / folder, ignore_errors=True)
    for folder in ("claims", "notebooks"):
        (target / folder).mkdir(parents=True)
    jobs, recorded, origin = [], [], {}
    for root in map(Path, job_roots):
        build = scale_folder(root, scale)
        runs = _job_runs(build)
        if not runs:
            raise ValueError(f"{build} holds no run of the {scale} scale: run its job first")
        sidecars = load_sidecars(build / "claims")
        check_base_seed(sidecars, seed, build)
        for claim_id, sidecar in sidecars.items():
            if claim_id in origin:
                raise ValueError(f"{claim_id} is recorded by two jobs: {origin[claim_id]} and "
                                 f"{build}")
            if sidecar.get("scale") != scale:
                raise ValueError(f"{build / 'claims' / claim_id}.json is of the "
                                 f"{sidecar.get('scale')} scale, not {scale}")
            origin[claim_id] = build
            shutil.copy2(build / "claims" / f"{claim_id}.json", target / "claims")
        for executed in sorted((build / "notebooks").glob("*.ipynb")):
            shutil.copy2(executed, target / "notebooks")
        recorded += recorded_runs(build / "report")
        last = runs[-1]
        jobs.append(f"{', '.join(last.get('notebooks', [])) or root.name} → run "
                    f"{last['run_id']} ({build})")
    note = (f"Snakemake workflow (docs/WORKFLOW.md): {len(jobs)} job(s) from base seed "
            f"{seed}, one run each: {'; '.join(jobs)}.")
    return write_report(target, scale=scale, runs=recorded, provenance=note, allow_mixed=True)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m repro.run.workflow gather --scale S --seed K --into ROOT JOB_ROOT...``."""
    parser = argparse.ArgumentParser(prog="python -m repro.run.workflow",
                                     description="the Snakemake workflow's gather step")
    sub = parser.add_subparsers(dest="command", required=True)
    gat = sub.add_parser("gather", help="merge the jobs of one base seed and write its report")
    gat.add_argument("job_roots", nargs="+", metavar="JOB_ROOT",
                     help="each job's build root (REPRO_BUILD_ROOT)")
    gat.add_argument("--into", required=True, help="the merged build root")
    gat.add_argument("--scale", required=True, choices=SCALES)
    gat.add_argument("--seed", required=True, type=int, help="the jobs' base seed")
    args = parser.parse_args(argv)
    try:
        report = gather(args.job_roots, args.into, scale=args.scale, seed=args.seed)
    except ValueError as error:  # also claims.provenance.ReportError
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"report: {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
