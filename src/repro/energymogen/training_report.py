"""How the EnergyMoGen notebooks' models were trained, shown from their training records
(``convergence.TrainingRecord``, issue #14): a table of steps used against the cap, how each
run stopped and its best held-out loss, and a figure of the validation curves. Nothing here
measures or trains anything.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib.pyplot as plt
from matplotlib.figure import Figure

from repro.core.tables import markdown_table
from repro.energymogen.convergence import TrainingRecord
from repro.energymogen.data import NotMeasurable
from repro.energymogen.pipeline import PipelineSource, pipeline_for

__all__ = ["augmentation_training", "latent_count_training", "training_markdown",
           "validation_curves_figure"]

Record = TrainingRecord | Mapping[str, Any]


def _as_dict(record: Record) -> dict[str, Any]:
    return record.to_dict() if isinstance(record, TrainingRecord) else dict(record)


def _number(value: float | None, digits: int = 3) -> str:
    return "—" if value is None else f"{value:.{digits}g}"


def training_markdown(records: Sequence[tuple[str, Record]]) -> str:
    """One row per (model name, record): steps used, step cap, how it stopped ("plateau",
    "step cap", or "fixed steps" for a run without validation), the best held-out loss and
    its step, training seconds; then how many runs converged."""
    rows, converged, validated = [], 0, 0
    for name, record in records:
        r = _as_dict(record)
        curve = r.get("validation_curve") or []
        best = min(curve, key=lambda point: point[1]) if curve else None
        if r.get("converged") is not None:
            validated += 1
            converged += bool(r["converged"])
        rows.append([name, _number(r.get("steps"), 6), _number(r.get("step_cap"), 6),
                     r.get("stop_reason") or "fixed steps",
                     "—" if best is None else f"{best[1]:.4g} (step {int(best[0])})",
                     _number(r.get("train_seconds"), 4)])
    table = markdown_table(["model", "steps used", "step cap", "stopped by",
                            "best validation loss", "training s"], rows)
    return table + (f"\n\n{converged} of {validated} validated runs stopped on the plateau "
                    "criterion; the others reached their step cap (not converged)."
                    if validated else "")


def latent_count_training(results: Mapping[str, Any], counts: Sequence[int],
                          seeds: Sequence[int]) -> list[tuple[str, Record]]:
    """``latent_count.latent_count_study``'s training records as (name, record) rows: the
    VAE and the denoiser of every (N, training seed)."""
    rows: list[tuple[str, Record]] = []
    for n in counts:
        for i, seed in enumerate(seeds):
            for part, record in results["training"][str(n)][i].items():
                rows.append((f"{part} N={n} seed {seed}", record))
    return rows


def augmentation_training(source: PipelineSource, results: Mapping[str, Any] | NotMeasurable,
                          seeds: Sequence[int]) -> list[tuple[str, Record]]:
    """Notebook 08's training records as (name, record) rows: per seed the pretrained VAE and
    denoiser of ``pipeline_for(source, seed)``, then the control and augmented fine-tuning
    runs of ``augmentation.augmentation_study`` (none when it is not measurable)."""
    rows: list[tuple[str, Record]] = []
    for i, s in enumerate(seeds):
        seed_pipe = pipeline_for(source, s)
        rows += [(f"vae train seed {seed_pipe.train_seed}", seed_pipe.training["vae"]),
                 (f"denoiser train seed {seed_pipe.train_seed}", seed_pipe.training["denoiser"])]
        if not isinstance(results, NotMeasurable):
            rows += [(f"{row} fine-tuning seed {s}", results["training"][row][i])
                     for row in ("control", "augmented")]
    return rows


def validation_curves_figure(records: Sequence[tuple[str, Record]],
                             title: str = "held-out validation loss") -> Figure:
    """The validation curves (loss against step) of the VAEs (left) and the denoisers
    (right) among ``records``, one line per model; names starting "vae" go left."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.4))
    for ax, family in zip(axes, ("vae", "denoiser"), strict=True):
        drawn = 0
        for name, record in records:
            curve = _as_dict(record).get("validation_curve") or []
            if (name.lower().startswith("vae")) != (family == "vae") or not curve:
                continue
            steps, losses = zip(*curve, strict=True)
            ax.plot(steps, losses, marker=".", lw=1, label=name)
            drawn += 1
        ax.set_title(f"{family}: {title}", fontsize=9)
        ax.set_xlabel("training step")
        ax.set_yscale("log")
        if drawn:
            ax.legend(fontsize=6)
        else:
            ax.text(0.5, 0.5, "no validated run", ha="center", transform=ax.transAxes)
    fig.tight_layout()
    return fig
