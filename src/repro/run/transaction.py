"""A run as a transaction: stage everything, publish a notebook only when it succeeded.

Each ``reproduce`` gets a run ID (UTC start time, commit, base seed, scale) and a staging folder
``<build>/runs/<run ID>/`` holding ``run.json`` and one folder per notebook (the notebook's
``build_dir``: its claims/, figures/, executed notebook, result and worker log). When a
notebook succeeds, :func:`publish` moves its figures, executed notebook and sidecars (last)
into the build folder the report reads; a failed or interrupted notebook publishes nothing,
and its staging folder is kept for inspection.
"""

from __future__ import annotations

import datetime as _dt
import os
import shutil
import subprocess
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from repro.infra import paths
from repro.infra.storage import read_json, write_json


@dataclass(frozen=True)
class Run:
    """One ``reproduce``: its ID and where it stages and publishes."""

    run_id: str
    commit: str
    seed: int
    scale: str
    started: str
    build_dir: Path
    staging: Path

    def notebook_dir(self, name: str) -> Path:
        return self.staging / name

    @property
    def progress_dir(self) -> Path:
        return self.staging / "progress"

    @property
    def pids_dir(self) -> Path:
        return self.staging / "pids"


def git_commit() -> str:
    """The short commit of the checkout, with ``+dirty`` when tracked files changed; "nogit"."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=paths.REPO_ROOT,
                              capture_output=True, text=True, timeout=10, check=False)
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=paths.REPO_ROOT, capture_output=True, text=True, timeout=10,
                               check=False)
    except (OSError, subprocess.SubprocessError):
        return "nogit"
    commit = head.stdout.strip() or "nogit"
    return commit + ("+dirty" if dirty.stdout.strip() else "")


def new_run(*, scale: str, seed: int, device: str, targets: list[str],
            parameters: dict[str, Any]) -> Run:
    """Create the staging folder and ``run.json`` of a new run."""
    now = _dt.datetime.now(_dt.UTC)
    commit = git_commit()
    run_id = f"{now:%Y%m%dT%H%M%S}.{now.microsecond // 1000:03d}Z-{commit}-seed{seed}-{scale}"
    build_dir = paths.run_build_dir(scale)
    staging = build_dir / "runs" / run_id
    staging.mkdir(parents=True)
    run = Run(run_id=run_id, commit=commit, seed=seed, scale=scale,
              started=now.isoformat(timespec="seconds"), build_dir=build_dir, staging=staging)
    record = {k: str(v) if isinstance(v, Path) else v for k, v in asdict(run).items()}
    write_json(staging / "run.json", {**record, "device": device, "notebooks": targets,
                                      "parameters": parameters, "runner_pid": os.getpid()})
    for folder in (run.progress_dir, run.pids_dir):
        folder.mkdir()
    return run


def _published_path(path: str, source: Path, target: Path) -> str:
    try:
        return str(target / Path(path).resolve().relative_to(source.resolve()))
    except ValueError:
        return path


def publish(run: Run, name: str) -> list[str]:
    """Move notebook ``name``'s staged outputs into the build folder; returns the claim IDs
    published. Raises ValueError (publishing nothing) when a sidecar is not this run's."""
    source = run.notebook_dir(name)
    sidecars = {p: read_json(p) for p in sorted((source / "claims").glob("*.json"))}
    for path, sidecar in sidecars.items():
        if sidecar.get("run_id") != run.run_id or sidecar.get("scale") != run.scale:
            raise ValueError(f"{path} says run {sidecar.get('run_id')!r}, scale "
                             f"{sidecar.get('scale')!r}; this is run {run.run_id} "
                             f"({run.scale} scale): not published")
    figures = source / "figures"
    for figure in sorted(figures.glob("*")) if figures.is_dir() else []:
        (run.build_dir / "figures").mkdir(parents=True, exist_ok=True)
        os.replace(figure, run.build_dir / "figures" / figure.name)
    executed = source / f"{name}.ipynb"
    if executed.is_file():
        (run.build_dir / "notebooks").mkdir(parents=True, exist_ok=True)
        os.replace(executed, run.build_dir / "notebooks" / executed.name)
    for sidecar in sidecars.values():
        sidecar["figures"] = [_published_path(f, figures, run.build_dir / "figures")
                              for f in sidecar.get("figures", [])]
        write_json(run.build_dir / "claims" / f"{sidecar['id']}.json", sidecar)
    shutil.rmtree(source, ignore_errors=True)
    return [sidecar["id"] for sidecar in sidecars.values()]


def finish(run: Run, failed: list[str]) -> None:
    """Remove the staging folder's contents when nothing in it needs inspecting, but for its
    ``run.json``: the run's start, from which the report measures the run's span
    (``claims.budgets.run_span_seconds``)."""
    if not failed:
        for entry in run.staging.iterdir():
            if entry.name == "run.json":
                continue
            if entry.is_dir():
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)
