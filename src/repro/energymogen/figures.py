"""What the EnergyMoGen notebooks share for showing their results: the training tables and
validation curves of their models (from the ``pipeline.TrainingRecord`` of each: steps used
against the cap, how each run stopped, its best held-out loss) and the animated samples.

Each claim's own figures are in its notebook's module. No function here measures or trains
anything.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
from matplotlib.figure import Figure

from repro.core.tables import markdown_table
from repro.energymogen.harness import TextToMotionTest
from repro.energymogen.pipeline import (
    EnergyMoGenPipeline,
    Sampler,
    TrainingRecord,
)
from repro.motion.plotting import animate_side_by_side, shorten

__all__ = [
    "Figures",
    "Record",
    "animate_samples",
    "training_markdown",
    "validation_curves_figure",
]
Figures = Sequence[str | os.PathLike]


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
