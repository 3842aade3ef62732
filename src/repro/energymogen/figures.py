"""The figures of the EnergyMoGen notebooks 04, 05, 07 and 08, drawn from measured values.

Each function takes what a study returned and gives a matplotlib figure; the notebook saves it
(``motion.plotting.save_figure``) and shows it. No function here measures anything.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from repro.core.diffusion import GaussianDiffusion
from repro.energymogen.augmentation import ROWS, ComposedSet
from repro.energymogen.config import HELD_OUT_PAIRS, NEGATION_CASES
from repro.energymogen.data import NotMeasurable
from repro.energymogen.harness import TextToMotionTest
from repro.energymogen.latent_count import PAPER_TABLE8
from repro.energymogen.pipeline import EnergyMoGenPipeline, Sampler
from repro.energymogen.studies import (
    PAPER_TABLE7,
    PAPER_TABLE9,
    TABLE7_LAMBDAS,
    TABLE9_GAMMAS,
    gamma_key,
    lambda_key,
)
from repro.motion.plotting import animate_side_by_side, filmstrip, save_figure, shorten

__all__ = [
    "agd_step_size_figure", "augmentation_figure", "composed_examples_figure",
    "composition_examples_figure", "composition_oracle_figure", "energy_maps_figure",
    "jacobian_asymmetry_figure", "latent_count_figure", "map_similarity_figure",
    "reconstructions_figure", "save_augmentation_figure", "save_composed_examples_figure",
    "save_composition_figures", "save_energy_map_figures", "save_sef_figures",
    "save_three_concepts_figure", "sef_tradeoff_figure", "three_concepts_figure",
    "transition_measures_figure",
]

Results = Mapping[str, Mapping[str, Sequence[float]]]


# ----------------------------------------------------------------------------------------------
# Notebook 04: EMG-1, EMG-2/3, EMG-6
# ----------------------------------------------------------------------------------------------


def jacobian_asymmetry_figure(asymmetry: Mapping[str, np.ndarray], timesteps: Sequence[int],
                              diffusion: GaussianDiffusion) -> Figure:
    """EMG-1: ‖J − Jᵀ‖/‖J‖ by timestep (``asymmetry``: name → (timesteps, samples)) beside the
    exact DDPM coefficient on ε_θ that Eq. 5–6 writes as 1."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    positions = np.arange(len(timesteps))
    for k, (name, values) in enumerate(asymmetry.items()):
        axes[0].boxplot(values.T, positions=positions + 0.25 * (k - 1), widths=0.22,
                        patch_artist=True, boxprops={"facecolor": f"C{k}", "alpha": 0.6},
                        medianprops={"color": "black"}, showfliers=False)
        axes[0].plot([], [], color=f"C{k}", lw=6, alpha=0.6, label=name)
    axes[0].axhline(0.1, color="grey", ls="--", lw=1, label="rule: ≤ 0.1")
    axes[0].axhline(np.sqrt(2), color="grey", ls=":", lw=1, label="random matrix ≈ √2")
    axes[0].set_yscale("log")
    axes[0].set_xticks(positions, [str(t) for t in timesteps])
    axes[0].set_xlabel("timestep t")
    axes[0].set_ylabel("‖J − Jᵀ‖ / ‖J‖")
    axes[0].set_title("Is ε_θ a gradient field? (J = ∂ε_θ/∂z_t)", fontsize=10)
    axes[0].legend(fontsize=7)
    steps = np.arange(diffusion.num_timesteps)
    beta, alpha = diffusion.betas, diffusion.alphas
    coefficient = beta / np.sqrt(alpha) / np.sqrt(1 - diffusion.alphas_cumprod)
    axes[1].semilogy(steps, coefficient, label="exact DDPM coefficient on ε_θ")
    axes[1].axhline(1.0, color="C3", ls="--", label="Eq. 5–6: η = 1")
    axes[1].set_xlabel("timestep t")
    axes[1].set_title("Step size of the Langevin reading", fontsize=10)
    axes[1].legend(fontsize=8)
    return fig


