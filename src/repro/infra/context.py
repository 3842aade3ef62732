"""One run's settings, passed explicitly from the notebook to the library and the ledger.

``repro.run.notebook.setup_notebook`` builds it from the notebook's parameters (and what the
runner's worker gives its kernel, the run ID and thread share, read once there); the notebook
reads its run settings from the context only (``ctx.data_dir``, ``ctx.threads``), and nothing
inside the process reads them back from the environment.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Self

import torch

#: The largest base seed: every derived seed must fit a signed 64-bit integer (torch's and
#: numpy's int64) wherever a notebook uses it, and the largest derivation is
#: ``10_000 * seed + k`` (``gmd.measurements``, Table B.1; ``gmd.controls.control_seed``
#: adds about 10⁷), so 2⁴⁸ − 1 leaves room: 10⁴ · 2⁴⁸ ≈ 2.8·10¹⁸ < 2⁶³ ≈ 9.2·10¹⁸. 2⁶⁴ − 1
#: fails inside the kernel of notebooks 05 and 06 ("Overflow when unpacking long long").
MAX_SEED = 2**48 - 1

#: The three scales: ``quick`` a test of the code (never a result); ``standard``
#: what ``make reproduce`` runs and ``results/`` holds (a cold run within 60 minutes on 2 CPU
#: cores, docs/COMPUTE.md); ``paper`` the papers' settings, for a GPU or a cluster. Each paper
#: package reads its settings for a scale from its one table.
SCALES = ("quick", "standard", "paper")


#: what a notebook of a quick run says at its top (its paper package's ``scale_note``)
QUICK_NOTE = ("**Quick scale: a test of the code.** Tiny data, a few training steps, one seed; "
              "no verdict of this run is a result.")


def scale_problem(scale: object) -> str | None:
    """Why ``scale`` is not one of :data:`SCALES`; None when it is."""
    if scale not in SCALES:
        return f"must be one of {', '.join(SCALES)}, got {scale!r}"
    return None


def check_scale(scale: object) -> str:
    """``scale`` itself, or a ValueError naming the scales."""
    problem = scale_problem(scale)
    if problem:
        raise ValueError(f"scale {problem}")
    return str(scale)


def seed_problem(seed: object) -> str | None:
    """Why ``seed`` cannot be a base seed (a bool, not an int, or outside 0…:data:`MAX_SEED`);
    None when it can."""
    if not isinstance(seed, int) or isinstance(seed, bool):
        return f"must be an integer, got {type(seed).__name__}"
    if seed < 0:
        return (f"is negative: a base seed is a whole number from 0 to 2^48 - 1 = {MAX_SEED} "
                "(e.g. --seed 0)")
    if seed > MAX_SEED:
        return (f"must be between 0 and 2^48 - 1 = {MAX_SEED} (every seed a notebook derives "
                "from it, up to 10000 x seed, must fit a 64-bit integer); pick a smaller one")
    return None


@dataclass(frozen=True)
class RunContext:
    """Where a run writes and how it runs.

    Attributes:
        scale: "quick" (a test of the code; never a result), "standard" or "paper".
        seed: base seed; experiments take ``seeds(...)`` from it.
        device: where models train and sample.
        threads: torch threads of this process (``setup_notebook`` sets them).
        build_dir: the run's output folder (claims/, figures/ below it).
        cache_dir: trained models and generated data, keyed by their configuration.
        data_dir: a HumanML3D-layout folder, or None for the generated stand-in set.
        run_id: names the run in every sidecar (commit, base seed, scale, start); "" by hand.
    """

    scale: str
    seed: int
    device: torch.device
    threads: int
    build_dir: Path
    cache_dir: Path
    data_dir: Path | None = None
    run_id: str = ""

    def __post_init__(self) -> None:
        check_scale(self.scale)

    @property
    def quick(self) -> bool:
        """A quick run: a test of the code, whose verdicts are never shown as results."""
        return self.scale == "quick"

    @property
    def figures_dir(self) -> Path:
        return self.build_dir / "figures"

    @property
    def claims_dir(self) -> Path:
        return self.build_dir / "claims"

    def figure_path(self, name: str) -> Path:
        """Where a figure named ``name`` (e.g. ``gmd_a2_coefficients.png``) is saved."""
        return self.figures_dir / name

    def seeds(self, full: int, quick: int = 1) -> list[int]:
        """``full`` consecutive seeds from the base seed (``quick`` of them in quick mode)."""
        return [self.seed + i for i in range(quick if self.quick else full)]


class RunSettings:
    """A notebook's settings for its run, the one way every notebook gets them:
    ``Settings.for_run(ctx, **overrides)`` — the settings table of ``ctx``'s scale
    (``for_scale``, defined by each notebook's settings class) with the notebook's
    overrides. A class that checks more of the run (a data folder) overrides ``for_run``."""

    @classmethod
    def for_scale(cls, scale: str, **overrides: Any) -> Self:
        raise NotImplementedError(f"{cls.__name__} defines no settings table (for_scale)")

    @classmethod
    def for_run(cls, ctx: RunContext, **overrides: Any) -> Self:
        return cls.for_scale(ctx.scale, **overrides)
