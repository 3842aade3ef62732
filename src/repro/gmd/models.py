"""Tiny GMD's models: the paper's settings, specs, text conditioning, cached training.

GMD (appendix D–F; REFERENCE.md "GMD") trains a *trajectory* DPM on the 4 root features
(angle, x, z, y) and a *motion* DPM on all 263, both 1D UNets with AdaGN. Here
``GMDModelSpec`` → ``load_or_train_gmd``: a ``models.unet.UNet1D`` trained by
``training.train_diffusion``, cached by ``cache.load_or_train`` under a hash of the spec *and*
a fingerprint of the training windows (so a real-data run never loads stand-in weights).
Everything is scaled down to run on 2 CPU cores.

The settings several notebooks share (architectures, diffusion steps T, the guidance stop
step, the x̂0 clamp) are stated once at the top, each a fact of GMD's paper or code or a
registered choice of this package, so the models one notebook trains are the ones another
loads (one cache key). ``schedule_diffusion`` builds a model's noise schedule.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor

from repro.core.diffusion import GaussianDiffusion, cosine_betas, linear_betas
from repro.core.training import (
    TRAIN_CONFIG_FIELDS,
    TrainConfig,
    ValidationSet,
    fixed_steps_patience,
    replace_with_training,
    train_diffusion,
)
from repro.gmd.windows import (
    CHANNELS,
    DataConfig,
    DataDir,
    FeatureSpace,
    MotionWindows,
    Representation,
    Task,
    check_task,
    load_windows,
)
from repro.infra import cache, paths
from repro.infra.storage import read_json
from repro.models.unet import UNet1D
from repro.motion.features import FEATURE_DIM, TRAJECTORY_FEATURES
from repro.standin.text import Vocabulary, tokenize

__all__ = ["Architecture", "ConvergenceTraining", "GMDModelSpec", "GUIDANCE_DIFFUSION_STEPS",
           "GUIDANCE_SCHEDULE", "GUIDANCE_STOP_T", "GuidanceModels", "MIN_GOAL_DISTANCE",
           "MOTION_ARCHITECTURE", "MOTION_TRAINING", "QUICK_GUIDANCE_DIFFUSION_STEPS",
           "QUICK_TRAINING", "STANDARD_DIFFUSION_STEPS", "STANDARD_MOTION_ARCHITECTURE",
           "STANDARD_MOTION_TRAINING", "STANDARD_TRAJECTORY_ARCHITECTURE",
           "STANDARD_TRAJECTORY_TRAINING", "TRAJECTORY_ARCHITECTURE", "TRAJECTORY_TRAINING",
           "TrainedGMD", "VALIDATION_SPLIT_SEED", "X0_CLAMP", "bag_of_words", "describe",
           "is_cached", "load_or_train_gmd", "load_or_train_many", "longer_run",
           "model_cache_config", "parameter_count", "schedule_diffusion", "training_fields",
           "trajectory_loss_weights", "validation_split"]


# --- GMD's settings that several notebooks share -------------------------------------------------

@dataclass(frozen=True)
class Architecture:
    """A ``models.unet.UNet1D``'s widths: ``base_channels`` × ``channel_mults`` per level."""

    base_channels: int
    channel_mults: tuple[float, ...]

    @property
    def full_resolution_width(self) -> int:
        """The narrowest width at full temporal resolution (the first level's)."""
        return int(self.base_channels * self.channel_mults[0])


#: the guidance experiments (GMD-A3, B2, F1) run GMD's diffusion: T = 1000, cosine schedule.
GUIDANCE_DIFFUSION_STEPS = 1000


GUIDANCE_SCHEDULE = "cosine"


#: GMD stops guidance at t = 20 of T = 1000 (appendix F).
GUIDANCE_STOP_T = 20


#: GMD clamps its ε trajectory model's x̂0 to ±6 (in its normalised units).
X0_CLAMP = 6.0


#: the tiny GMD UNets (set by the design pilots, pilots/pilot_gmd_motion.md and
#: pilots/pilot_gmd_trajectory.jsonl; the motion model's full-resolution width must be at least
#: the 263 features it carries, as GMD's [263 → 1024] is). The trajectory UNet has GMD's own
#: widths [4 → 64, 128, 256]: at 16 × (1, 2, 4) its ε model failed the trajectory gate (root
#: jerk 144 m/s³ against the bound 67.5), at 64 × (1, 2, 4) trained to its plateau it passed
#: (62.5; docs/TRAINING.md).
MOTION_ARCHITECTURE = Architecture(base_channels=288, channel_mults=(1, 0.5, 0.25))


TRAJECTORY_ARCHITECTURE = Architecture(base_channels=64, channel_mults=(1, 2, 4))