def _bar_panel(ax: Axes, labels: Sequence[str], series: Sequence[Sequence[float]], title: str,
               ylabel: str) -> None:
    """Bars of the per-seed means with the seeds as dots."""
    for k, values in enumerate(series):
        values = np.asarray(values)
        ax.bar(k, values.mean(), color=f"C{k}", alpha=0.7)
        ax.plot(np.full(len(values), k) + np.linspace(-0.15, 0.15, len(values)), values, "k.",
                ms=4)
    ax.set_xticks(range(len(labels)), labels, rotation=30, ha="right", fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)


def composition_oracle_figure(study: Mapping[str, Any], seeds: Sequence[int],
                              guidance_scale: float) -> Figure:
    """EMG-2/3 (``studies.composition_study``): conjunction both-present rates beside the
    baselines, and negation's negated and kept concepts."""
    lat, sem, extra = study["latent"], study["semantic"], study["extra"]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    _bar_panel(axes[0], ["best single\nconcept", "∅", "joined text", "latent\nEq. 7",
                         "semantic\nEq. 9", "ground truth"],
               [lat["best_single_concept_both_present"], extra["unconditional_both_present"],
                extra["multi_text_both_present"], lat["conjunction_both_present"],
                sem["conjunction_both_present"], extra["ground_truth_both_present"]],
               "Conjunction (held-out pairs): both concepts found", "fraction of samples")
    _bar_panel(axes[1], ["c_i alone", "latent\nEq. 8", "semantic\nEq. 9"],
               [lat["baseline_negated_present"], lat["negation_negated_present"],
                sem["negation_negated_present"]], "Negation: negated concept still found", "")
    _bar_panel(axes[2], ["c_i alone", "latent\nEq. 8", "semantic\nEq. 9"],
               [lat["baseline_kept_present"], lat["negation_kept_present"],
                sem["negation_kept_present"]], "Negation: kept concept found", "")
    fig.suptitle(f"Dots: seeds {list(seeds)} (one trained model each); s = {guidance_scale}",
                 fontsize=9)
    return fig


def composition_examples_figure(examples: Mapping[str, np.ndarray]) -> Figure:
    """One filmstrip per sampler of ``studies.composition_study``'s first item."""
    fig, axes = plt.subplots(len(examples), 1, figsize=(10, 1.9 * len(examples)))
    for ax, (name, joints) in zip(axes, examples.items(), strict=True):
        filmstrip(joints, frames=8, ax=ax, title=name)
    fig.suptitle("First item of the first seed, default model (conjunction: "
                 + " + ".join(HELD_OUT_PAIRS[0]) + "; negation: "
                 + " not ".join([" & ".join(NEGATION_CASES[0][0]), NEGATION_CASES[0][1]])
                 + ")", fontsize=9)
    return fig


_MAP_COLUMNS = ("concept 1", "concept 2", "composed", "multi-concept", "paraphrase",
                "control")


def save_composition_figures(study: Mapping[str, Any] | NotMeasurable, seeds: Sequence[int],
                             scale: float, figure_path: Callable[[str], Path]) -> list[Path]:
    """Notebook 04's EMG-2/3 figures saved under ``figure_path(name)``:
    :func:`composition_oracle_figure` and :func:`composition_examples_figure` (their paths, in
    that order); none for a ``NotMeasurable`` study (a data folder)."""
    if isinstance(study, NotMeasurable):
        return []
    return [save_figure(composition_oracle_figure(study, seeds, scale),
                        figure_path("emg2_emg3_composition_oracles.png")),
            save_figure(composition_examples_figure(study["examples"]),
                        figure_path("emg2_emg3_examples.png"))]


def save_energy_map_figures(cases: Mapping[str, Any] | NotMeasurable,
                            measured: Mapping[str, Sequence[float]] | NotMeasurable,
                            seeds: Sequence[int], figure_path: Callable[[str], Path]
                            ) -> list[Path]:
    """Notebook 04's EMG-6 figures saved under ``figure_path(name)``: the first case of each
    kind on the first seed (:func:`energy_maps_figure`) and :func:`map_similarity_figure`
    (their paths, in that order); none when not measurable (a data folder)."""
    if isinstance(cases, NotMeasurable) or isinstance(measured, NotMeasurable):
        return []
    return [save_figure(energy_maps_figure({kind: per_seed[0][0]
                                            for kind, per_seed in cases.items()}, seeds[0]),
                        figure_path("emg6_energy_contour_maps.png")),
            save_figure(map_similarity_figure(measured), figure_path("emg6_map_similarity.png"))]


