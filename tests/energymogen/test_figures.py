"""The figures of notebooks 04, 05, 07 and 08 (each claim module's, and the shared ones of
repro.energymogen.figures) drawn from values shaped as the studies return them: every panel is
there and shows the values given; the training tables and curves of notebooks 07/08."""

from __future__ import annotations

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import pytest

from repro.core.diffusion import GaussianDiffusion
from repro.energymogen.composed_augmentation import emg8
from repro.energymogen.composed_augmentation.compml import ComposedSet
from repro.energymogen.composed_augmentation.emg8 import ROWS
from repro.energymogen.energy_contour_maps import composition, emg1, emg6
from repro.energymogen.figures import training_markdown, validation_curves_figure
from repro.energymogen.latent_count import emg7 as lc
from repro.energymogen.latent_count.emg7 import latent_count_training
from repro.energymogen.pipeline import TrainingRecord, scaled_linear_betas
from repro.energymogen.sef_ablation import emg4, emg5, threes
from repro.energymogen.sef_ablation.common import (
    TABLE7_LAMBDAS,
    TABLE9_GAMMAS,
    gamma_key,
    lambda_key,
)
from repro.energymogen.settings import HELD_OUT_PAIRS

SEEDS = [0, 1]
JOINTS = np.zeros((8, 22, 3))


@pytest.fixture(autouse=True)
def close_figures() -> None:
    yield
    plt.close("all")


def _rows(keys: list[str], metrics: tuple[str, ...]) -> dict[str, dict[str, list[float]]]:
    return {k: {m: [0.2 + 0.01 * i, 0.3] for m in metrics} for i, k in enumerate(keys)}


def test_notebook_04_figures() -> None:
    diffusion = GaussianDiffusion(scaled_linear_betas(50))
    asymmetry = {"trained, text": np.full((3, 4), 0.05), "random init, text": np.ones((3, 4))}
    fig = emg1.jacobian_asymmetry_figure(asymmetry, (10, 20, 30), diffusion)
    assert len(fig.axes) == 2 and len(fig.axes[1].lines[0].get_xdata()) == 50
    names = ("conjunction_both_present", "best_single_concept_both_present",
             "negation_negated_present", "baseline_negated_present", "negation_kept_present",
             "baseline_kept_present")
    measured = {n: [0.5, 0.7] for n in names}
    extra = {k: [0.1, 0.2] for k in ("unconditional_both_present", "multi_text_both_present",
                                     "ground_truth_both_present")}
    study = {"latent": measured, "semantic": measured, "extra": extra}
    fig = composition.composition_oracle_figure(study, SEEDS, 2.5)
    assert len(fig.axes) == 3 and len(fig.axes[0].patches) == 6
    assert fig.axes[0].patches[3].get_height() == pytest.approx(0.6)
    fig = composition.composition_examples_figure({"a": np.zeros((16, 22, 3)),
                                                       "b": np.zeros((16, 22, 3))})
    assert len(fig.axes) == 2 and HELD_OUT_PAIRS[0][0] in fig._suptitle.get_text()
    maps = {name: np.random.default_rng(0).normal(size=(8, 8)) for name in (
        "concept 1", "concept 2", "composed", "multi-concept", "paraphrase", "control")}
    case = {"extent": (1.0, 1.0), "smooth": maps, "texts": {k: "text" for k in (
        "c1", "c2", "multi", "ceiling", "control")}, "scores": {"composed": np.zeros((4, 2))},
        "case": "walk_forward/clap"}
    fig = emg6.energy_maps_figure({"conjunction": case, "negation": case}, 0)
    assert len(fig.axes) == 12
    measured = {f"{kind}_similarity_{what}": [value, value + 0.05]
                for kind in ("conjunction", "negation")
                for what, value in (("floor", 0.2), ("to_multi", 0.5), ("ceiling", 0.8),
                                    ("to_control", 0.1))}
    fig = emg6.map_similarity_figure(measured)
    assert list(fig.axes[0].lines[0].get_ydata()) == [0.2, 0.5, 0.8]     # seed 1's line