#: the standard scale (docs/COMPUTE.md §3–§4, §15–§16; ``make reproduce`` on 2 CPU cores):
#: every GMD model at T = 100 cosine (the guidance stop steps at the same fraction of T,
#: ``guidance_schedule.sampling.model_stop_step``: GMD's 20 of 1000 → 2); the motion UNet
#: 64 × (1, 1) without an input skip (a full-rank input-to-output path passes x_t's noise into
#: an x0 model's output: its samples were jagged, COMPUTE.md §14; without it an ε model must
#: carry 263-d noise through 64 channels — GMD-A4's ε motion arm, trained at this width as the
#: arm its claim predicts worse, COMPUTE.md §21), the trajectory UNet 32 × (1, 2): the first run's
#: 16 × (1, 2) at 1000 steps failed its path-length gate in 9 of 12 records (COMPUTE.md §8); the
#: wider net passes at 1000 steps with a margin and costs less than 16 × (1, 2) at the 2000
#: steps that also pass (COMPUTE.md §11). Fixed from pilots, before the standard run that
#: reports with it.
STANDARD_DIFFUSION_STEPS = 100


STANDARD_MOTION_ARCHITECTURE = Architecture(base_channels=64, channel_mults=(1, 1))


STANDARD_TRAJECTORY_ARCHITECTURE = Architecture(base_channels=32, channel_mults=(1, 2))



# --- the noise schedule of a model ---------------------------------------------------------------

def schedule_diffusion(schedule: Literal["cosine", "linear"], num_timesteps: int = 1000,
                       prediction: Literal["x0", "epsilon"] = "epsilon") -> GaussianDiffusion:
    """The diffusion of a named schedule (GMD: cosine, T = 1000)."""
    if schedule not in ("cosine", "linear"):
        raise ValueError(f"schedule must be 'cosine' or 'linear', got {schedule!r}")
    betas = (cosine_betas if schedule == "cosine" else linear_betas)(num_timesteps)
    return GaussianDiffusion(betas, prediction)



# --- specs, text conditioning, cached training ---------------------------------------------------

#: 2: ``build_model`` seeds the initialisation (before, it drew from the process's global RNG,
#: so a model's weights depended on what the process had drawn before, not on its seed alone).
_CACHE_VERSION = 2


#: the validation fraction of a spec without convergence training
_DEFAULT_VALIDATION_FRACTION = 0.05


#: the held-out clips are drawn with this seed, whatever the model's seed (so both arms of a
#: comparison, and every seed, validate on the same windows)
VALIDATION_SPLIT_SEED = 0


@dataclass(frozen=True)
class ConvergenceTraining:
    """How a family is trained to convergence (``core.training``, docs/TRAINING.md): AdamW at
    ``lr`` with ``batch_size``, the held-out loss every ``validate_every`` steps, stop after
    ``patience`` evaluations without a 1 % gain, at most ``step_cap`` steps; ``autocast``
    "bfloat16" trains under bf16 autocast (``TrainConfig.autocast``), None in fp32."""

    batch_size: int
    lr: float
    validate_every: int
    patience: int
    step_cap: int
    autocast: str | None = None


#: full-mode motion models (``MOTION_ARCHITECTURE``), from the design pilot
#: (pilots/pilot_gmd_motion*.md): lr 3e-4 skated less than 1e-3 at every check (150–600 steps);
#: batch 32 and 64 were alike per CPU-second. Cap 12000, as the trajectory family's, so that the
#: plateau decides: at a 4000-step cap notebook 01's motion models stopped on the cap with the
#: held-out loss still falling 3 % per 1000 steps (docs/TRAINING.md point 9).
#: bf16 autocast (pilots/pilot_bf16_motion.md): 1.7-2.1x faster on an AMX CPU, with
#: the held-out loss within 0.13 % of fp32's and the gate values within their noise (a rule
#: written before the runs); on a CPU without AMX it is slower (0.69-0.98x, README).
MOTION_TRAINING = ConvergenceTraining(batch_size=64, lr=3e-4, validate_every=200, patience=5,
                                      step_cap=12000, autocast="bfloat16")


#: full-mode trajectory models: at 64 × (1, 2, 4) the ε model was still improving at a 4000-step
#: cap and stopped on its plateau at 6700 of 12000 (docs/TRAINING.md, trajectory pilots).
TRAJECTORY_TRAINING = ConvergenceTraining(batch_size=64, lr=1e-3, validate_every=100,
                                          patience=5, step_cap=12000)


