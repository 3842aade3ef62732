"""The standard scale's compute plan per notebook (docs/COMPUTE.md §3c), for honest progress.

``make reproduce`` estimates what is left from these shares until a run of the same scale has
measured its own times (``runner.known_seconds``); the step caps and the times of other
scales' runs never enter the estimate. A share is CPU-minutes on one torch thread, the plan's
measured cost × 1.3; a notebook runs on one core (two notebooks at a time on two cores), so
its share is also its planned wall time. The set-up, data and report (about 10 minutes of the
plan) are outside the notebooks.
"""

from __future__ import annotations

__all__ = ["STANDARD_PLAN_MINUTES", "planned_seconds"]

#: docs/COMPUTE.md §3c, "share" (CPU-minutes); notebook 00 is part of its fixed 10 minutes
STANDARD_PLAN_MINUTES: dict[str, float] = {
    "00_stand_in_data": 2.0,
    "01_x0_vs_eps": 23.9 + 6.4,   # + A4's x0 motion models (not shared with B3 at standard)
    "02_root_representation": 14.1,
    "03_emphasis_projection": 16.0,
    "04_energy_contour_maps": 13.9,
    "05_sef_ablation": 2.0,
    "06_guidance_schedule": 4.8,   # its second stage is B3's absolute x0 model (the bank)
    "07_latent_count": 10.8,
    "08_composed_augmentation": 3.2,
}


def planned_seconds(scale: str) -> dict[str, float]:
    """Each notebook's planned wall seconds at ``scale`` (the standard scale's plan; {} for
    the others, which have no plan on this machine)."""
    if scale != "standard":
        return {}
    return {name: minutes * 60.0 for name, minutes in STANDARD_PLAN_MINUTES.items()}


def plan_against_measured(measured: dict[str, float]) -> str:
    """A table of each notebook's planned and measured wall minutes at the standard scale
    (``measured``: seconds per notebook, a standard run's ``run_seconds``), and the totals."""
    lines = [f"{'notebook':28s} {'plan min':>9s} {'measured':>9s} {'ratio':>6s}"]
    for name, minutes in STANDARD_PLAN_MINUTES.items():
        seconds = measured.get(name)
        shown = "—" if seconds is None else f"{seconds / 60:.1f}"
        ratio = "" if seconds is None else f"{seconds / 60 / minutes:.2f}"
        lines.append(f"{name:28s} {minutes:9.1f} {shown:>9s} {ratio:>6s}")
    known = [n for n in STANDARD_PLAN_MINUTES if n in measured]
    lines.append(f"{'total (CPU-min, one thread each)':28s} "
                 f"{sum(STANDARD_PLAN_MINUTES.values()):9.1f} "
                 f"{sum(measured[n] for n in known) / 60:9.1f}"
                 + ("" if len(known) == len(STANDARD_PLAN_MINUTES)
                    else f"  ({len(known)} of {len(STANDARD_PLAN_MINUTES)} measured)"))
    return "\n".join(lines)
