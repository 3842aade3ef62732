"""The standard scale's compute plan per notebook (docs/COMPUTE.md §3c), for honest progress.

``make reproduce`` estimates what is left from these shares until a run of the same scale has
measured its own times (``runner.known_seconds``); the step caps and the times of other
scales' runs never enter the estimate. A share is the wall minutes a notebook takes with one
torch thread, two notebooks at a time on two cores (measured, not padded). The set-up and the
report (about 5 minutes) are outside the notebooks.
"""

from __future__ import annotations

__all__ = ["STANDARD_PLAN_MINUTES", "planned_seconds"]

#: docs/COMPUTE.md §13 (the third standard design): the second standard run's measured wall
#: minutes per notebook (§12), with notebook 03's GMD-C4 at one seed of two arms trained 1500
#: steps (2 × 1500 × 0.127 CPU-s, plus a third of its sampling) in place of 3 seeds at 900
STANDARD_PLAN_MINUTES: dict[str, float] = {
    "00_stand_in_data": 0.8,
    "01_x0_vs_eps": 21.5,
    "02_root_representation": 23.3,
    "03_emphasis_projection": 8.0,
    "04_energy_contour_maps": 17.1,
    "05_sef_ablation": 10.9,
    "06_guidance_schedule": 6.4,
    "07_latent_count": 15.4,
    "08_composed_augmentation": 8.6,
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