#: the standard scale's motion models (docs/COMPUTE.md §15: on the locomotion stand-in the x0
#: reference arm passes every sample gate on three seeds at 4500 steps, none at 3000): a fixed
#: 4500 steps × batch 32, lr 1e-3, fp32 (bf16 does not pay on a CPU without AMX, COMPUTE.md
#: §1), validated every 500 steps without the plateau stop, so both arms of every comparison
#: share the same budget.
STANDARD_MOTION_TRAINING = ConvergenceTraining(
    batch_size=32, lr=1e-3, validate_every=500, patience=fixed_steps_patience(4500, 500),
    step_cap=4500)


#: the standard scale's trajectory models (COMPUTE.md §4 item 2: both arms pass from 300
#: steps): a fixed 1000 steps × batch 32, lr 1e-3, fp32, validated every 100 steps.
STANDARD_TRAJECTORY_TRAINING = ConvergenceTraining(
    batch_size=32, lr=1e-3, validate_every=100, patience=fixed_steps_patience(1000, 100),
    step_cap=1000)


#: quick mode (a test of the code): validate every 5 steps, stop after 2 without a gain.
QUICK_TRAINING = ConvergenceTraining(batch_size=32, lr=1e-3, validate_every=5, patience=2,
                                     step_cap=20)


def bag_of_words(vocabulary: Vocabulary, captions: Sequence[str | Sequence[str]]) -> Tensor:
    """Text condition (B, V): word counts of each caption over the vocabulary, divided by the
    caption's number of words; a list of captions for one item gives their mean."""
    rows = []
    for item in captions:
        options = [item] if isinstance(item, str) else list(item)
        vector = np.zeros(len(vocabulary), dtype=np.float32)
        for caption in options:
            words = tokenize(caption)
            for word in words:
                vector[vocabulary.id(word)] += 1.0 / max(len(words), 1) / len(options)
        rows.append(vector)
    return torch.from_numpy(np.stack(rows))


def caption_alternatives(vocabulary: Vocabulary, captions: Sequence[Sequence[str]]) -> Tensor:
    """Text conditions (N, K, V): the bag of words of each of an item's captions, K the most
    any item has (an item with fewer repeats its own in turn), for a loader that draws one
    caption per item at every batch (``core.training``: a cond of shape (N, K, D))."""
    k = max(len(options) for options in captions)
    if k == 0:
        raise ValueError("an item has no caption")
    rows = []
    for options in captions:
        if not options:
            raise ValueError("an item has no caption")
        rows.append(bag_of_words(vocabulary, [options[i % len(options)] for i in range(k)]))
    return torch.stack(rows)


def trajectory_loss_weights(k: float, channels: int = FEATURE_DIM) -> list[float]:
    """GMD's trajectory loss scaling (appendix C.1, Eq. 5): weight k² on features 0:4."""
    weights = [1.0] * channels
    for i in range(TRAJECTORY_FEATURES.start, min(TRAJECTORY_FEATURES.stop, channels)):
        weights[i] = float(k) ** 2
    return weights


#: GMD's training defaults (a spec's ``training``): AdamW at lr 1e-3, weight decay 0.01, batch
#: 64, gradient clip 1, EMA 0.9999 with warm-up, 1000 steps, seed 0; a text-conditioned model
#: drops its condition 10 % of the time (``cond_dropout``: ``train_diffusion`` drops only a
#: condition it is given, and a spec without text leaves it out of its key)
GMD_TRAINING = TrainConfig(steps=1000, batch_size=64, lr=1e-3, weight_decay=0.01,
                           ema_decay=0.9999, cond_dropout=0.1)


#: the spec's key names of ``TrainConfig`` fields (the names before the spec held one)
_KEY_NAMES = {"steps": "train_steps"}


#: ``TrainConfig`` fields in the spec's key as they always were (the rest: only when changed)
_KEYED_TRAINING = ("steps", "batch_size", "lr", "weight_decay", "ema_decay", "seed",
                   "feature_weights")


