"""The training tables and curves of notebooks 07/08 (repro.energymogen.training_report)."""

from __future__ import annotations

import matplotlib

from repro.energymogen.figures import training_markdown, validation_curves_figure
from repro.energymogen.latent_count import latent_count_training
from repro.energymogen.pipeline import TrainingRecord

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
