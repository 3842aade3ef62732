"""The one training loop (``train_loop``: AdamW, gradient clipping, EMA, validation and the
plateau stop, threads, progress) and the diffusion models' loss on it (GMD appendix E).

Every family trains with ``train_loop``, supplying its batch source and its loss:
the diffusion models through ``train_diffusion`` (GMD's UNets, the latent denoiser), the VAE
(``models.vae.train_vae``, no EMA), the evaluator and EnergyMoGen's learned text encoder
(InfoNCE, no clip, no EMA).

GMD trains with AdamW (lr 1e-4, weight decay 0.01), clips the gradient norm at 1 and samples
from an exponential moving average of the weights (β = 0.9999). Our runs are a few thousand
steps, where a 0.9999 average would still be mostly the random initialisation, so the EMA
decay is warmed up (improved-diffusion / TF ExponentialMovingAverage ``num_updates``):

    decay_n = min(ema_decay, (1 + n)/(10 + n))   for the n-th update (n = 0, 1, …)

so the average covers roughly the last n/9 steps early on and the configured horizon
1/(1 − ema_decay) once n is large. ``ema_warmup=False`` uses ``ema_decay`` from the start.

``train_diffusion``'s data: a tensor (N, C, T), optional ``cond`` (N, D) and ``mask`` (N, T),
batched with a seeded generator; or an iterable of batches (a DataLoader) each either a tensor
x or a dict with ``"x"`` and optional ``"cond"`` and ``"mask"``. Models are called as
``model(x_t, t, cond=…, cond_mask=…)``; ``cond_mask`` (true = keep) is drawn here when
``cond_dropout > 0`` (classifier-free training).

Speed (measured by ``python -m repro.run.bench_training``): AdamW, the gradient
clip and the EMA run as ``foreach`` kernels over all parameters — on CPU the same arithmetic as
the per-parameter loops, bitwise (``tests/core/test_training.py`` checks it), so they are the
default and leave every cache key as it was. Two levers change the numerics and are opt-in,
entering ``to_config`` (and so the cache key) only when set: ``autocast="bfloat16"`` runs the
forward and backward under ``torch.autocast`` (bf16 matrix products, fp32 weights, optimiser
and loss reduction), and ``fused_adamw=True`` uses the fused AdamW kernel (float-noise
differences, ~1e-6 after a few steps).

Convergence (docs/TRAINING.md): with ``validate_every`` set and a ``validation``
set passed, the EMA weights' loss on held-out data is measured every ``validate_every`` steps
on a fixed grid of timesteps with fixed noise (``ValidationSet``), so successive values of the
curve differ only by the weights. Training stops when the best validation loss has not
improved by a relative ``min_delta`` for ``patience`` evaluations (``PlateauCriterion``);
``steps`` stays the cap. Validation draws from its own generator, so the training trajectory
is the one without validation, step for step. The convergence fields enter ``to_config``
only when ``validate_every`` is set, so every earlier cache key is unchanged.
"""

from __future__ import annotations

import contextlib
import copy
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

import torch
from torch import Tensor, nn

from repro.core.diffusion import GaussianDiffusion, UniformSampler
from repro.core.train_config import (
    AUTOCAST_DTYPES,
    TRAIN_CONFIG_FIELDS,
    TrainConfig,
    check_autocast,
    check_convergence_fields,
    drop_unset_convergence_fields,
    fixed_steps_patience,
    learning_rate_factor,
    replace_with_training,
)
from repro.infra import progress as run_progress
from repro.infra.cache import load_or_train

__all__ = ["AUTOCAST_DTYPES", "VALIDATION_SEED_OFFSET", "ConvergenceRecord", "PlateauCriterion",
           "TRAIN_CONFIG_FIELDS", "TrainConfig", "TrainResult", "ValidationPairs",
           "ValidationSet", "autocast_context", "check_autocast",
           "check_convergence_fields", "drop_unset_convergence_fields", "ema_decay_at",
           "fixed_steps_patience",
           "load_or_train", "make_adamw", "replace_with_training", "shuffled_indices",
           "torch_threads",
           "train_diffusion", "train_loop", "validation_loss"]