@dataclass(frozen=True)
class GMDModelSpec:
    """Everything that decides a trained tiny GMD model (with the data fingerprint: its key).

    ``task`` "trajectory" (4 channels) or "motion" (263); ``prediction`` "x0" or "epsilon";
    ``data`` the windows; the UNet is ``UNet1D(C, base_channels, channel_mults)``; the
    diffusion has ``diffusion_steps`` steps of the ``schedule``; ``training`` the optimisation
    (``core.training.TrainConfig``, :data:`GMD_TRAINING` by default): its ``feature_weights``
    (C,) weigh the squared error per channel (GMD's loss scaling k²,
    ``trajectory_loss_weights``). ``text_conditioned`` adds a bag-of-words caption condition
    (dropped with probability ``training.cond_dropout`` for classifier-free use).

    Convergence (docs/TRAINING.md): with ``training.validate_every`` set, the
    windows of a held-out ``validation_fraction`` of the *training-split* clips
    (``validation_split``; never the test windows the claims measure on) are left out of
    training, the EMA weights' loss on them is measured every ``validate_every`` steps, and
    training stops when it has not improved by a relative ``min_delta`` for ``patience``
    evaluations; ``training.steps`` is then the cap. Without ``validate_every`` these fields
    leave the key (every earlier key holds).
    """

    task: Task = "trajectory"
    prediction: Literal["x0", "epsilon"] = "epsilon"
    data: DataConfig = field(default_factory=DataConfig)
    base_channels: int = 16
    channel_mults: tuple[float, ...] = (1, 2, 4)
    diffusion_steps: int = 100
    schedule: Literal["cosine", "linear"] = "cosine"
    training: TrainConfig = GMD_TRAINING
    text_conditioned: bool = False
    validation_fraction: float = _DEFAULT_VALIDATION_FRACTION
    #: ``UNet1D(input_skip=True)``: a full-rank input-to-output path (in the key only when set)
    input_skip: bool = False
    #: the caption condition of a training window: "mean" of its captions' bags of words, or
    #: "one" of its captions drawn afresh at every batch (HumanML3D's loader; in the key only
    #: when "one" and the model reads text)
    caption_draw: Literal["mean", "one"] = "one"

    def __post_init__(self) -> None:
        check_task(self.task)
        if not isinstance(self.training, TrainConfig):
            raise TypeError(f"training must be a TrainConfig, got {type(self.training).__name__}")
        if not 0.0 < self.validation_fraction < 1.0:
            raise ValueError(f"validation_fraction must be in (0, 1), got "
                             f"{self.validation_fraction}")
        if (self.training.validate_every is None
                and self.validation_fraction != _DEFAULT_VALIDATION_FRACTION):
            raise ValueError("validation_fraction only acts with training.validate_every set")
        if self.prediction not in ("x0", "epsilon"):
            raise ValueError(f"prediction must be 'x0' or 'epsilon', got {self.prediction!r}")
        if self.caption_draw not in ("mean", "one"):
            raise ValueError(f"caption_draw must be 'mean' or 'one', got {self.caption_draw!r}")
        if self.schedule not in ("cosine", "linear"):
            raise ValueError(f"schedule must be 'cosine' or 'linear', got {self.schedule!r}")
        if self.training.device != "cpu" or self.training.num_threads is not None:
            raise ValueError("a spec's training holds no device or threads: load_or_train_gmd "
                             "takes the device")
        object.__setattr__(self, "channel_mults", tuple(float(m) for m in self.channel_mults))
        weights = self.training.feature_weights
        if weights is not None and len(weights) != CHANNELS[self.task]:
            raise ValueError(f"feature_weights needs {CHANNELS[self.task]} values for the "
                             f"{self.task} task, got {len(weights)}")
        if self.data.frames % 2 ** (len(self.channel_mults) - 1):
            raise ValueError(f"frames = {self.data.frames} must be divisible by "
                             f"2**(len(channel_mults) - 1) = {2 ** (len(self.channel_mults) - 1)}")

    @property
    def channels(self) -> int:
        return CHANNELS[self.task]

    def replace(self, **changes: Any) -> GMDModelSpec:
        """A copy with some fields changed (``core.training.replace_with_training``: a
        ``TrainConfig`` field name such as ``seed`` or ``steps`` changes ``training``'s)."""
        return replace_with_training(self, **changes)

    def as_dict(self) -> dict[str, Any]:
        """The spec's part of the cache key: its fields with ``training``'s flattened under
        their names from before the spec held a ``TrainConfig`` (``steps`` as ``train_steps``;
        ``cond_dropout`` only for a text-conditioned model, the convergence fields only with
        ``validate_every``, ``autocast`` and ``input_skip`` only when set, any other training
        field only when it differs from its default), so every earlier key holds."""
        training = self.training
        config = {"task": self.task, "prediction": self.prediction,
                  "data": self.data.as_dict(), "base_channels": self.base_channels,
                  "channel_mults": self.channel_mults, "diffusion_steps": self.diffusion_steps,
                  "schedule": self.schedule, "text_conditioned": self.text_conditioned}
        for name in _KEYED_TRAINING:
            config[_KEY_NAMES.get(name, name)] = getattr(training, name)
        if self.text_conditioned:
            config["cond_dropout"] = training.cond_dropout
        if training.validate_every is not None:
            config.update(validate_every=training.validate_every, patience=training.patience,
                          min_delta=training.min_delta,
                          validation_fraction=self.validation_fraction)
        if training.autocast is not None:
            config["autocast"] = training.autocast
        if self.input_skip:
            config["input_skip"] = True
        if self.text_conditioned and self.caption_draw != "mean":
            config["caption_draw"] = self.caption_draw
        unlisted = set(_KEYED_TRAINING) | {"cond_dropout", "validate_every", "patience",
                                           "min_delta", "autocast", "device", "num_threads"}
        for name in sorted(TRAIN_CONFIG_FIELDS - unlisted):
            value = getattr(training, name)
            if value != getattr(GMD_TRAINING, name):
                config[name] = value
        if config["feature_weights"] is not None:
            config["feature_weights"] = tuple(config["feature_weights"])
        return config

    def diffusion(self) -> GaussianDiffusion:
        return schedule_diffusion(self.schedule, self.diffusion_steps, self.prediction)

    def build_model(self, cond_dim: int | None = None) -> UNet1D:
        """The untrained UNet, initialised from ``torch.manual_seed(seed)`` in a forked RNG: the
        same weights whatever the process drew before, and the caller's global RNG untouched."""
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(self.training.seed)
            return UNet1D(self.channels, self.base_channels, self.channel_mults,
                          cond_dim=cond_dim, input_skip=self.input_skip)

    def train_config(self, device: str | torch.device = "cpu") -> TrainConfig:
        """``training`` on ``device``, without the condition dropout of a model that has no
        condition (it would drop nothing)."""
        return dataclasses.replace(
            self.training, device=str(device),
            cond_dropout=self.training.cond_dropout if self.text_conditioned else 0.0)


