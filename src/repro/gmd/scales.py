"""What a GMD notebook's reader must know about its run's scale, rendered from the settings.

The notebooks' design text describes GMD's own settings (T = 1000, its widths, the registered
seed counts): the paper scale. A standard run (``make reproduce``) uses the tiny design of
docs/COMPUTE.md; :func:`scale_note` says which, from the constants the code runs with.
"""

from __future__ import annotations

from repro.gmd.emphasis_study import STANDARD_C4_TRAIN_STEPS
from repro.gmd.models import STANDARD_MOTION_TRAINING, STANDARD_TRAJECTORY_TRAINING
from repro.gmd.paper_settings import (
    GUIDANCE_DIFFUSION_STEPS,
    MOTION_ARCHITECTURE,
    STANDARD_DIFFUSION_STEPS,
    STANDARD_MOTION_ARCHITECTURE,
    STANDARD_TRAJECTORY_ARCHITECTURE,
    TRAJECTORY_ARCHITECTURE,
    Architecture,
)
from repro.gmd.run_seeds import STANDARD_SEEDS
from repro.infra.context import QUICK_NOTE, check_scale

__all__ = ["scale_note"]


def _widths(architecture: Architecture) -> str:
    mults = ", ".join(f"{m:g}" for m in architecture.channel_mults)
    return f"{architecture.base_channels} × ({mults})"


def scale_note(scale: str) -> str:
    """A markdown line for the top of a GMD notebook: the run's scale and, at standard, how
    its models and diffusion differ from the paper settings the design text names."""
    if check_scale(scale) == "quick":
        return QUICK_NOTE
    if scale == "paper":
        return ("**Paper scale**: GMD's settings as the design text states them "
                f"(T = {GUIDANCE_DIFFUSION_STEPS} for guidance, motion UNet "
                f"{_widths(MOTION_ARCHITECTURE)}, trajectory UNet "
                f"{_widths(TRAJECTORY_ARCHITECTURE)}, the registered seed counts).")
    seeds = ", ".join(f"{claim} {n}" for claim, n in STANDARD_SEEDS.items())
    return (f"**Standard scale** (`make reproduce`, docs/COMPUTE.md): every GMD model has "
            f"T = {STANDARD_DIFFUSION_STEPS} (guidance stop steps at the same fraction of T "
            f"as GMD's 20 of {GUIDANCE_DIFFUSION_STEPS}); motion UNet "
            f"{_widths(STANDARD_MOTION_ARCHITECTURE)} with a full-rank input skip, "
            f"{STANDARD_MOTION_TRAINING.step_cap} steps (GMD-C4's arms "
            f"{STANDARD_C4_TRAIN_STEPS}); trajectory UNet "
            f"{_widths(STANDARD_TRAJECTORY_ARCHITECTURE)}, "
            f"{STANDARD_TRAJECTORY_TRAINING.step_cap} steps; seeds per claim: {seeds}. "
            "Where the text below names GMD's T = 1000, its widths or more "
            "seeds, those are the paper scale's; the values this run used are printed by its "
            "cells and recorded in every claim's sidecar.")