#: the validation noise's generator seed is ``seed + VALIDATION_SEED_OFFSET`` (not the
#: training generator, so validating leaves the training trajectory unchanged)
VALIDATION_SEED_OFFSET = 7919


@dataclass
class PlateauCriterion:
    """Stop when the best loss has not improved by a relative ``min_delta`` for ``patience``
    evaluations: an evaluation improves when loss < best·(1 − min_delta)."""

    patience: int
    min_delta: float
    best: float = float("inf")
    best_step: int | None = None
    evaluations_since_best: int = 0

    def update(self, step: int, loss: float) -> bool:
        """Record ``loss`` measured after ``step`` steps; true when training should stop."""
        if not loss == loss:                        # NaN never improves
            self.evaluations_since_best += 1
        elif self.best_step is None or loss < self.best * (1.0 - self.min_delta):
            self.best, self.best_step, self.evaluations_since_best = loss, step, 0
        else:
            self.evaluations_since_best += 1
        return self.evaluations_since_best >= self.patience


@dataclass
class ConvergenceRecord:
    """How a run with validation ended: the curve (step, loss), the steps it used, and
    whether the plateau criterion stopped it (``converged``) or the step cap did."""

    validation: list[tuple[int, float]]
    steps_used: int
    step_cap: int
    converged: bool
    best_step: int | None
    best_loss: float

    @property
    def stop_reason(self) -> str:
        return "plateau" if self.converged else "step cap"

    def to_dict(self) -> dict[str, Any]:
        return {"validation": [[step, loss] for step, loss in self.validation],
                "steps_used": self.steps_used, "step_cap": self.step_cap,
                "converged": self.converged, "stop_reason": self.stop_reason,
                "best_step": self.best_step, "best_loss": self.best_loss}


@dataclass
class TrainResult:
    """The trained model, its EMA copy, and the loss of every step."""

    model: nn.Module
    ema_model: nn.Module
    losses: list[float] = field(default_factory=list)
    seconds: float = 0.0
    #: set when the run validated (``TrainConfig.validate_every``), else None
    convergence: ConvergenceRecord | None = None

    @property
    def steps_per_second(self) -> float:
        return len(self.losses) / self.seconds if self.seconds > 0 else float("nan")

    @property
    def steps_used(self) -> int:
        return len(self.losses)

    def metrics(self) -> dict[str, Any]:
        """Losses and timing; plus ``"convergence"`` (``ConvergenceRecord.to_dict``) when the
        run validated."""
        metrics = {"losses": self.losses,
                   "final_loss": self.losses[-1] if self.losses else None,
                   "seconds": self.seconds, "steps_per_second": self.steps_per_second}
        if self.convergence is not None:
            metrics["convergence"] = self.convergence.to_dict()
        return metrics

    def for_cache(self, use_ema: bool = True) -> tuple[nn.Module, dict[str, Any]]:
        """``(module, metrics)`` as ``load_or_train``'s ``train`` callable should return."""
        return (self.ema_model if use_ema else self.model), self.metrics()


def ema_decay_at(update: int, ema_decay: float, warmup: bool = True) -> float:
    """decay_n = min(ema_decay, (1 + n)/(10 + n)) with warm-up, else ema_decay."""
    return min(ema_decay, (1.0 + update) / (10.0 + update)) if warmup else ema_decay


@torch.no_grad()
def _update_ema(ema_model: nn.Module, model: nn.Module, decay: float) -> None:
    """θ_ema ← decay·θ_ema + (1 − decay)·θ (one foreach lerp over all parameters, the same
    arithmetic as ``lerp_`` per parameter); buffers are copied."""
    ema_params = list(ema_model.parameters())
    params = [p.detach() for p in model.parameters()]
    if len(ema_params) != len(params):
        raise ValueError("the EMA model and the model have different parameter lists")
    if params:
        torch._foreach_lerp_(ema_params, params, 1.0 - decay)
    for ema_buffer, buffer in zip(ema_model.buffers(), model.buffers(), strict=True):
        ema_buffer.copy_(buffer)