@dataclass
class TrainedGMD:
    """A trained model (the EMA weights, eval mode), its diffusion and its feature space."""

    model: UNet1D
    diffusion: GaussianDiffusion
    space: FeatureSpace
    spec: GMDModelSpec
    vocabulary: Vocabulary | None = None
    metrics: dict[str, Any] = field(default_factory=dict)
    cache_key: str = ""
    #: max |x| over the training windows' model channels: the default clamp on x̂0 in sampling
    x0_bound: float | None = None

    @property
    def device(self) -> torch.device:
        return next(self.model.parameters()).device

    @property
    def num_timesteps(self) -> int:
        return self.diffusion.num_timesteps

    def text_condition(self, text: str | Sequence[str], n: int) -> Tensor:
        """Bag-of-words conditions (n, V) for one caption or n captions."""
        if self.vocabulary is None:
            raise ValueError("this model is not text-conditioned")
        captions = [text] * n if isinstance(text, str) else list(text)
        if len(captions) != n:
            raise ValueError(f"need 1 or {n} captions, got {len(captions)}")
        return bag_of_words(self.vocabulary, captions).to(self.device)


def training_fields(task: Task, *, scale: str, step_cap: int | None = None,
                    seed: int = 0) -> dict[str, Any]:
    """The architecture fields and the ``training`` (seeded with ``seed``) of a notebook's
    ``GMDModelSpec`` of ``task`` at ``scale``, a scale its settings constructor checked
    (docs/COMPUTE.md; any other is a KeyError).

    - ``paper``: ``models``' architecture of the family and its ``ConvergenceTraining``
      (batch, lr, validation interval, patience, autocast, step cap; ``step_cap`` overrides the
      cap): today's registered full settings, the same keys.
    - ``standard``: the family's standard architecture and ``STANDARD_*_TRAINING``: a fixed
      step count (``step_cap`` overrides it), validated but never stopped on a plateau, fp32.
    - ``quick``: only the convergence path (``QUICK_TRAINING``: validate every few steps,
      short patience) on the notebook's own tiny model, whose step count (``step_cap``,
      required) is the cap."""
    check_task(task)
    families = _SCALE_FAMILIES[scale]
    if families is None:
        if step_cap is None:
            raise ValueError("quick mode needs the notebook's step count as step_cap")
        return {"training": dataclasses.replace(
            GMD_TRAINING, steps=int(step_cap), validate_every=QUICK_TRAINING.validate_every,
            patience=QUICK_TRAINING.patience, seed=int(seed))}
    architecture, plan = families[task]
    steps = plan.step_cap if step_cap is None else int(step_cap)
    patience = (fixed_steps_patience(steps, plan.validate_every) if scale == "standard"
                else plan.patience)
    training = dataclasses.replace(GMD_TRAINING, steps=steps, batch_size=plan.batch_size,
                                   lr=plan.lr, validate_every=plan.validate_every,
                                   patience=patience, autocast=plan.autocast, seed=int(seed))
    return {"base_channels": architecture.base_channels,
            "channel_mults": architecture.channel_mults, "training": training}


