"""Training the EnergyMoGen pipeline's VAE and latent denoiser to convergence (issue #14).

:class:`TrainingPlan` says how (``repro.core.training``'s plateau criterion on a held-out
validation loss, with a step cap; docs/TRAINING.md); :class:`TrainingRecord` is what a trained
model's own cache entry says of its training (steps used, seconds, validation curve, whether
it converged), read by exactly its key (:func:`cached_training_record`), never by scanning the
cache. ``pipeline.load_pipeline`` keeps one record per trained model on the pipeline, and
``model_gates`` takes them from there.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from repro.core.training import fixed_steps_patience
from repro.energymogen.config import STANDARD_DENOISER_STEPS, STANDARD_VAE_STEPS
from repro.infra import cache, paths, storage
from repro.infra.context import check_scale

__all__ = ["FULL_VAE_STEP_CAP", "TrainingPlan", "TrainingRecord", "cached_training_record"]


#: the full-mode VAE step cap: what 20 CPU-minutes buy on one thread (0.1015 CPU-s per step,
#: rounded down to 250), as the rule of ``pilots/pilot_emg_vae.md`` says when the pilot VAE
#: (N = 5) did not reach its gate within them
FULL_VAE_STEP_CAP = 11750


@dataclass(frozen=True)
class TrainingPlan:
    """Convergence training of the VAE and the latent denoiser (``repro.core.training``'s
    plateau criterion): the validation loss on ``validation_clips`` held-out clips of the
    training distribution (``data.load_or_build_validation_clips``, the stand-in for
    HumanML3D's validation split) every ``*_validate_every`` steps; stop after ``patience``
    evaluations without a relative gain of ``min_delta``, or at the ``*_step_cap``.

    With a plan the caps replace the step counts of ``PipelineConfig.vae_training`` /
    ``denoiser_training`` and the convergence fields and the validation data enter the cache
    keys; without one (None) training is as before, with the same keys. :meth:`for_scale`
    gives the notebooks' plans.
    """

    validation_clips: int
    vae_step_cap: int
    vae_validate_every: int
    denoiser_step_cap: int
    denoiser_validate_every: int
    patience: int = 5
    min_delta: float = 0.01
    #: False: train exactly the step caps (a fixed step count); the validation curve is still
    #: recorded (the standard scale, docs/COMPUTE.md §3a item 3)
    plateau_stop: bool = True

    def __post_init__(self) -> None:
        for name in ("validation_clips", "vae_step_cap", "vae_validate_every",
                     "denoiser_step_cap", "denoiser_validate_every", "patience"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if not 0.0 <= self.min_delta < 1.0:
            raise ValueError(f"min_delta must be in [0, 1), got {self.min_delta}")

    def patience_of(self, step_cap: int, validate_every: int) -> int:
        """The plateau criterion's patience for a model validated every ``validate_every``
        steps up to ``step_cap``: :attr:`patience`, or without :attr:`plateau_stop` one more
        than the run's evaluations, so the criterion records the curve but never stops it."""
        if self.plateau_stop:
            return self.patience
        return fixed_steps_patience(step_cap, validate_every)

    @property
    def vae_patience(self) -> int:
        return self.patience_of(self.vae_step_cap, self.vae_validate_every)

    @property
    def denoiser_patience(self) -> int:
        return self.patience_of(self.denoiser_step_cap, self.denoiser_validate_every)

    def summary(self) -> str:
        """How the plan trains, in words (for notes)."""
        if not self.plateau_stop:
            return (f"fixed {self.vae_step_cap} VAE and {self.denoiser_step_cap} denoiser "
                    f"steps (no plateau stop; held-out loss on {self.validation_clips} "
                    "validation clips recorded)")
        return (f"trained to convergence: VAE cap {self.vae_step_cap}, denoiser cap "
                f"{self.denoiser_step_cap} steps; validation on {self.validation_clips} "
                f"held-out clips, patience {self.patience}, min delta {self.min_delta}")

    @classmethod
    def for_scale(cls, scale: str) -> TrainingPlan:
        """The notebooks' plan at ``scale`` (``infra.context.SCALES``).

        paper: the caps of ``pilots/pilot_emg_vae.md`` (VAE) and 4× the fixed 2500 denoiser
        steps (no denoiser pilot), 128 validation clips, validation every 250 steps
        (≈ 2–3 % of the training time), the TRAINING.md defaults patience 5 and δ 1 %.
        standard (docs/COMPUTE.md §3b, §4 item 3): a FIXED 900 VAE steps (the pilot's VAE
        passed its gate from 750 in both seeds) and 1500 denoiser steps (§10), no plateau stop; the
        held-out curve is still recorded (VAE every 150 steps, as the pilot's checks;
        denoiser every 250), on 128 validation clips. quick: caps at the quick
        configuration's fixed step counts (40 VAE, 80 denoiser steps), two evaluations each,
        patience 2: a test of the code path only."""
        scale = check_scale(scale)
        if scale == "quick":
            return cls(validation_clips=16, vae_step_cap=40, vae_validate_every=20,
                       denoiser_step_cap=80, denoiser_validate_every=40, patience=2)
        if scale == "standard":
            return cls(validation_clips=128, vae_step_cap=STANDARD_VAE_STEPS,
                       vae_validate_every=150, denoiser_step_cap=STANDARD_DENOISER_STEPS,
                       denoiser_validate_every=250, plateau_stop=False)
        return cls(validation_clips=128, vae_step_cap=FULL_VAE_STEP_CAP, vae_validate_every=250,
                   denoiser_step_cap=10000, denoiser_validate_every=250)


@dataclass(frozen=True)
class TrainingRecord:
    """How one model of the pipeline was trained, from its own cache entry (the metrics.json
    written beside its weights): ``steps`` used, ``step_cap``, ``train_seconds`` (None when
    the entry keeps none), ``converged`` (None: trained without validation), ``stop_reason``,
    the held-out ``validation_curve`` [(step, loss)] (empty without validation) and the
    per-step training ``losses``."""

    steps: int | None
    step_cap: int | None
    train_seconds: float | None
    converged: bool | None
    stop_reason: str | None
    validation_curve: tuple[tuple[int, float], ...]
    losses: tuple[float, ...]

    def to_dict(self) -> dict[str, Any]:
        return {"steps": self.steps, "step_cap": self.step_cap,
                "train_seconds": self.train_seconds, "converged": self.converged,
                "stop_reason": self.stop_reason,
                "validation_curve": [list(p) for p in self.validation_curve]}


def cached_training_record(kind: str, key: Mapping[str, Any],
                           step_cap: int | None) -> TrainingRecord:
    """The :class:`TrainingRecord` of the cache entry of ``kind`` under exactly ``key`` (its
    metrics.json: ``losses``, ``seconds``, ``convergence``); ``step_cap`` is the configured
    step count (the steps used when the run did not validate)."""
    metrics_file = paths.cache_dir() / kind / cache.config_hash(dict(key)) / "metrics.json"
    stored = storage.read_json(metrics_file) if metrics_file.exists() else {}
    losses = stored.get("losses", [])
    if isinstance(losses, Mapping):
        losses = losses.get("loss", [])
    convergence = stored.get("convergence")
    if convergence is None:
        return TrainingRecord(steps=len(losses) or step_cap, step_cap=step_cap,
                              train_seconds=stored.get("seconds"), converged=None,
                              stop_reason=None, validation_curve=(),
                              losses=tuple(float(v) for v in losses))
    return TrainingRecord(
        steps=int(convergence["steps_used"]), step_cap=int(convergence["step_cap"]),
        train_seconds=stored.get("seconds"), converged=bool(convergence["converged"]),
        stop_reason=convergence["stop_reason"],
        validation_curve=tuple((int(a), float(b)) for a, b in convergence["validation"]),
        losses=tuple(float(v) for v in losses))