def make_adamw(parameters: Iterable[nn.Parameter], *, lr: float, weight_decay: float,
               fused: bool = False) -> torch.optim.AdamW:
    """AdamW as the package trains with it: the foreach kernel (bitwise the per-parameter
    loop's result on CPU), or the fused kernel when ``fused`` (float-noise differences)."""
    if fused:
        return torch.optim.AdamW(parameters, lr=lr, weight_decay=weight_decay, fused=True)
    return torch.optim.AdamW(parameters, lr=lr, weight_decay=weight_decay, foreach=True)


def autocast_context(device: torch.device, dtype: torch.dtype | None
                     ) -> contextlib.AbstractContextManager:
    """``torch.autocast(device.type, dtype)`` when ``dtype`` is set, else a no-op context."""
    if dtype is None:
        return contextlib.nullcontext()
    return torch.autocast(device.type, dtype=dtype)


def shuffled_indices(n: int, batch_size: int, generator: torch.Generator) -> Iterator[Tensor]:
    """Endless batches of ``batch_size`` indices into ``n`` examples, without replacement
    within an epoch: one ``torch.randperm(n, generator)`` per epoch, drawn when needed."""
    order = torch.empty(0, dtype=torch.long)
    while True:
        while order.numel() < batch_size:
            order = torch.cat([order, torch.randperm(n, generator=generator)])
        index, order = order[:batch_size], order[batch_size:]
        yield index


def _tensor_batches(x: Tensor, cond: Tensor | None, mask: Tensor | None, batch_size: int,
                    generator: torch.Generator, *,
                    cond_choices: bool = False) -> Iterator[dict[str, Tensor]]:
    """Endless shuffled batches (``shuffled_indices``) of x and its cond and mask. With
    ``cond_choices`` the cond (N, K, …) holds K alternatives per example (e.g. its K
    captions): each batch takes one of them per example, drawn uniformly with ``generator``."""
    for index in shuffled_indices(x.shape[0], batch_size, generator):
        batch = {"x": x[index]}
        if cond is not None and cond_choices:
            pick = torch.randint(cond.shape[1], (index.numel(),), generator=generator)
            batch["cond"] = cond[index, pick]
        elif cond is not None:
            batch["cond"] = cond[index]
        if mask is not None:
            batch["mask"] = mask[index]
        yield batch


def _loader_batches(loader: Iterable[Any]) -> Iterator[dict[str, Tensor]]:
    while True:
        empty = True
        for batch in loader:
            empty = False
            if isinstance(batch, Tensor):
                yield {"x": batch}
            elif isinstance(batch, dict) and "x" in batch:
                yield batch
            else:
                raise ValueError("a data loader must yield tensors x or dicts with key 'x' "
                                 f"(optional 'cond', 'mask'), got {type(batch).__name__}")
        if empty:
            raise ValueError("the data loader yielded no batch")


@dataclass
class ValidationSet:
    """Held-out data x (N, C, T) with optional ``cond`` (N, …) and frame ``mask`` (N, T).

    ``pairs`` fixes what one evaluation covers: every example at each of K evenly spaced
    timesteps t_k = round(k·(T − 1)/(K − 1)) (K = 1: t = T − 1), each pair with its own
    noise; ``validation_loss`` redraws that noise from ``torch.Generator(noise_seed)`` in the
    same chunks every time, so two evaluations differ only by the weights (and nothing of
    size N·K·C·T is kept between them).
    """

    x: Tensor
    cond: Tensor | None = None
    mask: Tensor | None = None

    def __post_init__(self) -> None:
        if self.x.dim() < 2 or self.x.shape[0] < 1:
            raise ValueError(f"validation x must be (N, C, T), got {tuple(self.x.shape)}")
        for name, extra in (("cond", self.cond), ("mask", self.mask)):
            if extra is not None and extra.shape[0] != self.x.shape[0]:
                raise ValueError(f"validation {name} has {extra.shape[0]} rows but x has "
                                 f"{self.x.shape[0]}")

    def pairs(self, num_timesteps: int, timesteps: int, noise_seed: int) -> ValidationPairs:
        """The fixed (example, t) pairs, examples varying fastest."""
        k = min(timesteps, num_timesteps)
        grid = (torch.tensor([num_timesteps - 1]) if k == 1 else
                torch.round(torch.linspace(0, num_timesteps - 1, k)).long())
        n = self.x.shape[0]
        return ValidationPairs(data=self, index=torch.arange(n).repeat(k),
                               t=grid.repeat_interleave(n), noise_seed=noise_seed)


