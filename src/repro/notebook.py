"""What every notebook calls first: build folder, threads, seeds, plotting style.

Notebooks run under papermill (``python -m repro reproduce``) or by hand in Jupyter; both go
through :func:`setup_notebook` so outputs land in the same places.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import torch

from . import paths


@dataclass(frozen=True)
class NotebookContext:
    quick: bool
    seed: int
    device: torch.device
    build_dir: Path
    figures_dir: Path

    def figure_path(self, name: str) -> Path:
        """Where a figure named ``name`` (e.g. ``gmd_a2_coefficients.png``) is saved."""
        return self.figures_dir / name


def setup_notebook(*, quick: bool, seed: int, device: str,
                   build_dir: str | None) -> NotebookContext:
    """Validate the standard parameters and prepare the process.

    Args:
        quick: tiny data and few steps (a test of the code; never a result).
        seed: base seed; experiments derive their per-seed lists from it.
        device: "cpu", "cuda" or "cuda:N".
        build_dir: where figures and claim sidecars go; None = ``build/`` (``build/quick`` when
            quick).
    """
    if not isinstance(quick, bool):
        raise ValueError(f"parameter quick must be true or false, got {quick!r}")
    if not isinstance(seed, int) or seed < 0:
        raise ValueError(f"parameter seed must be a non-negative integer, got {seed!r}")
    try:
        torch_device = torch.device(device)
    except (RuntimeError, TypeError) as error:
        raise ValueError(f"parameter device {device!r} is not a torch device: {error}") from None
    if torch_device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"parameter device={device!r} but CUDA is not available here")
    if build_dir is None:
        build_dir = str(paths.run_build_dir(quick))
    os.environ["REPRO_BUILD_DIR"] = str(Path(build_dir).resolve())
    threads = int(os.environ.get("REPRO_TORCH_THREADS", "0")) or (os.cpu_count() or 1)
    torch.set_num_threads(threads)
    torch.manual_seed(seed)
    import matplotlib

    matplotlib.rcParams.update({"figure.dpi": 100, "savefig.dpi": 110, "figure.figsize": (7, 4),
                                "axes.grid": True, "grid.alpha": 0.3})
    figures = paths.figures_dir()
    figures.mkdir(parents=True, exist_ok=True)
    return NotebookContext(quick, seed, torch_device, paths.build_dir(), figures)


def seeds_for(ctx: NotebookContext, full: int, quick: int = 1) -> list[int]:
    """The per-experiment seed list: ``full`` seeds from the base seed (``quick`` in quick mode)."""
    return [ctx.seed + i for i in range(quick if ctx.quick else full)]