def energy_maps_figure(cases: Mapping[str, Mapping[str, Any]], seed: int) -> Figure:
    """EMG-6 as Fig. 5/6: one row per kind (``energy.energy_map_case`` results of one seed),
    the smoothed conditional maps of every condition with that row's samples."""
    fig, axes = plt.subplots(2, len(_MAP_COLUMNS), figsize=(20, 6.6))
    for row, kind in enumerate(("conjunction", "negation")):
        case = cases[kind]
        extent = [-case["extent"][0], case["extent"][0], -case["extent"][1], case["extent"][1]]
        levels = np.linspace(min(case["smooth"][c].min() for c in _MAP_COLUMNS),
                             max(case["smooth"][c].max() for c in _MAP_COLUMNS), 14)
        if levels[0] == levels[-1]:
            levels = np.linspace(levels[0] - 1e-9, levels[0] + 1e-9, 3)
        for col, name in enumerate(_MAP_COLUMNS):
            ax = axes[row, col]
            ax.contourf(case["smooth"][name], levels=levels, cmap="viridis", extent=extent,
                        origin="lower")
            ax.contour(case["smooth"][name], levels=levels, colors="k", linewidths=0.3,
                       extent=extent, origin="lower")
            key = {"concept 1": "c1", "concept 2": "c2", "multi-concept": "multi",
                   "paraphrase": "ceiling", "control": "control"}.get(name)
            text = case["texts"][key] if key else (
                "Eq. 7 (unit weights)" if kind == "conjunction" else "Eq. 8 (w = 1)")
            if name in case["scores"]:
                pts = case["scores"][name]
                ax.plot(pts[:, 0], pts[:, 1], "w.", ms=3)
            ax.set_title(f"{name}\n" + "\n".join(textwrap.wrap(text, 34)), fontsize=7)
            ax.set_xticks([])
            ax.set_yticks([])
        axes[row, 0].set_ylabel(f"{kind}: {case['case']}", fontsize=8)
    fig.suptitle("Conditional part of the denoising-loss energy, E_k − E_∅, on the PC1–PC2 "
                 "slice of generated latents (dark = low energy; white dots: that row's "
                 f"samples). Seed {seed} (default model).", fontsize=9)
    return fig


def map_similarity_figure(measured: Mapping[str, Sequence[float]]) -> Figure:
    """EMG-6's numbers (``energy.map_similarities``): per kind, the floor (one concept alone ~
    multi), composed ~ multi and the ceiling (a paraphrase ~ multi), one line per seed (each
    seed the mean over its cases); composed ~ unrelated control as grey crosses."""
    fig, ax = plt.subplots(figsize=(8, 3.8))
    ticks, labels = [], []
    for k, kind in enumerate(("conjunction", "negation")):
        x = 4 * k + np.arange(3)
        values = np.array([measured[f"{kind}_similarity_{what}"]
                           for what in ("floor", "to_multi", "ceiling")])      # (3, seeds)
        for seed_values in values.T:
            ax.plot(x, seed_values, "-", color="grey", lw=0.8)
        for xi, row, marker, colour in zip(x, values, ("v", "o", "^"), ("C3", "C0", "C2"),
                                           strict=True):
            ax.plot(np.full(row.size, xi), row, marker, color=colour)
        control = measured[f"{kind}_similarity_to_control"]
        ax.plot(np.full(len(control), x[1] + 0.25), control, "x", color="0.5")
        ticks += list(x)
        labels += [f"{kind[:4]}.: floor\n(one concept)", f"{kind[:4]}.: composed",
                   f"{kind[:4]}.: ceiling\n(paraphrase)"]
    ax.set_xticks(ticks, labels, fontsize=8)
    ax.set_ylabel("Pearson r with the multi-concept map")
    ax.set_title("EMG-6: one line per seed (mean over its cases); grey ×: composed ~ unrelated "
                 "control", fontsize=9)
    return fig