def test_notebook_05_figures() -> None:
    keys = [lambda_key(lam) for lam in TABLE7_LAMBDAS] + [gamma_key(g) for g in TABLE9_GAMMAS]
    results = _rows(keys, ("r_precision_top3", "transition_distance", "both_present"))
    timelines = _rows(keys + ["real"], ("transition_distance_at_transitions",))
    fig = emg5.sef_tradeoff_figure(results, timelines)
    assert len(fig.axes) == 3                                  # two panels and the colour bar
    fig.canvas.draw()   # every named point's label inside its panel ("single text" sits at
    renderer = fig.canvas.get_renderer()   # the paper panel's right edge)
    for ax in fig.axes[:2]:
        box = ax.get_window_extent(renderer)
        labels = [t for t in ax.texts if t.get_text()]
        assert {t.get_text() for t in labels} == {"latent only", "semantic only",
                                                  "single text", "SEF"}
        for label in labels:
            extent = label.get_window_extent(renderer)
            assert box.x0 <= extent.x0 and extent.x1 <= box.x1, label.get_text()
    plt.close(fig)
    fig = emg5.transition_measures_figure(
        _rows(keys + ["real"], ("transition_distance_at_transitions", "transition_speed_ratio")),
        [("SEF", "0.1,0.7,0.2"), ("latent only", "1.0,0.0,0.0")])
    assert len(fig.axes) == 2 and len(fig.axes[0].patches) == 2
    change = {gamma_key(g): [0.0 if g == (0.0, 0.0) else 10 * g[0], 12 * g[0]]
              for g in TABLE9_GAMMAS}
    fig = emg4.agd_step_size_figure(results, {"relative_change": change, "target_change": 1.0,
                                              "t": 500})
    heights = [p.get_height() for p in fig.axes[0].patches]
    assert heights == pytest.approx([np.mean(results[gamma_key(g)]["r_precision_top3"])
                                     for g in TABLE9_GAMMAS])
    dots = [line.get_ydata().tolist() for line in fig.axes[2].lines[:-1]]   # the rows with AGD
    assert dots == [change[gamma_key(g)] for g in TABLE9_GAMMAS[1:]]
    rows = [("SEF", "0.1,0.7,0.2"), ("latent only", "1.0,0.0,0.0")]
    fig = threes.three_concepts_figure(rows, results, results, results)
    assert len(fig.axes) == 2 and len(fig.axes[0].patches) == 3 * len(rows)


def test_notebook_07_figures() -> None:
    counts = (1, 5)
    part = {str(n): {m: [0.1 * n, 0.2] for m in ("mpjpe", "fid", "r_precision_top3")}
            for n in counts}
    fig = lc.latent_count_figure({"reconstruction": part, "generation": part}, counts)
    assert len(fig.axes) == 2 * 2 + 3                          # four panels, three paper axes
    fig = lc.reconstructions_figure(JOINTS, "a person claps.",
                                         [(1, JOINTS, 0.25), (5, JOINTS, 0.125)])
    assert len(fig.axes) == 3 and "0.125" in fig.axes[2].get_title()


def test_notebook_08_figures() -> None:
    example = ComposedSet(concepts=(HELD_OUT_PAIRS[0], ("walk_forward", "wave_left")),
                          concept_texts=(("a", "b"), ("c", "d")), texts=("ab", "cd"),
                          features=np.zeros((2, 8, 263)), joints=np.zeros((2, 8, 22, 3)))
    fig = emg8.composed_examples_figure(example, [0, 1])
    titles = [ax.get_title() for ax in fig.axes]
    assert "held-out pair" in titles[0] and "trained pair" in titles[1]
    part = {row: {m: [0.1, 0.2] for m in ("r_precision_top3", "fid", "both_present")}
            for row in ROWS}
    fig = emg8.augmentation_figure({"t2m": part, "held_out": part}, SEEDS)
    assert len(fig.axes) == 3 and len(fig.axes[0].patches) == len(ROWS)


matplotlib.use("Agg")

PLATEAU = TrainingRecord(steps=40, step_cap=60, train_seconds=2.0, converged=True,
                         stop_reason="plateau", validation_curve=((0, 1.0), (20, 0.5), (40, 0.6)),
                         losses=())
CAPPED = TrainingRecord(steps=60, step_cap=60, train_seconds=3.0, converged=False,
                        stop_reason="step cap", validation_curve=((0, 1.0), (60, 0.9)), losses=())
FIXED = TrainingRecord(steps=10, step_cap=10, train_seconds=None, converged=None,
                       stop_reason=None, validation_curve=(), losses=(1.0,))


def test_the_table_says_how_each_run_stopped() -> None:
    text = training_markdown([("vae a", PLATEAU), ("denoiser b", CAPPED), ("vae c", FIXED)])
    assert "0.5 (step 20)" in text and "step cap" in text and "fixed steps" in text
    assert "1 of 2 validated runs stopped on the plateau" in text


def test_latent_count_rows_and_the_figure() -> None:
    results = {"training": {"1": [{"vae": PLATEAU.to_dict(), "denoiser": CAPPED.to_dict()}]}}
    rows = latent_count_training(results, [1], [0])
    assert [name for name, _ in rows] == ["vae N=1 seed 0", "denoiser N=1 seed 0"]
    figure = validation_curves_figure(rows)
    assert [len(ax.lines) for ax in figure.axes] == [1, 1]
