"""What every notebook calls first: validate its parameters and build its run context.

Notebooks run under papermill (``python -m repro reproduce``) or by hand in Jupyter; both go
through :func:`setup_notebook`, so outputs land in the same places, and the rest of the notebook
reads its run's settings from the returned context only (``ctx.data_dir``, ``ctx.threads``, ...).

Parameters are checked once, by ``run.params``' rules: by the runner before any kernel starts
(it also makes a relative ``data_dir`` absolute and passes its staging folder as ``build_dir``),
or here when a notebook runs by hand. What the runner's worker gives its kernel beyond the
parameters (``REPRO_RUN_ID``, the run's ID, which marks a kernel of the runner;
``REPRO_TORCH_THREADS``) and the user's ``REPRO_CACHE_DIR`` are read here once and carried by
the context.
"""

from __future__ import annotations

import os
from pathlib import Path

import torch

from repro.infra import paths
from repro.infra.context import RunContext
from repro.run.params import check_standard_parameters

__all__ = ["RunContext", "seeds_for", "setup_notebook"]


def setup_notebook(*, scale: str, seed: int, device: str, build_dir: str | None,
                   data_dir: str | None = None, max_threads: int | None = None,
                   notebook: str | None = None) -> RunContext:
    """Validate the standard parameters (by hand; the runner has), prepare the process (torch
    threads and seed, figure style) and return the run context.

    Args:
        scale: "quick" (tiny data and few steps: a test of the code, never a result),
            "standard" (``make reproduce``, ``results/``) or "paper" (the papers' settings).
        seed: base seed; experiments derive their per-seed lists from it.
        device: "cpu", "cuda" or "cuda:N".
        build_dir: where figures and claim sidecars go (the runner's staging folder under
            ``reproduce``); None = the scale's folder (``paths.run_build_dir``).
        data_dir: a HumanML3D-layout folder (relative: to the working folder); None = the
            generated stand-in set. The context holds it absolute.
        max_threads: at most this many torch threads for the notebook (``ctx.threads``: the
            runner's share of the cores, else every core, capped by it).
        notebook: the notebook's name (e.g. "04_energy_contour_maps"): run by hand, a data
            folder is checked against the windows of its family (``run.params.needs_of``).
    """
    run_id = os.environ.get("REPRO_RUN_ID", "")
    if not run_id:  # by hand: the checks the runner makes before it starts a kernel
        check_standard_parameters({"scale": scale, "seed": seed, "device": device,
                                   "build_dir": build_dir, "data_dir": data_dir}, notebook)
    data = None if data_dir is None else Path(data_dir).expanduser().resolve()
    if build_dir is None:
        build_dir = str(paths.run_build_dir(scale))
    threads = int(os.environ.get("REPRO_TORCH_THREADS", "0")) or (os.cpu_count() or 1)
    if max_threads is not None:
        if max_threads < 1:
            raise ValueError(f"max_threads must be at least 1, got {max_threads}")
        threads = min(threads, max_threads)
    torch.set_num_threads(threads)
    torch.manual_seed(seed)
    import matplotlib

    matplotlib.rcParams.update({"figure.dpi": 100, "savefig.dpi": 110, "figure.figsize": (7, 4),
                                "axes.grid": True, "grid.alpha": 0.3})
    ctx = RunContext(scale=scale, seed=seed, device=torch.device(device), threads=threads,
                     build_dir=Path(build_dir).resolve(), cache_dir=paths.cache_dir(),
                     data_dir=data, run_id=run_id)
    ctx.figures_dir.mkdir(parents=True, exist_ok=True)
    return ctx


def seeds_for(ctx: RunContext, full: int, quick: int = 1) -> list[int]:
    """The per-experiment seed list: ``full`` seeds from the base seed (``quick`` in quick mode)."""
    return ctx.seeds(full, quick)