#: per scale, each task's architecture and training plan (quick: None, the notebook's own tiny
#: model on ``QUICK_TRAINING``)
_SCALE_FAMILIES: dict[str, dict[str, tuple[Architecture, ConvergenceTraining]] | None] = {
    "quick": None,
    "standard": {"motion": (STANDARD_MOTION_ARCHITECTURE, STANDARD_MOTION_TRAINING),
                 "trajectory": (STANDARD_TRAJECTORY_ARCHITECTURE, STANDARD_TRAJECTORY_TRAINING)},
    "paper": {"motion": (MOTION_ARCHITECTURE, MOTION_TRAINING),
              "trajectory": (TRAJECTORY_ARCHITECTURE, TRAJECTORY_TRAINING)}}


#: the quick scale's T of the guidance experiments' trajectory models (a test of the code, never
#: a result)
QUICK_GUIDANCE_DIFFUSION_STEPS = 50


#: the guidance experiments' goals are end positions of test windows whose root travels at least
#: this far (m)
MIN_GOAL_DISTANCE = 0.5


@dataclass(frozen=True)
class GuidanceModels:
    """The GMD models of one scale that notebook 01 trains and the guidance notebooks load:
    the windows they train on (``stand_in_clips`` clips cut into ``frames``-frame windows, or
    a data folder's), their training (``train_steps``: the step cap, or count at the standard
    scale; None: each family's, ``training_fields``), their T, and the goals guidance reaches
    for (``min_goal_distance``).

    :meth:`spec` is one of the four models (trajectory/motion × x0/ε); :meth:`guidance_
    trajectory_spec` the trajectory model of the guidance experiments (GMD-A3, F1; GMD's
    T = ``guidance_diffusion_steps`` cosine). One spec here is one cache key for every notebook
    that builds it."""

    scale: str
    stand_in_clips: int
    frames: int
    train_steps: int | None
    batch_size: int
    diffusion_steps: int
    #: T of the guidance experiments' trajectory models (GMD's 1000; standard 100; quick 50)
    guidance_diffusion_steps: int
    min_goal_distance: float = MIN_GOAL_DISTANCE

    @classmethod
    def for_scale(cls, scale: str, *, train_steps: int | None = None) -> GuidanceModels:
        """The models of ``scale``, a scale its notebook's settings constructor checked (any
        other is a KeyError). Paper: 48-frame windows of the 2000-clip stand-in set, batch 64,
        T = 100 (guidance T = 1000). Standard: batch 32, T = 100 for every model (so the
        guidance trajectory models are the T = 100 trajectory models). Quick: 24-frame windows
        of 120 clips, 20 steps (``train_steps`` None), T = 20 (guidance 50)."""
        steps = None if train_steps is None else int(train_steps)
        table: dict[str, dict[str, Any]] = {
            "quick": {"stand_in_clips": 120, "frames": 24,
                      "train_steps": 20 if steps is None else steps, "batch_size": 32,
                      "diffusion_steps": 20,
                      "guidance_diffusion_steps": QUICK_GUIDANCE_DIFFUSION_STEPS},
            "standard": {"stand_in_clips": 2000, "frames": 48, "train_steps": steps,
                         "batch_size": 32, "diffusion_steps": STANDARD_DIFFUSION_STEPS,
                         "guidance_diffusion_steps": STANDARD_DIFFUSION_STEPS},
            "paper": {"stand_in_clips": 2000, "frames": 48, "train_steps": steps,
                      "batch_size": 64, "diffusion_steps": 100,
                      "guidance_diffusion_steps": GUIDANCE_DIFFUSION_STEPS}}
        return cls(scale=scale, **table[scale])

    def data(self, data_dir: DataDir = None,
             representation: Representation = "absolute") -> DataConfig:
        """The windows (``data_dir`` or the stand-in set) in ``representation``: absolute
        root by default, the trajectory models'."""
        if data_dir is not None:
            return DataConfig(data_dir=data_dir, frames=self.frames,
                              representation=representation)
        return DataConfig(stand_in_clips=self.stand_in_clips, frames=self.frames,
                          representation=representation)

    def spec(self, task: Task, prediction: Literal["x0", "epsilon"], data: DataConfig,
             seed: int = 0) -> GMDModelSpec:
        """One of the four models (trajectory/motion × x0/ε): x0 and ε of a task share the
        architecture and the training budget (:func:`training_fields`, ``train_steps`` the
        cap). Below the paper scale the motion models are text-conditioned (notebook 02's
        GMD-B3 relative-root model is notebook 01's x0 motion model, one cache key;
        docs/COMPUTE.md §3d), sampled with the null condition where a claim reads the
        unconditional model; the paper scale's are unconditional."""
        fields = training_fields(task, scale=self.scale, step_cap=self.train_steps, seed=seed)
        spec = GMDModelSpec(task=task, prediction=prediction, data=data,
                            diffusion_steps=self.diffusion_steps, **fields)
        return spec.replace(batch_size=self.batch_size,
                            text_conditioned=task == "motion" and self.scale != "paper")

    def guidance_trajectory_spec(self, prediction: Literal["x0", "epsilon"], data: DataConfig,
                                 seed: int = 0) -> GMDModelSpec:
        """The trajectory model of the guidance experiments (GMD-A3 in notebook 01, GMD-F1 in
        06, GMD-B2 in 02: one cache key): ``spec("trajectory", …)`` with GMD's diffusion,
        T = ``guidance_diffusion_steps`` (1000) and the ``GUIDANCE_SCHEDULE`` (cosine)."""
        return self.spec("trajectory", prediction, data, seed).replace(
            diffusion_steps=self.guidance_diffusion_steps, schedule=GUIDANCE_SCHEDULE)