# ----------------------------------------------------------------------------------------------
# Notebook 05: EMG-4, EMG-5 and the sets of three
# ----------------------------------------------------------------------------------------------


def save_three_concepts_figure(rows: Sequence[tuple[str, str]], pairs: Results,
                               threes: Results | NotMeasurable,
                               control: Results | NotMeasurable,
                               figure_path: Callable[[str], Path]) -> list[Path]:
    """Notebook 05's :func:`three_concepts_figure` saved under ``figure_path(name)`` (its path
    in a list); none when the sets of three are not measurable (a data folder)."""
    if isinstance(threes, NotMeasurable) or isinstance(control, NotMeasurable):
        return []
    return [save_figure(three_concepts_figure(rows, pairs, threes, control),
                        figure_path("emg5_three_concepts.png"))]


def save_sef_figures(results: Results, timelines: Results | NotMeasurable,
                     rows: Sequence[tuple[str, str]], figure_path: Callable[[str], Path]
                     ) -> list[Path]:
    """Notebook 05's EMG-5 figures saved under ``figure_path(name)``:
    :func:`sef_tradeoff_figure` and :func:`transition_measures_figure` of ``rows`` (their
    paths, in that order); none when not measurable (a data folder)."""
    if isinstance(timelines, NotMeasurable):
        return []
    return [save_figure(sef_tradeoff_figure(results, timelines),
                        figure_path("emg5_sef_tradeoff.png")),
            save_figure(transition_measures_figure(timelines, rows),
                        figure_path("emg5_transitions.png"))]


def three_concepts_figure(rows: Sequence[tuple[str, str]], pairs: Results, threes: Results,
                          control: Results) -> Figure:
    """Table 3's ``rows`` (label, key) on the held-out pairs, the sets of three and their
    two-concept control: all concepts found and R@3, dots per seed."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.6))
    labels = [label for label, _ in rows]
    groups = (("held-out pairs", pairs), ("sets of three", threes),
              ("control: same motions as lower + wave_both", control))
    for ax, metric, title in zip(axes, ("both_present", "r_precision_top3"),
                                 ("all concepts found by the oracles", "R@3 (%)"), strict=True):
        for offset, (name, res) in zip((-0.27, 0.0, 0.27), groups, strict=True):
            values = [np.asarray(res[key][metric], dtype=float) for _, key in rows]
            ax.bar(np.arange(len(rows)) + offset, [v.mean() for v in values], width=0.27,
                   label=name, alpha=0.7)
            for k, v in enumerate(values):
                ax.plot(np.full(len(v), k + offset), v, "k.", ms=4)
        ax.set_xticks(range(len(rows)), labels, rotation=15, fontsize=8)
        ax.set_title(title + " (dots: seeds)", fontsize=9)
    handles, names = axes[0].get_legend_handles_labels()
    fig.legend(handles, names, loc="lower center", ncol=3, fontsize=8)
    fig.subplots_adjust(bottom=0.27)
    fig.suptitle("Table 3's rows on the held-out pairs, the sets of three and their two-concept "
                 "control (same models, seeds and rows)", fontsize=9)
    return fig


def _mean_sem(results: Results, key: str, metric: str) -> tuple[float, float]:
    """Mean and standard error over seeds (0 for one seed)."""
    values = np.asarray(results[key][metric], dtype=float)
    half = values.std(ddof=1) / np.sqrt(len(values)) if len(values) > 1 else 0.0
    return float(values.mean()), float(half)


def _name_points(ax: plt.Axes, named: Sequence[tuple[str, float, float]]) -> None:
    """Bold labels beside points, on the side facing the middle of the axes (a point in
    the right half is named to its left), so that no label runs past the axes' edge."""
    low, high = ax.get_xlim()
    for text, x, y in named:
        left = x > (low + high) / 2
        ax.annotate(text, (x, y), fontsize=8, xytext=(-4 if left else 4, 3),
                    textcoords="offset points", fontweight="bold",
                    ha="right" if left else "left")