@dataclass
class ValidationPairs:
    """``ValidationSet.pairs``: example ``index`` and timestep ``t`` per pair (N·K,)."""

    data: ValidationSet
    index: Tensor
    t: Tensor
    noise_seed: int


@torch.no_grad()
def validation_loss(model: nn.Module, diffusion: GaussianDiffusion, pairs: ValidationPairs,
                    *, batch_size: int, device: torch.device,
                    feature_weights: Tensor | None = None) -> float:
    """Mean of ``diffusion.training_losses`` over the fixed pairs (the condition always
    kept), in chunks of ``batch_size``, the noise of each chunk drawn in turn from a fresh
    ``torch.Generator(pairs.noise_seed)``; the model is used as it is (pass the EMA copy, in
    eval mode)."""
    data, generator = pairs.data, torch.Generator().manual_seed(pairs.noise_seed)
    total, count = 0.0, pairs.index.shape[0]
    for start in range(0, count, batch_size):
        index = pairs.index[start:start + batch_size]
        x0 = data.x[index]
        noise = torch.randn(x0.shape, generator=generator, dtype=x0.dtype)
        model_kwargs: dict[str, Any] = {}
        if data.cond is not None:
            model_kwargs["cond"] = data.cond[index].to(device)
        mask = None if data.mask is None else data.mask[index].to(device)
        losses = diffusion.training_losses(
            model, x0.to(device), pairs.t[start:start + batch_size].to(device),
            model_kwargs=model_kwargs, noise=noise.to(device), feature_weights=feature_weights,
            mask=mask)
        total += float(losses.double().sum())
    return total / count