def longer_run(spec: GMDModelSpec, factor: int = 2) -> GMDModelSpec:
    """``spec`` trained ``factor``× its step cap without the plateau stop (the patience
    outlasts the run), still validated so its curve is recorded: GMD-A4's longer ε run, which
    shows whether the ε arm converges later than the budget both arms share."""
    validate_every = spec.training.validate_every
    if validate_every is None:
        raise ValueError("longer_run needs a spec trained with validation (validate_every)")
    steps = int(factor) * spec.training.steps
    return spec.replace(steps=steps, patience=fixed_steps_patience(steps, validate_every))


def validation_split(data: MotionWindows, fraction: float) -> tuple[Tensor, Tensor]:
    """(training indices, validation indices) of ``data``'s windows: every window of a
    ``fraction`` of its clips (at least one clip, at least one left to train on), drawn with
    ``VALIDATION_SPLIT_SEED`` among the clips in sorted order. Whole clips are held out,
    because overlapping windows of one clip would leak into the held-out loss."""
    clips = [window_id.rsplit(":", 1)[0] for window_id in data.ids]
    unique = sorted(set(clips))
    if len(unique) < 2:
        raise ValueError(f"need at least 2 training clips to hold one out, have {len(unique)}")
    held_count = min(len(unique) - 1, max(1, int(round(fraction * len(unique)))))
    order = np.random.default_rng(VALIDATION_SPLIT_SEED).permutation(len(unique))
    held = {unique[k] for k in order[:held_count]}
    is_held = torch.tensor([clip in held for clip in clips])
    return torch.nonzero(~is_held).flatten(), torch.nonzero(is_held).flatten()


def model_cache_config(spec: GMDModelSpec, data: MotionWindows) -> dict[str, Any]:
    """What a trained model's cache key covers: the spec and the training windows' content."""
    return {"spec": spec.as_dict(), "data_fingerprint": data.fingerprint,
            "version": _CACHE_VERSION}


def load_or_train_gmd(spec: GMDModelSpec, data: MotionWindows | None = None, *,
                      device: str | torch.device = "cpu", retrain: bool = False,
                      progress: bool = False,
                      on_validation: Callable[[int, float, torch.nn.Module], None] | None = None,
                      ) -> TrainedGMD:
    """The trained model of ``spec`` from the cache (kind ``gmd_<task>``), trained on a miss.

    ``data`` are the training windows of ``spec.data`` (loaded when None; pass them to avoid
    reloading). Deterministic given ``spec.training.seed``; the same code runs on ``device="cuda"``.
    ``on_validation`` goes to ``train_diffusion`` on a miss (a pilot measuring the EMA weights
    at each held-out evaluation); it does not change the training, so it is not in the key.
    """
    if data is None:
        data = load_windows(spec.data)
    if data.config != spec.data or data.split != "train":
        raise ValueError(f"data are the {data.split!r} windows of {data.config}, but the spec "
                         f"trains on the 'train' windows of {spec.data}")
    device = torch.device(device)
    vocabulary = data.vocabulary if spec.text_conditioned else None
    cond_dim = len(vocabulary) if vocabulary is not None else None
    config = model_cache_config(spec, data)
    kind = f"gmd_{spec.task}"
    diffusion = spec.diffusion()

    def train(model: torch.nn.Module) -> tuple[torch.nn.Module, dict[str, Any]]:
        x = data.channels(spec.task).contiguous()
        choices = vocabulary is not None and spec.caption_draw == "one"
        cond = None
        if choices:
            cond = caption_alternatives(vocabulary, data.captions)
        elif vocabulary is not None:
            cond = bag_of_words(vocabulary, data.captions)
        validation = None
        if spec.training.validate_every is not None:
            fit, held = validation_split(data, spec.validation_fraction)
            held_cond = None if cond is None else cond[held]
            if choices:
                held_cond = held_cond[:, 0]          # a fixed caption per held-out window
            validation = ValidationSet(x[held], cond=held_cond)
            x, cond = x[fit].contiguous(), None if cond is None else cond[fit]
        result = train_diffusion(model, diffusion, x, spec.train_config(device), cond=cond,
                                 cond_choices=choices,
                                 validation=validation, on_validation=on_validation,
                                 progress=progress)
        return result.for_cache()

    model = cache.load_or_train(kind, config, lambda: spec.build_model(cond_dim), train,
                                device=device, retrain=retrain)
    stored = cache.cached_artifact_dir(kind, config) / "metrics.json"
    train_metrics = read_json(stored) if stored.exists() else {}
    bound = float(data.channels(spec.task).abs().max())
    return TrainedGMD(model.requires_grad_(False), diffusion, data.space(spec.task), spec,
                      vocabulary, train_metrics, cache.config_hash(config), bound)