def sef_tradeoff_figure(results: Results, timelines: Results) -> Figure:
    """EMG-5: R@3 (``results``: the held-out pairs) against the transition distance at the
    MTT-style timelines' boundaries (``timelines``: ``studies.timeline_rows``, its ``real``
    row a dashed line) over Table 7's λ rows, ours beside the paper's."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    keys = [lambda_key(lam) for lam in TABLE7_LAMBDAS]
    marks = {"1.0,0.0,0.0": "latent only", "0.0,1.0,0.0": "semantic only",
             "0.0,0.0,1.0": "single text", "0.1,0.7,0.2": "SEF"}
    cmap = plt.get_cmap("viridis")
    for ax, source in zip(axes, ("ours", "paper"), strict=True):
        named = []
        for key, lam in zip(keys, TABLE7_LAMBDAS, strict=True):
            colour = cmap(lam[1])
            if source == "ours":
                (x, dx) = _mean_sem(timelines, key, "transition_distance_at_transitions")
                (y, dy) = _mean_sem(results, key, "r_precision_top3")
                ax.errorbar(x, y, xerr=dx, yerr=dy, fmt="o", color=colour, ms=7, capsize=2)
            else:
                x, y = (PAPER_TABLE7[key]["transition_distance"],
                        PAPER_TABLE7[key]["r_precision_top3"])
                ax.plot(x, y, "o", color=colour, ms=7)
            if key in marks:
                named.append((marks[key], x, y))
        _name_points(ax, named)
        if source == "ours" and "real" in timelines:
            ax.axvline(float(np.mean(timelines["real"]["transition_distance_at_transitions"])),
                       color="k", ls="--", lw=0.8, label="real \"then\" clips")
            ax.legend(fontsize=7, loc="lower right")
        ax.set_xlabel("transition distance at the timelines' boundaries, cm (ours)"
                      if source == "ours" else "transition distance (paper: STMC, ×100)")
        ax.set_ylabel("R@3 (%)")
        ax.set_title("ours (mean ± s.e. over seeds)" if source == "ours" else "paper (Table 7)",
                     fontsize=10)
    fig.suptitle("Text alignment vs transition distance across the 12 λ rows of Table 7 (colour "
                 "= λ_s; named: the Table 3 rows; up-left is better)", fontsize=9)
    fig.colorbar(plt.cm.ScalarMappable(cmap=cmap), ax=axes, label="λ_s")
    return fig


def transition_measures_figure(timelines: Results, rows: Sequence[tuple[str, str]]) -> Figure:
    """EMG-5's two transition measurements (``studies.timeline_rows``) for ``rows`` (label,
    key): bars the mean over seeds, dots the seeds, the dashed line the real "then" clips."""
    panels = (("transition_distance_at_transitions", "distance at the boundaries (cm)"),
              ("transition_speed_ratio", "ratio to the clip's mean speed (1: as elsewhere)"))
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.6))
    for ax, (metric, title) in zip(axes, panels, strict=True):
        values = [np.asarray(timelines[key][metric], dtype=float) for _, key in rows]
        ax.bar(range(len(rows)), [v.mean() for v in values], color="C0", alpha=0.7)
        for k, v in enumerate(values):
            ax.plot(np.full(len(v), k), v, "k.", ms=4)
        ax.axhline(float(np.mean(timelines["real"][metric])), color="k", ls="--", lw=0.8,
                   label='real "then" clips')
        ax.set_xticks(range(len(rows)), [label for label, _ in rows], rotation=15, fontsize=8)
        ax.set_title(title + " (dots: seeds)", fontsize=9)
    axes[0].legend(fontsize=7)
    fig.suptitle("EMG-5 on the MTT-style timelines: transitions where they happen", fontsize=10)
    fig.tight_layout()
    return fig


def agd_step_size_figure(results: Results) -> Figure:
    """EMG-4: R@3 by AGD step size, ours (mean ± s.e., dots per seed) beside Table 9's."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.6))
    labels = [f"[{gamma_key(g)}]" for g in TABLE9_GAMMAS]
    keys = [gamma_key(g) for g in TABLE9_GAMMAS]
    ours = [_mean_sem(results, k, "r_precision_top3") for k in keys]
    axes[0].bar(range(len(keys)), [m for m, _ in ours], yerr=[h for _, h in ours], color="C0",
                alpha=0.7, capsize=3)
    for k, key in enumerate(keys):
        values = results[key]["r_precision_top3"]
        axes[0].plot(np.full(len(values), k), values, "k.", ms=4)
    axes[0].set_title("ours: R@3 by AGD step size (dots: seeds)", fontsize=9)
    axes[1].bar(range(len(keys)), [PAPER_TABLE9[k]["r_precision_top3"] for k in keys],
                color="C1", alpha=0.7)
    axes[1].set_title("paper (Table 9): R@3 by AGD step size", fontsize=9)
    for ax in axes:
        ax.set_xticks(range(len(keys)), labels, rotation=20, fontsize=8)
        ax.set_xlabel("[γ_attn, γ_reg]")
        ax.set_ylabel("R@3 (%)")
    return fig


