"""The compute plan per notebook: the standard scale's measured minutes (docs/COMPUTE.md §3c,
§16a), for honest progress, and the paper scale's counted CPU-hours (§2), for the workflow's
job requests (``run.workflow``).

``make reproduce`` estimates what is left from these shares until a run of the same scale has
measured its own times (``runner.known_seconds``); the step caps and the times of other
scales' runs never enter the estimate. A share is the wall minutes a notebook takes with one
torch thread, two notebooks at a time on two cores (measured on the fast CPU and scaled to
the slow one, not padded). The set-up and the
report (about 5 minutes) are outside the notebooks.
"""

from __future__ import annotations

__all__ = ["PAPER_CPU_HOURS", "PAPER_SHARED_CPU_HOURS", "STANDARD_PLAN_MINUTES",
           "STANDARD_READS", "planned_seconds"]

#: docs/COMPUTE.md §16a (the fourth standard design): the wall minutes per notebook of its cold
#: standard run on the Intel with AMX, doubled — the plan is sized for the slowest CPU, the
#: Intel without AMX, about twice as slow on these models (§0); 05 from §19a's run (EMG-4's
#: Table 9 on 320 items, registry v7: 430 s). Then the GMD arms and controls added since,
#: counted from ``results/models.json``'s training seconds on the slow CPU under two notebooks
#: at a time and the standard UNets' forward passes: 01 + 20.9 (GMD-A4's ε motion arm, 3 × 4500
#: steps ≈ 3 × 375 s, and its 3 × 128 samples ≈ 60 s; the A/A copies' sampling, A3 ≈ 26 s and A4
#: ≈ 87 s, less A4's former FID-calibrated controls ≈ 35 s); 02 + 1.0 (B2's A/A: rel imputation
#: and guidance of 3 copies, ≈ 58 s); 03 + 23.7 (GMD-C4 at k = c ∈ {2, 10} on 3 seeds: 10 more
#: models ≈ 10 × 125 s, 12 more imputed sample sets ≈ 85 s, their gates and Table B.1's Emphasis
#: row ≈ 45 s, the A/A copies' 6 sample sets ≈ 43 s); 06 + 1.8 (F1's A/A: 12 of the 22 sweep
#: groups per seed the experiment samples, ≈ 3 × 36 s). EnergyMoGen's A/A controls and EMG-7's N
#: ∈ {1, 3, 5, 7} added, counted from the standard run's stage times on the slow CPU (results/):
#: 04 + 150 s (EMG-2/3's three baseline samplers of 9 on a copy, 14 s of 41 s; EMG-6's maps
#: again on a copy, 139 s); 05 + 110 s (EMG-4's γ = 0 on two copies, 2 × 3 × 15 s on 320 items;
#: EMG-5's latent row and timeline on a copy, 3 × (3 + 3) s); 07 + 940 s (N = 1 and 3 × 3 seeds:
#: VAE ≈ 55 and 67 s, denoiser ≈ 74 and 86 s, linear in N from N = 5, 7's 79/91 s and 98/110 s,
#: 846 s; their measurements and gates, 6 × 14 s; the A/A's three N = 5 generations on a copy,
#: 12 s); 08 + 10 s (the copy's control generations, 3 × 3 s); the planted controls they replace
#: are not subtracted
STANDARD_PLAN_MINUTES: dict[str, float] = {
    "00_stand_in_data": 0.5,
    "01_x0_vs_eps": 52.1,
    "02_root_representation": 7.9,
    "03_emphasis_projection": 30.5,
    "04_energy_contour_maps": 18.1,
    "05_sef_ablation": 16.1,
    "06_guidance_schedule": 5.7,
    "07_latent_count": 29.1,
    "08_composed_augmentation": 6.7,
}


#: docs/COMPUTE.md §2 (census of the paper scale, fp32 column, counted at the step caps from
#: the code and §1's per-step costs on the 2-core Xeon without AMX): each notebook's own
#: CPU-hours with one thread — the models it trains first (a bank model is charged to the
#: first notebook that reads it) and its sampling. 01: motion 41.8 + trajectory 26.0 +
#: evaluator 0.01 + sampling 2.0; 02: trajectory 6.5 + motion 34.8 + sampling 1.9; 03: motion
#: 125.3 + sampling 0.4; 06: motion 10.4 + sampling 3.5; EnergyMoGen: 04 the pipelines of
#: train seeds 0–4 (3.7), 07 N ∈ {1, 3, 7} (6.6), 08 the fine-tunes (0.7), and the ≈ 1 CPU-h
#: of 04–08's sampling split evenly, 05's grown as its standard time grew with EMG-4's
#: 320-item Table 9 (270 → 430 s, §19a: 0.25 → 0.4) [e]. Notebook 00 is not in the census:
#: it generates the same stand-in set as at the standard scale (``standin.figures.Settings``),
#: so its standard minutes stand. Total ≈ 265 CPU-h, §2's fp32 figure.
PAPER_CPU_HOURS: dict[str, float] = {
    "00_stand_in_data": STANDARD_PLAN_MINUTES["00_stand_in_data"] / 60.0,
    "01_x0_vs_eps": 41.8 + 26.0 + 0.01 + 2.0,
    "02_root_representation": 6.5 + 34.8 + 1.9,
    "03_emphasis_projection": 125.3 + 0.4,
    "04_energy_contour_maps": 3.7 + 0.25,
    "05_sef_ablation": 0.4,
    "06_guidance_schedule": 10.4 + 3.5,
    "07_latent_count": 6.6 + 0.25,
    "08_composed_augmentation": 0.7 + 0.25,
}

#: docs/COMPUTE.md §2 "Shared today": the models a notebook reads that another notebook's
#: share pays for (reader → lender → CPU-hours at the paper scale). Run as separate jobs on a
#: shared cache, the reader either trains them itself or waits on the lender's lock
#: (``infra.cache.artifact_lock``) while the lender trains them, so its request must cover
#: them. The T = 1000 ε trajectory model on absolute windows (3 seeds: 6.5 of 01's 26.0,
#: §2's B2 row) is read by 02 (B2) and 06 (F1); the EnergyMoGen pipelines of train seeds
#: 0–2 (3 of 04's 5 at 3.7) by 05, 07 (N = 5) and 08 (pretrained).
PAPER_SHARED_CPU_HOURS: dict[str, dict[str, float]] = {
    "02_root_representation": {"01_x0_vs_eps": 6.5},
    "06_guidance_schedule": {"01_x0_vs_eps": 6.5},
    "05_sef_ablation": {"04_energy_contour_maps": 3.7 * 3 / 5},
    "07_latent_count": {"04_energy_contour_maps": 3.7 * 3 / 5},
    "08_composed_augmentation": {"04_energy_contour_maps": 3.7 * 3 / 5},
}

#: docs/COMPUTE.md §3c, §5 and §16 (as built): the notebooks whose bank models a notebook
#: reads at the standard scale — 02 and 06 read 01's absolute-root trajectory models (06's
#: second stage, which read 02's absolute-root x0 text model, is not run at this scale), 05,
#: 07 (N = 5) and 08 the pipelines 04 trains. §3c does not split a share by model, so a
#: reader's request adds its lenders' whole shares (an upper bound).
STANDARD_READS: dict[str, tuple[str, ...]] = {
    "02_root_representation": ("01_x0_vs_eps",),
    "06_guidance_schedule": ("01_x0_vs_eps",),
    "05_sef_ablation": ("04_energy_contour_maps",),
    "07_latent_count": ("04_energy_contour_maps",),
    "08_composed_augmentation": ("04_energy_contour_maps",),
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