def is_cached(spec: GMDModelSpec, data: MotionWindows) -> bool:
    """Whether ``load_or_train_gmd(spec, data)`` would load instead of train."""
    config = model_cache_config(spec, data)
    return (paths.cache_dir() / f"gmd_{spec.task}" / cache.config_hash(config)
            / "model.pt").is_file()


_WORKER_DATA: dict[DataConfig, MotionWindows] = {}


def _train_in_worker(spec: GMDModelSpec, fingerprint: str) -> str:
    torch.set_num_threads(1)
    data = _WORKER_DATA.get(spec.data)
    if data is None:
        data = _WORKER_DATA.setdefault(spec.data, load_windows(spec.data))
    if data.fingerprint != fingerprint:
        raise ValueError(f"a worker loaded different windows for {spec.data} (fingerprint "
                         f"{data.fingerprint} ≠ {fingerprint}): train these in-process")
    return load_or_train_gmd(spec, data).cache_key


def load_or_train_many(specs: Sequence[GMDModelSpec], data: MotionWindows, *,
                       device: str | torch.device = "cpu", workers: int | None = None,
                       ) -> list[TrainedGMD]:
    """``load_or_train_gmd`` for several specs on the same windows; the models not yet cached
    are trained in ``workers`` processes with one torch thread each (default: as many as
    this process's torch threads; small models use two cores better as two processes than as
    two threads of one). Every model is then loaded from the cache, in ``specs`` order.
    ``data`` must be ``load_windows(spec.data)`` for every spec (checked by fingerprint).
    Workers are spawned: a script calling this needs the ``if __name__ == "__main__":`` guard
    (a notebook does not)."""
    if any(spec.data != data.config for spec in specs):
        raise ValueError("load_or_train_many needs specs that all train on data.config")
    workers = torch.get_num_threads() if workers is None else int(workers)
    missing = [spec for spec in dict.fromkeys(specs) if not is_cached(spec, data)]
    if workers > 1 and len(missing) > 1 and torch.device(device).type == "cpu":
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        from repro.infra.lifetime import die_with_parent

        context = multiprocessing.get_context("spawn")
        # a worker dies with its kernel (an out-of-memory kill included), never outlives it
        with ProcessPoolExecutor(min(workers, len(missing)), mp_context=context,
                                 initializer=die_with_parent) as pool:
            list(pool.map(_train_in_worker, missing, [data.fingerprint] * len(missing)))
    return [load_or_train_gmd(spec, data, device=device) for spec in specs]


def describe(spec: GMDModelSpec) -> str:
    """A one-line summary of a spec for notes and figure titles."""
    mults = ",".join(f"{m:g}" for m in spec.channel_mults)
    training = spec.training
    steps = (f"{training.steps} steps" if training.validate_every is None else
             f"to convergence (held-out loss every {training.validate_every} steps, stop after "
             f"{training.patience} without a {training.min_delta:.0%} gain, cap "
             f"{training.steps} steps)")
    return (f"{spec.task}/{spec.prediction} UNet1D(base {spec.base_channels}, mults [{mults}]), "
            f"T={spec.diffusion_steps} {spec.schedule}, {steps} × batch "
            f"{training.batch_size}, lr {training.lr:g}"
            f"{', bf16 autocast' if training.autocast == 'bfloat16' else ''}, {spec.data.frames} "
            f"frames ({spec.data.representation} root)")


def parameter_count(trained: TrainedGMD) -> int:
    """The number of trainable parameters of the model."""
    return sum(p.numel() for p in trained.model.parameters())