# ----------------------------------------------------------------------------------------------
# Notebook 07: EMG-7
# ----------------------------------------------------------------------------------------------


def latent_count_figure(results: Mapping[str, Any], counts: Sequence[int]) -> Figure:
    """EMG-7 (``latent_count.latent_count_study``): MPJPE, reconstruction and generation FID
    and generation R@3 by N, ours (dots: seeds) and the paper's Table 8 (dashed, right axis)."""

    def dots(ax: Axes, part: str, metric: str) -> None:
        means = [np.mean(results[part][str(n)][metric]) for n in counts]
        ax.plot(counts, means, "-o", color="C0", label="ours")
        for n in counts:
            values = results[part][str(n)][metric]
            ax.plot(np.full(len(values), n), values, ".", color="k", ms=4, alpha=0.6)

    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    dots(axes[0, 0], "reconstruction", "mpjpe")
    axes[0, 0].set_title("reconstruction error (MPJPE, m) — the rule's measurement", fontsize=9)
    for ax, part, metric, title in ((axes[0, 1], "reconstruction", "fid", "reconstruction FID"),
                                    (axes[1, 0], "generation", "fid", "generation FID"),
                                    (axes[1, 1], "generation", "r_precision_top3",
                                     "generation R-precision top-3")):
        dots(ax, part, metric)
        twin = ax.twinx()
        twin.plot(counts, [PAPER_TABLE8[part][str(n)][metric] for n in counts], "--s",
                  color="C1", label="paper (right axis)")
        twin.set_ylabel(f"paper {metric}", color="C1")
        ax.set_title(f"{title}: ours (dots: seeds) and paper (dashed)", fontsize=9)
        handles = ax.get_legend_handles_labels()[0] + twin.get_legend_handles_labels()[0]
        ax.legend(handles, [h.get_label() for h in handles], fontsize=7, loc="best")
    for ax in axes.ravel():
        ax.set_xlabel("N latent vectors")
        ax.set_xticks(counts)
    fig.tight_layout()
    return fig


def reconstructions_figure(clip_joints: np.ndarray, caption: str,
                           reconstructions: Sequence[tuple[int, np.ndarray, float]]) -> Figure:
    """One test clip (joints (T, 22, 3)) and its reconstruction by each N: ``reconstructions``
    holds (N, joints, MPJPE in m)."""
    fig, axes = plt.subplots(1 + len(reconstructions), 1,
                             figsize=(10, 2.3 * (1 + len(reconstructions))))
    filmstrip(clip_joints, ax=axes[0], title=f"test clip: {caption}")
    for ax, (n, joints, error) in zip(axes[1:], reconstructions, strict=True):
        filmstrip(joints, ax=ax, title=f"N = {n} reconstruction (MPJPE {error:.3f} m)")
    fig.tight_layout()
    return fig


# ----------------------------------------------------------------------------------------------
# Notebook 08: EMG-8
# ----------------------------------------------------------------------------------------------


def save_composed_examples_figure(results: Mapping[str, Any] | NotMeasurable,
                                  figure_path: Callable[[str], Path]) -> list[Path]:
    """Notebook 08's :func:`composed_examples_figure` of the study's example set (the first
    seed's): its first composition on a held-out pair and its first on a trained pair, saved
    under ``figure_path(name)`` (its path in a list); none when not measurable."""
    if isinstance(results, NotMeasurable):
        return []
    example, held = results["example"], {frozenset(p) for p in HELD_OUT_PAIRS}
    picks = [next(i for i, c in enumerate(example.concepts) if frozenset(c) in held),
             next(i for i, c in enumerate(example.concepts) if frozenset(c) not in held)]
    return [save_figure(composed_examples_figure(example, picks),
                        figure_path("emg8_composed_examples.png"))]