def train_loop(model: nn.Module, loss_fn: Callable[[Any], Tensor], batches: Iterator[Any],
               config: TrainConfig, *, ema: bool = True,
               validate: Callable[[nn.Module], float] | None = None,
               on_validation: Callable[[int, float, nn.Module], None] | None = None,
               stage: str = "training", progress: bool = False) -> TrainResult:
    """The package's one training loop: ``config.steps`` steps of
    ``loss_fn(next(batches))`` (a scalar) minimised by AdamW (``make_adamw``: ``lr``,
    ``weight_decay``, ``fused_adamw``), the gradient norm clipped at ``grad_clip`` (None: no
    clip), under ``autocast`` when set, with ``num_threads`` torch threads (restored after).

    Every draw is the family's: ``batches`` (its batch source) and ``loss_fn`` (noise,
    timesteps, dropout) take them from the family's own generators in the order they always
    did; the loop draws nothing. With ``ema`` an exponential moving average of the weights is
    kept (``ema_decay``, warm-up ``ema_warmup``; ``ema_decay_at``) and is what ``validate``
    measures; without it ``TrainResult.ema_model`` is the model itself. With
    ``config.validate_every`` set, ``validate`` (required then) gives the held-out loss after
    0, k, 2k, … steps and after the last, ``on_validation(steps_done, loss, weights)`` is
    called after each, and the plateau criterion may stop the run early (module docstring).
    A non-finite loss raises ``FloatingPointError``. The step is reported to the runner as
    ``stage`` (``infra.progress``); a bar is shown when ``progress`` and stderr is a terminal.
    The model is left in eval mode.
    """
    if (config.validate_every is None) != (validate is None):
        raise ValueError("pass a validation set exactly when config.validate_every is set")
    device = next(model.parameters()).device
    model.train()
    ema_model = copy.deepcopy(model).eval().requires_grad_(False) if ema else model
    optimizer = make_adamw(model.parameters(), lr=config.lr, weight_decay=config.weight_decay,
                           fused=config.fused_adamw)
    schedule = None if config.lr_schedule is None else torch.optim.lr_scheduler.LambdaLR(
        optimizer, lambda step: learning_rate_factor(config.lr_schedule, step, config.steps))
    autocast_dtype = config.autocast_dtype
    plateau = PlateauCriterion(config.patience, config.min_delta)
    curve: list[tuple[int, float]] = []
    converged = False

    def validate_at(steps_done: int) -> bool:
        assert validate is not None
        with autocast_context(device, autocast_dtype):
            loss = validate(ema_model)
        curve.append((steps_done, loss))
        if on_validation is not None:
            on_validation(steps_done, loss, ema_model)
        return plateau.update(steps_done, loss)

    previous_threads = torch.get_num_threads()
    if config.num_threads is not None:
        torch.set_num_threads(config.num_threads)

    from tqdm import tqdm  # text bar: no ipywidgets here, and it shows on a terminal only

    bar = tqdm(total=config.steps, desc="training", leave=False,
               disable=not (progress and sys.stderr.isatty()))
    losses: list[float] = []
    start = time.perf_counter()
    try:
        if validate is not None:
            validate_at(0)
        for step in range(config.steps):
            batch = next(batches)
            with autocast_context(device, autocast_dtype):
                loss = loss_fn(batch)
            if not torch.isfinite(loss):
                raise FloatingPointError(f"{stage}: the loss became {loss.item()} at step "
                                         f"{step}")
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            if config.grad_clip is not None:
                nn.utils.clip_grad_norm_(model.parameters(), config.grad_clip, foreach=True)
            optimizer.step()
            if schedule is not None:
                schedule.step()
            if ema:
                _update_ema(ema_model, model,
                            ema_decay_at(step, config.ema_decay, config.ema_warmup))
            losses.append(loss.item())
            bar.update(1)
            if step % 50 == 0:
                bar.set_postfix(loss=f"{losses[-1]:.4f}")
            run_progress.report(stage, step + 1, config.steps, loss=losses[-1])
            if validate is not None and config.validate_every is not None and (
                    (step + 1) % config.validate_every == 0 or step + 1 == config.steps):
                if validate_at(step + 1):
                    converged = True
                    break
    finally:
        bar.close()
        if config.num_threads is not None:
            torch.set_num_threads(previous_threads)
    seconds = time.perf_counter() - start
    model.eval()
    convergence = None if validate is None else ConvergenceRecord(
        validation=curve, steps_used=len(losses), step_cap=config.steps, converged=converged,
        best_step=plateau.best_step, best_loss=plateau.best)
    return TrainResult(model=model, ema_model=ema_model, losses=losses, seconds=seconds,
                       convergence=convergence)


