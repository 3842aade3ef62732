"""What a training run is (``TrainConfig``) and which of its fields a cache key covers.

``TrainConfig`` is frozen: a model family's config holds one (``GMDModelSpec.training``,
``EvaluatorConfig.training``, ``PipelineConfig``'s per-model trainings) and
:func:`replace_with_training` changes a held field. ``to_config`` is what a cache hash covers:
not the device or the threads; the opt-in speed levers (``autocast``, ``fused_adamw``) only
when set, and the convergence fields (``validate_every``, ``patience``, ``min_delta``,
``validation_timesteps``) only with ``validate_every`` set, so every earlier key holds.
``core.training`` (the loop) re-exports all of it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, TypeVar

import torch

__all__ = ["AUTOCAST_DTYPES", "LR_SCHEDULES", "TRAIN_CONFIG_FIELDS", "TrainConfig",
           "check_autocast", "check_convergence_fields", "drop_unset_convergence_fields",
           "fixed_steps_patience", "learning_rate_factor", "replace_with_training"]

#: the ``TrainConfig.autocast`` values and the dtype each runs the matrix products in
AUTOCAST_DTYPES: dict[str | None, torch.dtype | None] = {None: None, "bfloat16": torch.bfloat16}
_OPT_IN_DEFAULTS: dict[str, Any] = {"autocast": None, "fused_adamw": False,
                                     "lr_schedule": None}
#: the ``TrainConfig.lr_schedule`` values: None (constant ``lr``) or "cosine"
#: (:func:`learning_rate_factor`)
LR_SCHEDULES = (None, "cosine")
#: the linear warm-up of the "cosine" schedule: this share of the steps (at least one step)
WARMUP_SHARE = 0.05


def learning_rate_factor(schedule: str | None, step: int, steps: int) -> float:
    """The multiplier of ``lr`` at optimiser step ``step`` (0-based) of ``steps``.

    None: 1. "cosine": a linear warm-up over the first w = max(1, ⌈WARMUP_SHARE·steps⌉) steps,
    (step + 1)/w, then half a cosine from 1 to 0 over the rest (Loshchilov & Hutter's SGDR
    without restarts): ½(1 + cos(π·(step − w)/(steps − w))). A short run ends with small steps,
    which averages the weights as an EMA would, without the EMA's lag.
    """
    if schedule not in LR_SCHEDULES:
        raise ValueError(f"lr_schedule must be one of {LR_SCHEDULES}, got {schedule!r}")
    if schedule is None:
        return 1.0
    warmup = max(1, math.ceil(WARMUP_SHARE * steps))
    if step < warmup:
        return (step + 1) / warmup
    return 0.5 * (1.0 + math.cos(math.pi * (step - warmup) / max(1, steps - warmup)))
#: the convergence fields: in ``to_config`` (as a group) only when ``validate_every`` is set
_CONVERGENCE_DEFAULTS: dict[str, Any] = {"validate_every": None, "patience": 5,
                                         "min_delta": 0.01, "validation_timesteps": 10}


def fixed_steps_patience(steps: int, validate_every: int) -> int:
    """The plateau criterion's patience that outlasts a run of ``steps`` validated every
    ``validate_every`` steps (one more than its evaluations): the held-out curve is recorded,
    the plateau stop never acts, so the run trains exactly ``steps`` steps."""
    return steps // validate_every + 1


def check_autocast(autocast: str | None) -> None:
    """Raise unless ``autocast`` is one of ``AUTOCAST_DTYPES`` (None: fp32)."""
    if autocast not in AUTOCAST_DTYPES:
        raise ValueError(f"autocast must be one of {sorted(map(str, AUTOCAST_DTYPES))}, "
                         f"got {autocast!r}")


def check_convergence_fields(config: Any) -> None:
    """Validate ``validate_every``/``patience``/``min_delta``/``validation_timesteps``; they
    may differ from their defaults only when ``validate_every`` is set (else they do nothing
    and would still change the cache key)."""
    if config.validate_every is None:
        changed = [name for name, default in _CONVERGENCE_DEFAULTS.items()
                   if getattr(config, name, default) != default]
        if changed:
            raise ValueError(f"{changed} only act with validate_every set")
        return
    if config.validate_every < 1:
        raise ValueError(f"validate_every must be >= 1 or None, got {config.validate_every}")
    if config.patience < 1:
        raise ValueError(f"patience must be >= 1, got {config.patience}")
    if not 0.0 <= config.min_delta < 1.0:
        raise ValueError(f"min_delta must be in [0, 1), got {config.min_delta}")
    if getattr(config, "validation_timesteps", 1) < 1:
        raise ValueError("validation_timesteps must be >= 1")


def drop_unset_convergence_fields(config: dict[str, Any]) -> dict[str, Any]:
    """Without ``validate_every`` the convergence fields leave the key (as before they
    existed); with it they all stay."""
    if config.get("validate_every") is None:
        for name in _CONVERGENCE_DEFAULTS:
            config.pop(name, None)
    return config


@dataclass(frozen=True)
class TrainConfig:
    """Optimisation settings (frozen: a model family's config holds one, and a spec is
    hashable). ``to_config()`` is what a cache hash should cover; change a field with
    ``dataclasses.replace``."""

    steps: int = 1000
    batch_size: int = 64
    lr: float = 1e-4
    weight_decay: float = 0.01
    grad_clip: float | None = 1.0
    ema_decay: float = 0.9999
    ema_warmup: bool = True
    seed: int = 0
    feature_weights: tuple[float, ...] | None = None
    cond_dropout: float = 0.0
    device: str = "cpu"
    num_threads: int | None = None
    #: None (fp32) or "bfloat16": forward/backward under torch.autocast (opt-in; in the key)
    autocast: str | None = None
    #: the fused AdamW kernel (float-noise differences from the loop; opt-in; in the key)
    fused_adamw: bool = False
    #: None (constant ``lr``) or "cosine" (``learning_rate_factor``; opt-in; in the key)
    lr_schedule: str | None = None
    #: evaluate the EMA weights on the validation set every this many steps (None: never;
    #: the convergence fields below enter the key only when this is set)
    validate_every: int | None = None
    #: stop after this many evaluations without a relative improvement of ``min_delta``
    patience: int = 5
    min_delta: float = 0.01
    #: the validation loss averages over this many evenly spaced timesteps 0 … T − 1
    validation_timesteps: int = 10

    def __post_init__(self) -> None:
        if self.steps < 1 or self.batch_size < 1:
            raise ValueError(f"steps and batch_size must be >= 1, got {self.steps}, "
                             f"{self.batch_size}")
        if self.lr <= 0 or self.weight_decay < 0:
            raise ValueError(f"need lr > 0 and weight_decay >= 0, got {self.lr}, "
                             f"{self.weight_decay}")
        if self.grad_clip is not None and self.grad_clip <= 0:
            raise ValueError(f"grad_clip must be > 0 or None, got {self.grad_clip}")
        if not 0.0 <= self.ema_decay < 1.0:
            raise ValueError(f"ema_decay must be in [0, 1), got {self.ema_decay}")
        if not 0.0 <= self.cond_dropout <= 1.0:
            raise ValueError(f"cond_dropout must be in [0, 1], got {self.cond_dropout}")
        if self.feature_weights is not None:
            object.__setattr__(self, "feature_weights",
                               tuple(float(w) for w in self.feature_weights))
        check_autocast(self.autocast)
        if self.lr_schedule not in LR_SCHEDULES:
            raise ValueError(f"lr_schedule must be one of {LR_SCHEDULES}, got "
                             f"{self.lr_schedule!r}")
        check_convergence_fields(self)

    def to_config(self) -> dict[str, Any]:
        """Every field that changes the trained weights (not ``device`` or ``num_threads``).

        The opt-in speed levers appear only when set, so the keys of configs that leave them
        at their defaults are those of the configs before the levers existed.
        """
        config = dataclasses.asdict(self)
        config.pop("device")
        config.pop("num_threads")
        if self.feature_weights is not None:
            config["feature_weights"] = list(self.feature_weights)
        for name, default in _OPT_IN_DEFAULTS.items():
            if config[name] == default:
                config.pop(name)
        return drop_unset_convergence_fields(config)

    @property
    def autocast_dtype(self) -> torch.dtype | None:
        return AUTOCAST_DTYPES[self.autocast]


TRAIN_CONFIG_FIELDS = frozenset(f.name for f in dataclasses.fields(TrainConfig))

_Holder = TypeVar("_Holder")


def replace_with_training(config: _Holder, **changes: Any) -> _Holder:
    """``dataclasses.replace(config, **changes)`` for a model family's config that holds its
    ``TrainConfig`` as ``training``: a ``TrainConfig`` field name (``seed``, ``steps`` …)
    changes that field of ``config.training``."""
    training = {name: changes.pop(name) for name in list(changes)
                if name in TRAIN_CONFIG_FIELDS}
    if training:
        held = changes.get("training", config.training)  # type: ignore[attr-defined]
        changes["training"] = dataclasses.replace(held, **training)
    return dataclasses.replace(config, **changes)  # type: ignore[type-var]