def save_augmentation_figure(results: Mapping[str, Any] | NotMeasurable, seeds: Sequence[int],
                             figure_path: Callable[[str], Path]) -> list[Path]:
    """Notebook 08's :func:`augmentation_figure` saved under ``figure_path(name)`` (its path
    in a list); none when not measurable (a data folder)."""
    if isinstance(results, NotMeasurable):
        return []
    return [save_figure(augmentation_figure(results, seeds),
                        figure_path("emg8_composed_augmentation.png"))]


def composed_examples_figure(example: ComposedSet, picks: Sequence[int]) -> Figure:
    """Composed motions ``picks`` of the set, titled with their text, kind of pair and what
    the oracles find."""
    presence = example.presence()
    held = {frozenset(p) for p in HELD_OUT_PAIRS}
    fig, axes = plt.subplots(len(picks), 1, figsize=(10, 2.4 * len(picks)), squeeze=False)
    for ax, i in zip(axes[:, 0], picks, strict=True):
        found = ", ".join(f"{c} {'✓' if p else '✗'}"
                          for c, p in zip(example.concepts[i], presence[i], strict=True))
        kind = "held-out pair" if frozenset(example.concepts[i]) in held else "trained pair"
        filmstrip(example.joints[i], ax=ax, title=f"composed ({kind}): “{example.texts[i]}” — "
                  f"oracle: {found}")
    fig.tight_layout()
    return fig


def augmentation_figure(results: Mapping[str, Any], seeds: Sequence[int]) -> Figure:
    """EMG-8 (``augmentation.augmentation_study``): R@3 and FID on the in-distribution test
    and both-found on the held-out composed texts, per row, one line per seed (paired)."""
    panels = [("t2m", "r_precision_top3", "in-distribution test: R@3 (↑)"),
              ("t2m", "fid", "in-distribution test: FID (↓)"),
              ("held_out", "both_present", "held-out composed texts: both concepts found (↑)")]
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    x = np.arange(len(ROWS))
    for ax, (part, metric, title) in zip(axes, panels, strict=True):
        values = np.array([results[part][row][metric] for row in ROWS])    # (rows, seeds)
        ax.bar(x, values.mean(1), color=["0.7", "C0", "C2"], alpha=0.7)
        for k in range(len(seeds)):
            ax.plot(x, values[:, k], "k.-", lw=0.8, ms=5, alpha=0.6,
                    label="one seed (paired)" if k == 0 else None)
        ax.set_xticks(x, ROWS)
        ax.set_title(title, fontsize=9)
    axes[0].legend(fontsize=7)
    fig.suptitle("EMG-8: pretrained vs fine-tuned on stand-in data alone (control, the "
                 "baseline) vs with the composed set (augmented)", fontsize=10)
    fig.tight_layout()
    return fig


def animate_samples(pipes: Mapping[str, EnergyMoGenPipeline], test: TextToMotionTest,
                    path: str | Path, *, seed: int, count: int = 2) -> Path:
    """A GIF of the first ``count`` test clips beside each pipeline's decoded sample for the
    same caption (single-text guidance, DDIM from ``pipe.noise(seed)``, as the denoiser's
    sample gates draw them: ``model_gates.denoiser_sample_values``), each in its own world
    frame (``motion.plotting.animate_side_by_side``)."""
    count = min(count, len(test))
    texts = test.texts(seed)[:count]
    first = next(iter(pipes.values()))
    clips = {f"data: {shorten(t)}": joints
             for t, joints in zip(texts, first.joints(test.features[:count]), strict=True)}
    for label, pipe in pipes.items():
        joints = pipe.joints(pipe.decode(pipe.sample(Sampler("single"), [], texts, seed,
                                                     batch=count)))
        for t, clip in zip(texts, joints, strict=True):
            clips[f"{label}: {shorten(t)}"] = clip
    return animate_side_by_side(clips, path, columns=count)