def train_diffusion(model: nn.Module | Callable[[], nn.Module], diffusion: GaussianDiffusion,
                    data: Tensor | Iterable[Any], config: TrainConfig, *,
                    cond: Tensor | None = None, mask: Tensor | None = None,
                    cond_choices: bool = False,
                    validation: ValidationSet | None = None,
                    on_validation: Callable[[int, float, nn.Module], None] | None = None,
                    progress: bool = True) -> TrainResult:
    """Minimise ``diffusion.training_losses`` (simple MSE on x0 or ε) for ``config.steps``
    with ``train_loop`` (EMA on).

    Deterministic given ``config.seed`` (on one device/thread count): the model's
    initialisation uses ``torch.manual_seed(seed)`` when ``model`` is a factory, and batches,
    timesteps, noise and condition dropout come from one ``torch.Generator(seed)``.
    With ``config.validate_every`` set, ``validation`` (required then) is evaluated on the EMA
    weights after 0, k, 2k, … steps and after the last one (``validation_loss``), and training
    stops early when the plateau criterion fires (module docstring); the result's
    ``convergence`` records it. ``on_validation(steps_done, loss, ema_model)`` is called after
    each evaluation (e.g. a pilot measuring samples of the EMA weights on the way; it must not
    train them, and it draws nothing from the training generator, so the run is the same with
    or without it). The progress bar is shown only when ``progress`` is true and stderr is a
    terminal. With ``cond_choices`` a tensor ``cond`` (N, K, …) holds K alternative conditions
    per example, one drawn per example and batch (HumanML3D's loader drawing one caption).
    """
    device = torch.device(config.device)
    torch.manual_seed(config.seed)
    if not isinstance(model, nn.Module):
        model = model()
        if not isinstance(model, nn.Module):
            raise ValueError("model must be an nn.Module or a factory returning one")
    model = model.to(device)

    generator = torch.Generator().manual_seed(config.seed)
    if isinstance(data, Tensor):
        if data.dim() < 2 or data.shape[0] < 1:
            raise ValueError(f"data must be (N, C, T), got shape {tuple(data.shape)}")
        for name, extra in (("cond", cond), ("mask", mask)):
            if extra is not None and extra.shape[0] != data.shape[0]:
                raise ValueError(f"{name} has {extra.shape[0]} rows but data has {data.shape[0]}")
        if cond_choices and (cond is None or cond.dim() < 3):
            raise ValueError("cond_choices needs a cond of shape (N, K, …)")
        batches = _tensor_batches(data, cond, mask, config.batch_size, generator,
                                  cond_choices=cond_choices)
    else:
        if cond is not None or mask is not None:
            raise ValueError("with a data loader, put cond and mask in its batches")
        batches = _loader_batches(data)

    feature_weights = (None if config.feature_weights is None
                       else torch.tensor(config.feature_weights, device=device))
    sampler = UniformSampler(diffusion.num_timesteps)

    def loss_fn(batch: dict[str, Tensor]) -> Tensor:
        x0 = batch["x"].to(device)
        b = x0.shape[0]
        t = sampler.sample(b, generator=generator, device=device)
        noise = torch.randn(x0.shape, generator=generator, dtype=x0.dtype).to(device)
        model_kwargs: dict[str, Any] = {}
        if batch.get("cond") is not None:
            model_kwargs["cond"] = batch["cond"].to(device)
            if config.cond_dropout > 0:
                keep = torch.rand(b, generator=generator) >= config.cond_dropout
                model_kwargs["cond_mask"] = keep.to(device)
        batch_mask = batch.get("mask")
        return diffusion.training_losses(
            model, x0, t, model_kwargs=model_kwargs, noise=noise,
            feature_weights=feature_weights,
            mask=None if batch_mask is None else batch_mask.to(device)).mean()

    validate = None
    if validation is not None:
        pairs = validation.pairs(diffusion.num_timesteps, config.validation_timesteps,
                                 config.seed + VALIDATION_SEED_OFFSET)

        def validate(weights: nn.Module) -> float:
            return validation_loss(weights, diffusion, pairs, batch_size=config.batch_size,
                                   device=device, feature_weights=feature_weights)

    return train_loop(model, loss_fn, batches, config, validate=validate,
                      on_validation=on_validation, stage="training diffusion model",
                      progress=progress)


@contextlib.contextmanager
def torch_threads(threads: int | None) -> Iterator[None]:
    """Run the block with ``torch.set_num_threads(threads)`` (None: unchanged), then restore.

    Speed only, never a result: the EnergyMoGen notebooks 07/08 use 1 (with widths of 64 a
    second thread gains little, and on cores shared with other processes we measured 2
    threads 10–30× *slower*, spin-waits).
    """
    previous = torch.get_num_threads()
    if threads is not None:
        torch.set_num_threads(int(threads))
    try:
        yield
    finally:
        torch.set_num_threads(previous)
