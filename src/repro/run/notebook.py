"""What every notebook calls first: validate its parameters and build its run context.

Notebooks run under papermill (``python -m repro reproduce``) or by hand in Jupyter; both go
through :func:`setup_notebook`, so outputs land in the same places. The user's environment
overrides (``REPRO_BUILD_DIR``, set by the runner for its kernels; ``REPRO_TORCH_THREADS``;
``REPRO_CACHE_DIR``; ``REPRO_RUN_ID``) are read here once and carried by the context.
"""

from __future__ import annotations

import os
from pathlib import Path

import torch

from repro.infra import paths
from repro.infra.context import RunContext, scale_problem, seed_problem

__all__ = ["RunContext", "seeds_for", "setup_notebook"]


def setup_notebook(*, scale: str, seed: int, device: str, build_dir: str | None,
                   data_dir: str | None = None) -> RunContext:
    """Validate the standard parameters, prepare the process and return the run context.

    Args:
        scale: "quick" (tiny data and few steps: a test of the code, never a result),
            "standard" (``make reproduce``, ``results/``) or "paper" (the papers' settings).
        seed: base seed; experiments derive their per-seed lists from it.
        device: "cpu", "cuda" or "cuda:N".
        build_dir: where figures and claim sidecars go; None = the runner's folder, else
            the scale's folder (``paths.run_build_dir``).
        data_dir: a HumanML3D-layout folder; None = the generated stand-in set.
    """
    problem = scale_problem(scale)
    if problem:
        raise ValueError(f"parameter scale {problem}")
    problem = seed_problem(seed)
    if problem:
        raise ValueError(f"parameter seed={seed!r} {problem}")
    try:
        torch_device = torch.device(device)
    except (RuntimeError, TypeError) as error:
        raise ValueError(f"parameter device {device!r} is not a torch device: {error}") from None
    if torch_device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"parameter device={device!r} but CUDA is not available here")
    data = None
    if data_dir is not None:
        data = Path(data_dir).expanduser().resolve()
        if not data.is_dir():
            raise ValueError(f"parameter data_dir={data_dir!r} is not a folder ({data} does "
                             f"not exist; a relative folder is read from {Path.cwd()})")
    if build_dir is None:
        build_dir = os.environ.get("REPRO_BUILD_DIR") or str(paths.run_build_dir(scale))
    threads = int(os.environ.get("REPRO_TORCH_THREADS", "0")) or (os.cpu_count() or 1)
    torch.set_num_threads(threads)
    torch.manual_seed(seed)
    import matplotlib

    matplotlib.rcParams.update({"figure.dpi": 100, "savefig.dpi": 110, "figure.figsize": (7, 4),
                                "axes.grid": True, "grid.alpha": 0.3})
    ctx = RunContext(scale=scale, seed=seed, device=torch_device, threads=threads,
                     build_dir=Path(build_dir).resolve(), cache_dir=paths.cache_dir(),
                     data_dir=data, run_id=os.environ.get("REPRO_RUN_ID", ""))
    ctx.figures_dir.mkdir(parents=True, exist_ok=True)
    return ctx


def seeds_for(ctx: RunContext, full: int, quick: int = 1) -> list[int]:
    """The per-experiment seed list: ``full`` seeds from the base seed (``quick`` in quick mode)."""
    return ctx.seeds(full, quick)
