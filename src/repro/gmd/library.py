"""Tiny GMD: data windows, trajectory/motion diffusion models, guided sampling, measurements.

The shared library of the GMD notebooks (01 x0 vs ε, 02 root representation, 03 Emphasis,
06 guidance schedule). GMD (appendix D–F; REFERENCE.md "GMD") trains a *trajectory* DPM on
the 4 root features (angle, x, z, y) and a *motion* DPM on all 263, both 1D UNets with AdaGN,
with goal functions on x̂0 for guidance. Here everything is scaled down to run on 2 CPU cores.

Data (``DataConfig`` → ``load_windows``): fixed-length windows of ``frames`` frames cut from
the clips of a HumanML3D-layout folder (the generated stand-in set when ``data_dir`` is
None). Each window is converted on its own, so it starts at the origin facing +Z:
``features.relative_to_absolute_root`` for the absolute representation (GMD's), left as is
for the relative one (HumanML3D's). Windows are normalised with the mean and block-averaged
std of the training windows (``data.compute_statistics``) and stored channels-first
``(N, 263, frames)``. The trajectory view is channels 0:4 (``features.TRAJECTORY_FEATURES``).

Models (``GMDModelSpec`` → ``load_or_train_gmd``): ``models.unet.UNet1D`` trained by
``training.train_diffusion``, cached by ``cache.load_or_train`` under a hash of the spec *and*
a fingerprint of the training windows (so a real-data run never loads stand-in weights).

Guidance (``goal_guidance``): GMD's goal functions G on the un-normalised x̂0 — L1 (p = 1),
averaged over the target entries as GMD does — plugged into ``diffusion.Guidance``
(μ̃ = μ − s·Σ_t·∇_{x_t} G(x̂0)). Measurements: goal error, jitter, foot skating and the
survival of a guided change (``guided_change_survival``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor

from repro.core import metrics
from repro.core.diffusion import (
    GaussianDiffusion,
    Guidance,
    Imputation,
    SampleTrajectory,
    cosine_betas,
    linear_betas,
)
from repro.core.training import TrainConfig, train_diffusion
from repro.infra import cache, paths
from repro.infra.storage import read_json
from repro.models.unet import UNet1D
from repro.motion.features import (
    FEATURE_DIM,
    FPS,
    TRAJECTORY_FEATURES,
    absolute_features_to_joints,
    absolute_to_relative_root,
    features_to_joints,
    recover_root,
    relative_to_absolute_root,
)
from repro.motion.humanml3d import MotionDataset, compute_statistics
from repro.motion.skeleton import NUM_JOINTS
from repro.standin.text import Vocabulary, tokenize

__all__ = [
    "DataConfig",
    "FeatureSpace",
    "GMDModelSpec",
    "GoalReachingResult",
    "MotionWindows",
    "TrainedGMD",
    "bag_of_words",
    "coefficient_shares",
    "default_stop_step",
    "describe",
    "evaluator_inputs",
    "foot_skating_of",
    "goal_error",
    "goal_error_kept",
    "goal_guidance",
    "goal_reaching_experiment",
    "goal_reaching_loss",
    "goal_targets",
    "guided_change_survival",
    "is_cached",
    "jitter_of",
    "load_or_train_gmd",
    "load_or_train_many",
    "load_windows",
    "model_cache_config",
    "obstacle_loss",
    "parameter_count",
    "peak_fraction",
    "posterior_mean_forms",
    "printed_c_relative_error",
    "sample",
    "schedule_diffusion",
    "trajectory_loss_weights",
    "waypoint_loss",
]

Task = Literal["trajectory", "motion"]
Representation = Literal["absolute", "relative"]
TASKS = ("trajectory", "motion")
REPRESENTATIONS = ("absolute", "relative")
#: number of model channels per task: the trajectory model sees (angle, x, z, y).
CHANNELS = {"trajectory": TRAJECTORY_FEATURES.stop - TRAJECTORY_FEATURES.start,
            "motion": FEATURE_DIM}
#: GMD stops guidance at t = 20 of T = 1000 (appendix F): 2 % of the steps.
GMD_STOP_FRACTION = 20 / 1000
#: GMD's guidance strength s (appendix F; REFERENCE.md "Guidance").
GMD_GUIDANCE_STRENGTH = 100.0
_CACHE_VERSION = 1


# ---------------------------------------------------------------------------------------------
# Appendix A: the posterior-mean coefficients (Eq. 1–2, Fig. A.1)
# ---------------------------------------------------------------------------------------------


def schedule_diffusion(schedule: Literal["cosine", "linear"], num_timesteps: int = 1000,
                       prediction: Literal["x0", "epsilon"] = "epsilon") -> GaussianDiffusion:
    """The diffusion of a named schedule (GMD: cosine, T = 1000)."""
    if schedule not in ("cosine", "linear"):
        raise ValueError(f"schedule must be 'cosine' or 'linear', got {schedule!r}")
    betas = (cosine_betas if schedule == "cosine" else linear_betas)(num_timesteps)
    return GaussianDiffusion(betas, prediction)


def posterior_mean_forms(diffusion: GaussianDiffusion, *, samples: int = 64,
                         seed: int = 0) -> np.ndarray:
    """max |a·x0 + b·x_t − (c·x_t − d·ε)| per t (T,), float64, for random x_t, ε ~ N(0, I)
    (``samples`` values per t) and x0 = (x_t − √(1−ᾱ_t) ε)/√ᾱ_t (GMD Eq. 1 vs Eq. 2)."""
    generator = torch.Generator().manual_seed(seed)
    steps = diffusion.num_timesteps
    x_t = torch.randn(steps, samples, generator=generator, dtype=torch.float64)
    eps = torch.randn(steps, samples, generator=generator, dtype=torch.float64)
    t = torch.arange(steps)
    x0 = diffusion.predict_x0_from_eps(x_t, t, eps)
    eq1 = diffusion.q_posterior_mean(x0, x_t, t)
    eq2 = diffusion.posterior_mean_from_eps(x_t, eps, t)
    return (eq1 - eq2).abs().amax(dim=1).numpy()


def printed_c_relative_error(diffusion: GaussianDiffusion) -> np.ndarray:
    """|c_printed − c|/c per t, c_printed = a/ᾱ_t + b (Eq. 2 as printed), c = a/√ᾱ_t + b."""
    c = diffusion.eps_mean_coef_xt
    return np.abs(diffusion.eps_mean_coef_xt_as_printed - c) / c


def coefficient_shares(diffusion: GaussianDiffusion) -> dict[str, np.ndarray]:
    """Fig. A.1's curves over t: a, b (Eq. 1), c, d (Eq. 2), the x0 share a/(a+b) and the
    ε share d/(c+d) (the relative shares registered for claim GMD-A2)."""
    a, b = diffusion.posterior_mean_coef_x0, diffusion.posterior_mean_coef_xt
    c, d = diffusion.eps_mean_coef_xt, diffusion.eps_mean_coef_eps
    return {"a": a, "b": b, "c": c, "d": d, "x0_share": a / (a + b), "eps_share": d / (c + d)}


def peak_fraction(values: np.ndarray) -> float:
    """Where a curve over t = 0 … T−1 peaks, as the paper's step (t + 1) divided by T."""
    return float((int(np.argmax(values)) + 1) / len(values))


# ---------------------------------------------------------------------------------------------
# Data: fixed-length windows
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DataConfig:
    """Which windows a model trains on.

    ``data_dir`` is a HumanML3D-layout folder, or None for the generated stand-in set
    (``generator.ensure_dataset(DatasetConfig(n_clips=stand_in_clips, seed=stand_in_seed))``).
    Windows of ``frames`` frames (a multiple of 4) start every ``stride`` frames of each clip;
    clips shorter than ``frames`` give none. ``max_windows`` keeps a random subset (seed 0,
    in clip order) of at most that many *training* windows; other splits are never cut.
    """

    data_dir: str | None = None
    stand_in_clips: int = 2000
    stand_in_seed: int = 0
    frames: int = 48
    stride: int = 24
    representation: Representation = "absolute"
    max_windows: int | None = None

    def __post_init__(self) -> None:
        if self.frames < 4 or self.frames % 4:
            raise ValueError(f"frames must be a positive multiple of 4, got {self.frames}")
        if self.stride < 1:
            raise ValueError(f"stride must be >= 1, got {self.stride}")
        if self.representation not in REPRESENTATIONS:
            raise ValueError(f"representation must be one of {REPRESENTATIONS}, got "
                             f"{self.representation!r}")
        if self.data_dir is None and self.stand_in_clips < 1:
            raise ValueError(f"stand_in_clips must be >= 1, got {self.stand_in_clips}")
        if self.max_windows is not None and self.max_windows < 1:
            raise ValueError(f"max_windows must be >= 1 or None, got {self.max_windows}")

    def as_dict(self) -> dict[str, Any]:
        config = dataclasses.asdict(self)
        if self.max_windows is None:   # keeps the hashes of configs made before the field
            config.pop("max_windows")
        if self.data_dir is not None:
            config["data_dir"] = str(Path(self.data_dir).resolve())
            config.pop("stand_in_clips")
            config.pop("stand_in_seed")
        return config

    def dataset_root(self) -> Path:
        """The folder: ``data_dir``, or the stand-in set (generated on first use, cached)."""
        if self.data_dir is not None:
            return Path(self.data_dir)
        from repro.standin.dataset import DatasetConfig, ensure_dataset

        return ensure_dataset(DatasetConfig(n_clips=self.stand_in_clips,
                                            seed=self.stand_in_seed))


@dataclass(frozen=True)
class FeatureSpace:
    """Model space ↔ world: (B, C, T) normalised channels ↔ un-normalised features, root, joints.

    ``mean``/``std`` are the statistics of the C model channels (C = 4 for the trajectory task,
    263 for the motion task). Every torch method is differentiable (goal functions use them).
    """

    task: Task
    representation: Representation
    mean: np.ndarray
    std: np.ndarray

    @property
    def channels(self) -> int:
        return CHANNELS[self.task]

    def _stats(self, like: Tensor) -> tuple[Tensor, Tensor]:
        mean = torch.as_tensor(self.mean, dtype=like.dtype, device=like.device)
        std = torch.as_tensor(self.std, dtype=like.dtype, device=like.device)
        return mean, std

    def normalise(self, features: Tensor) -> Tensor:
        """Un-normalised features (B, T, C) → model space (B, C, T): (f − mean)/std."""
        mean, std = self._stats(features)
        return ((features - mean) / std).transpose(1, 2)

    def unnormalise(self, x: Tensor) -> Tensor:
        """Model space (B, C, T) → un-normalised features (B, T, C): x·std + mean."""
        if x.dim() != 3 or x.shape[1] != self.channels:
            raise ValueError(f"x must be (B, {self.channels}, T), got {tuple(x.shape)}")
        mean, std = self._stats(x)
        return x.transpose(1, 2) * std + mean

    def _as_263(self, features: Tensor) -> Tensor:
        if features.shape[-1] == FEATURE_DIM:
            return features
        # recover_root reads only the 4 root features: the trajectory task pads the rest
        pad = features.new_zeros(*features.shape[:-1], FEATURE_DIM - features.shape[-1])
        return torch.cat((features, pad), dim=-1)

    def root_positions(self, x: Tensor) -> Tensor:
        """World root positions (B, T, 3) = (x, y, z) of model-space samples (B, C, T).

        Absolute: read from features 1, 3, 2. Relative: ``features.recover_root``."""
        features = self.unnormalise(x)
        if self.representation == "absolute":
            return features[..., [1, 3, 2]]
        _, position = recover_root(self._as_263(features))
        return position

    def root_xz(self, x: Tensor) -> Tensor:
        """World root x/z (B, T, 2) of model-space samples (B, C, T)."""
        return self.root_positions(x)[..., [0, 2]]

    def joints(self, x: Tensor) -> Tensor:
        """Joint positions (B, T, 22, 3) of motion-task samples (B, 263, T)."""
        if self.task != "motion":
            raise ValueError("joints need the motion task (the trajectory task has no body)")
        features = self.unnormalise(x)
        if self.representation == "absolute":
            return absolute_features_to_joints(features)
        return features_to_joints(features)

    def relative_features(self, x: Tensor) -> Tensor:
        """HumanML3D (relative-root) features (B, T, 263) of motion-task samples (B, 263, T),
        e.g. for the evaluator, which reads the relative representation."""
        if self.task != "motion":
            raise ValueError("relative_features needs the motion task")
        features = self.unnormalise(x)
        if self.representation == "absolute":
            return absolute_to_relative_root(features)
        return features

    def as_dict(self) -> dict[str, Any]:
        return {"task": self.task, "representation": self.representation,
                "mean": np.asarray(self.mean).tolist(), "std": np.asarray(self.std).tolist()}


@dataclass
class MotionWindows:
    """Normalised windows ``x`` (N, 263, frames) float32 with their captions.

    ``mean``/``std`` (263,) are the statistics the windows were normalised with (the training
    windows'); ``ids`` are ``"<clip id>:<first frame>"``; ``fingerprint`` hashes the windows,
    captions and statistics (part of every model's cache key).
    """

    config: DataConfig
    split: str
    root: Path
    x: Tensor
    mean: np.ndarray
    std: np.ndarray
    captions: list[list[str]]
    ids: list[str]
    fingerprint: str
    vocabulary: Vocabulary | None = field(repr=False, default=None)

    def __len__(self) -> int:
        return int(self.x.shape[0])

    @property
    def frames(self) -> int:
        return int(self.x.shape[2])

    def trajectory(self) -> Tensor:
        """The trajectory view (N, 4, frames): channels (angle, x, z, y) — in the absolute
        representation the heading half-angle and the world root x, z, y."""
        return self.x[:, TRAJECTORY_FEATURES]

    def channels(self, task: Task) -> Tensor:
        """What a model of ``task`` sees: the trajectory view or all 263 channels."""
        _check_task(task)
        return self.trajectory() if task == "trajectory" else self.x

    def space(self, task: Task) -> FeatureSpace:
        """The ``FeatureSpace`` of a model of ``task`` trained on these windows."""
        _check_task(task)
        picks = TRAJECTORY_FEATURES if task == "trajectory" else slice(None)
        return FeatureSpace(task, self.config.representation, self.mean[picks].copy(),
                            self.std[picks].copy())

    def features(self) -> Tensor:
        """Un-normalised features (N, frames, 263) in the windows' representation."""
        return self.space("motion").unnormalise(self.x)


def _check_task(task: str) -> None:
    if task not in TASKS:
        raise ValueError(f"task must be one of {TASKS}, got {task!r}")


def _cut_windows(dataset: MotionDataset, frames: int,
                 stride: int) -> tuple[list[np.ndarray], list[list[str]], list[str]]:
    pieces, captions, ids = [], [], []
    for index in range(len(dataset)):
        item = dataset[index]
        motion = item["motion"][:item["length"]].numpy()
        for start in range(0, len(motion) - frames + 1, stride):
            pieces.append(motion[start:start + frames])
            captions.append(list(item["captions"]))
            ids.append(f"{item['id']}:{start}")
    return pieces, captions, ids


def _to_representation(windows: np.ndarray, representation: str,
                       chunk: int = 512) -> np.ndarray:
    """Relative windows (N, T, 263) → the representation, each window starting at the origin."""
    if representation == "relative":
        return windows
    out = np.empty_like(windows)
    for start in range(0, len(windows), chunk):
        block = torch.from_numpy(windows[start:start + chunk].astype(np.float64))
        out[start:start + chunk] = relative_to_absolute_root(block).numpy().astype(np.float32)
    return out


def _fingerprint(x: Tensor, captions: list[list[str]], mean: np.ndarray,
                 std: np.ndarray) -> str:
    return cache.fingerprint(x, np.asarray(mean, np.float32), np.asarray(std, np.float32),
                             captions, digits=16)


def load_windows(config: DataConfig, split: str = "train", *,
                 statistics: tuple[np.ndarray, np.ndarray] | None = None) -> MotionWindows:
    """Windows of one split, normalised (channels-first, float32).

    ``statistics`` (mean, std) of the *training* windows must be passed for any other split
    (e.g. ``load_windows(cfg, "test", statistics=(train.mean, train.std))``); when None they
    are computed here — mean and block-averaged std over all frames of these windows
    (``data.compute_statistics``, HumanML3D's convention).
    """
    root = config.dataset_root()
    dataset = MotionDataset(root, split, normalise=False, representation="relative")
    pieces, captions, ids = _cut_windows(dataset, config.frames, config.stride)
    if not pieces:
        raise ValueError(f"no clip of {root}/{split}.txt has {config.frames} frames")
    limit = config.max_windows if split == "train" else None
    if limit is not None and limit < len(pieces):
        keep = np.sort(np.random.default_rng(0).choice(len(pieces), limit, replace=False))
        pieces = [pieces[i] for i in keep]
        captions = [captions[i] for i in keep]
        ids = [ids[i] for i in keep]
    windows = _to_representation(np.stack(pieces).astype(np.float32), config.representation)
    if statistics is None:
        mean, std = compute_statistics([windows.reshape(-1, FEATURE_DIM)])
    else:
        mean, std = (np.asarray(a, dtype=np.float32) for a in statistics)
    x = torch.from_numpy(((windows - mean) / std).astype(np.float32)).transpose(1, 2).contiguous()
    vocabulary = Vocabulary.build(c for options in captions for c in options)
    return MotionWindows(config, split, Path(root), x, mean, std, captions, ids,
                         _fingerprint(x, captions, mean, std), vocabulary)


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


def trajectory_loss_weights(k: float, channels: int = FEATURE_DIM) -> list[float]:
    """GMD's trajectory loss scaling (appendix C.1, Eq. 5): weight k² on features 0:4."""
    weights = [1.0] * channels
    for i in range(TRAJECTORY_FEATURES.start, min(TRAJECTORY_FEATURES.stop, channels)):
        weights[i] = float(k) ** 2
    return weights


# ---------------------------------------------------------------------------------------------
# Models
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class GMDModelSpec:
    """Everything that decides a trained tiny GMD model (with the data fingerprint: its key).

    ``task`` "trajectory" (4 channels) or "motion" (263); ``prediction`` "x0" or "epsilon";
    ``data`` the windows; the UNet is ``UNet1D(C, base_channels, channel_mults)``; the
    diffusion has ``diffusion_steps`` steps of the ``schedule``; AdamW (``lr``,
    ``weight_decay``), gradient clip 1, EMA ``ema_decay`` with warm-up (``training``).
    ``feature_weights`` (C,) weigh the squared error per channel (GMD's loss scaling k²,
    ``trajectory_loss_weights``). ``text_conditioned`` adds a bag-of-words caption condition
    (dropped with probability ``cond_dropout`` for classifier-free use).
    """

    task: Task = "trajectory"
    prediction: Literal["x0", "epsilon"] = "epsilon"
    data: DataConfig = field(default_factory=DataConfig)
    base_channels: int = 16
    channel_mults: tuple[float, ...] = (1, 2, 4)
    diffusion_steps: int = 100
    schedule: Literal["cosine", "linear"] = "cosine"
    train_steps: int = 1000
    batch_size: int = 64
    lr: float = 1e-3
    weight_decay: float = 0.01
    ema_decay: float = 0.9999
    seed: int = 0
    feature_weights: tuple[float, ...] | None = None
    text_conditioned: bool = False
    cond_dropout: float = 0.1

    def __post_init__(self) -> None:
        _check_task(self.task)
        if self.prediction not in ("x0", "epsilon"):
            raise ValueError(f"prediction must be 'x0' or 'epsilon', got {self.prediction!r}")
        if self.schedule not in ("cosine", "linear"):
            raise ValueError(f"schedule must be 'cosine' or 'linear', got {self.schedule!r}")
        object.__setattr__(self, "channel_mults", tuple(float(m) for m in self.channel_mults))
        if self.feature_weights is not None:
            weights = tuple(float(w) for w in self.feature_weights)
            if len(weights) != CHANNELS[self.task]:
                raise ValueError(f"feature_weights needs {CHANNELS[self.task]} values for the "
                                 f"{self.task} task, got {len(weights)}")
            object.__setattr__(self, "feature_weights", weights)
        if self.data.frames % 2 ** (len(self.channel_mults) - 1):
            raise ValueError(f"frames = {self.data.frames} must be divisible by "
                             f"2**(len(channel_mults) - 1) = {2 ** (len(self.channel_mults) - 1)}")

    @property
    def channels(self) -> int:
        return CHANNELS[self.task]

    def replace(self, **changes: Any) -> GMDModelSpec:
        """A copy with some fields changed (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, Any]:
        config = dataclasses.asdict(self)
        config["data"] = self.data.as_dict()
        if not self.text_conditioned:
            config.pop("cond_dropout")
        return config

    def diffusion(self) -> GaussianDiffusion:
        return schedule_diffusion(self.schedule, self.diffusion_steps, self.prediction)

    def build_model(self, cond_dim: int | None = None) -> UNet1D:
        return UNet1D(self.channels, self.base_channels, self.channel_mults, cond_dim=cond_dim)

    def train_config(self, device: str | torch.device = "cpu") -> TrainConfig:
        return TrainConfig(steps=self.train_steps, batch_size=self.batch_size, lr=self.lr,
                           weight_decay=self.weight_decay, ema_decay=self.ema_decay,
                           seed=self.seed,
                           feature_weights=None if self.feature_weights is None
                           else list(self.feature_weights),
                           cond_dropout=self.cond_dropout if self.text_conditioned else 0.0,
                           device=str(device))


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


def model_cache_config(spec: GMDModelSpec, data: MotionWindows) -> dict[str, Any]:
    """What a trained model's cache key covers: the spec and the training windows' content."""
    return {"spec": spec.as_dict(), "data_fingerprint": data.fingerprint,
            "version": _CACHE_VERSION}


def load_or_train_gmd(spec: GMDModelSpec, data: MotionWindows | None = None, *,
                      device: str | torch.device = "cpu", retrain: bool = False,
                      progress: bool = False) -> TrainedGMD:
    """The trained model of ``spec`` from the cache (kind ``gmd_<task>``), trained on a miss.

    ``data`` are the training windows of ``spec.data`` (loaded when None; pass them to avoid
    reloading). Deterministic given ``spec.seed``; the same code runs on ``device="cuda"``.
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
        cond = bag_of_words(vocabulary, data.captions) if vocabulary is not None else None
        result = train_diffusion(model, diffusion, x, spec.train_config(device), cond=cond,
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

        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(min(workers, len(missing)), mp_context=context) as pool:
            list(pool.map(_train_in_worker, missing, [data.fingerprint] * len(missing)))
    return [load_or_train_gmd(spec, data, device=device) for spec in specs]


# ---------------------------------------------------------------------------------------------
# Sampling and goal functions
# ---------------------------------------------------------------------------------------------


def default_stop_step(num_timesteps: int) -> int:
    """GMD's stop step t = 20 of T = 1000 (guidance acts while t ≥ 20), scaled to T."""
    return int(round(GMD_STOP_FRACTION * num_timesteps))


def sample(trained: TrainedGMD, n: int, *, seed: int, guidance: Guidance | None = None,
           imputation: Imputation | None = None, stop_guidance_at: int | None = None,
           return_trajectory: bool = False, trajectory_timesteps: Sequence[int] | None = None,
           text: str | Sequence[str] | None = None, noise: Tensor | None = None,
           clip_x0: float | None | Literal["auto"] = "auto",
           ) -> Tensor | tuple[Tensor, SampleTrajectory]:
    """n samples (n, C, frames) in model space by ancestral sampling (``p_sample_loop``).

    The same ``seed`` gives the same x_T and the same per-step noise whatever the guidance
    (guidance draws nothing), so guided and unguided runs with one seed are paired.
    ``stop_guidance_at`` defaults to GMD's 2 % of T (``default_stop_step``). ``text``: one
    caption or n (text-conditioned models only).

    ``clip_x0`` "auto": an ε model's x̂0 is clamped to ±``trained.x0_bound`` (the largest
    |value| of its training windows), as GMD clamps its ε trajectory model's x̂0 (to ±6 in
    its normalisation; an x0 model is not clamped). Without it an ε model diverges at the
    first step of the cosine schedule, where x̂0 = (x_T − √(1−ᾱ) ε̂)/√ᾱ multiplies the error
    of ε̂ by 1/√ᾱ_{T−1} (≈ 2000 at T = 100). A number clamps any model, None never.
    """
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    shape = (n, trained.space.channels, trained.spec.data.frames)
    kwargs: dict[str, Any] = {}
    if text is not None:
        kwargs["cond"] = trained.text_condition(text, n)
    elif trained.vocabulary is not None:
        kwargs["force_unconditional"] = True
    stop = default_stop_step(trained.num_timesteps) if stop_guidance_at is None else int(
        stop_guidance_at)
    if clip_x0 == "auto":
        clip_x0 = trained.x0_bound if trained.spec.prediction == "epsilon" else None
    return trained.diffusion.p_sample_loop(
        trained.model, shape, model_kwargs=kwargs, seed=seed, guidance=guidance,
        imputation=imputation, stop_guidance_at=stop, clip_x0=clip_x0, device=trained.device,
        noise=noise, return_trajectory=return_trajectory,
        trajectory_timesteps=trajectory_timesteps)


def _targets(target_xz: Tensor | np.ndarray | Sequence[float], like: Tensor) -> Tensor:
    target = torch.as_tensor(np.asarray(target_xz, dtype=np.float32), device=like.device,
                             dtype=like.dtype)
    if target.shape[-1] != 2 or target.dim() > 2:
        raise ValueError(f"targets must be (2,) or (B, 2) world x/z, got {tuple(target.shape)}")
    return target if target.dim() == 2 else target[None]


def goal_reaching_loss(space: FeatureSpace, target_xz: Tensor | np.ndarray | Sequence[float],
                       frame: int = -1) -> Callable[[Tensor], Tensor]:
    """G(x̂0) = ½‖p_xz(frame) − target‖₁ (m) per sample: GMD's goal reaching, L1 (p = 1) on the
    un-normalised root of x̂0 (model space (B, C, T)), averaged over the target's two
    coordinates as GMD normalises by the number of target entries. ``target_xz`` (2,) or
    (B, 2)."""

    def goal(pred_x0: Tensor) -> Tensor:
        position = space.root_xz(pred_x0)[:, frame]
        return (position - _targets(target_xz, position)).abs().mean(dim=-1)

    return goal


def waypoint_loss(space: FeatureSpace, target_xz: Tensor | np.ndarray | Sequence[float],
                  frame: int) -> Callable[[Tensor], Tensor]:
    """G(x̂0) = ½‖p_xz(frame) − target‖₁: reach a location at frame ``frame`` (GMD's keyframe
    locations)."""
    return goal_reaching_loss(space, target_xz, frame)


def obstacle_loss(space: FeatureSpace, centres_xz: np.ndarray | Sequence[Sequence[float]],
                  radii: np.ndarray | Sequence[float]) -> Callable[[Tensor], Tensor]:
    """G(x̂0) = Σ_t Σ_k max(0, r_k − ‖p_xz(t) − c_k‖): penetration depth of the root path into
    circular obstacles (our cost; GMD's obstacle avoidance uses a comparable hinge)."""
    centres = np.asarray(centres_xz, dtype=np.float32).reshape(-1, 2)
    radius = np.asarray(radii, dtype=np.float32).reshape(-1)
    if len(radius) != len(centres):
        raise ValueError(f"{len(centres)} centres but {len(radius)} radii")

    def goal(pred_x0: Tensor) -> Tensor:
        position = space.root_xz(pred_x0)                                # (B, T, 2)
        c = torch.as_tensor(centres, dtype=position.dtype, device=position.device)
        r = torch.as_tensor(radius, dtype=position.dtype, device=position.device)
        distance = (position[:, :, None, :] - c).norm(dim=-1)            # (B, T, K)
        return torch.relu(r - distance).sum(dim=(1, 2))

    return goal


def goal_guidance(trained: TrainedGMD, target_xz: Tensor | np.ndarray | Sequence[float], *,
                  frame: int = -1, strength: float = GMD_GUIDANCE_STRENGTH) -> Guidance:
    """Classifier guidance toward ``target_xz`` at ``frame`` (default the last): μ̃ = μ −
    s·Σ_t·∇_{x_t}½‖p_xz(x̂0) − target‖₁ (GMD, s = 100)."""
    return Guidance(goal_reaching_loss(trained.space, target_xz, frame), strength=strength)


# ---------------------------------------------------------------------------------------------
# Measurements
# ---------------------------------------------------------------------------------------------


def goal_error(trained: TrainedGMD | FeatureSpace, x: Tensor,
               target_xz: Tensor | np.ndarray | Sequence[float], frame: int = -1) -> np.ndarray:
    """Euclidean distance (m) between the root x/z at ``frame`` and the target, per sample."""
    space = trained.space if isinstance(trained, TrainedGMD) else trained
    with torch.no_grad():
        position = space.root_xz(x.detach())[:, frame]
        return (position - _targets(target_xz, position)).norm(dim=-1).cpu().numpy()


def _root_as_joints(root: np.ndarray) -> np.ndarray:
    # metrics.jitter averages over 22 joints: 22 copies of the root give the root's own value
    return np.repeat(root[:, :, None, :], NUM_JOINTS, axis=2)


def jitter_of(trained: TrainedGMD | FeatureSpace, x: Tensor,
              part: Literal["auto", "joints", "root"] = "auto") -> metrics.Jitter:
    """Mean acceleration (m/s²) and jerk (m/s³) of samples (B, C, T) (``metrics.jitter``):
    of all recovered joints for the motion task, of the root path for the trajectory task
    (``part`` forces one; a trajectory sample has only a root)."""
    space = trained.space if isinstance(trained, TrainedGMD) else trained
    if part == "auto":
        part = "joints" if space.task == "motion" else "root"
    with torch.no_grad():
        if part == "joints":
            points = space.joints(x.detach()).cpu().double().numpy()
        else:
            points = _root_as_joints(space.root_positions(x.detach()).cpu().double().numpy())
    return metrics.jitter(points, fps=FPS)


def foot_skating_of(trained: TrainedGMD | FeatureSpace, x: Tensor) -> float:
    """Mean horizontal foot speed in contact (m/s, ``metrics.foot_skating``), motion task."""
    space = trained.space if isinstance(trained, TrainedGMD) else trained
    with torch.no_grad():
        joints = space.joints(x.detach()).cpu().double().numpy()
    return metrics.foot_skating(joints, fps=FPS)


def guided_change_survival(space: TrainedGMD | FeatureSpace, x0_guided_at_stop: Tensor,
                           x0_unguided_at_stop: Tensor, final_guided: Tensor,
                           final_unguided: Tensor) -> float:
    """Fraction of the guided change in x̂0 at the stop step still present in the final sample.

    With g(·) the world root x/z path (B, T, 2) in metres and two runs from the same seed
    (same x_T, same per-step noise), one guided (G) and one not (U):

        Δ_stop  = g(x̂0^G at the last guided step t = stop) − g(x̂0^U at that step)
        Δ_final = g(final sample^G) − g(final sample^U)
        survival = Σ Δ_final·Δ_stop / Σ Δ_stop·Δ_stop      (sums over samples, frames, x/z)

    i.e. the least-squares share of the change the guidance had made by the stop step that the
    remaining (unguided) steps leave in place: 1 = all kept, 0 = all undone.
    """
    space = space.space if isinstance(space, TrainedGMD) else space
    with torch.no_grad():
        stop = (space.root_xz(x0_guided_at_stop) - space.root_xz(x0_unguided_at_stop)).double()
        final = (space.root_xz(final_guided) - space.root_xz(final_unguided)).double()
    norm = float((stop * stop).sum())
    if norm == 0.0:
        return float("nan")
    return float((final * stop).sum()) / norm


def goal_error_kept(unguided_error: np.ndarray | Sequence[float],
                    reference_error: np.ndarray | Sequence[float] | float,
                    final_error: np.ndarray | Sequence[float]) -> float:
    """The goal-error reduction kept at the end relative to a reference (batch means ē):
    (ē_unguided − ē_final) / (ē_unguided − ē_reference); NaN when ē_reference ≥ ē_unguided."""
    unguided = float(np.mean(unguided_error))
    reference = float(np.mean(reference_error))
    final = float(np.mean(final_error))
    if not unguided > reference:
        return float("nan")
    return (unguided - final) / (unguided - reference)


@dataclass
class GoalReachingResult:
    """A guided and an unguided run with the same seed (same x_T, same per-step noise).

    ``timesteps`` run from T−1 down to 0; ``x0_error_*`` (S, n) is the goal error of the
    model's x̂0 at each of them; ``error_at_stop`` (n,) that of the guided x̂0 at the last
    guided step t = stop, whose x̂0 in both runs are ``x0_*_at_stop``.
    """

    targets: np.ndarray
    stop_guidance_at: int
    strength: float
    space: FeatureSpace
    guided: Tensor
    unguided: Tensor
    error_guided: np.ndarray
    error_unguided: np.ndarray
    error_at_stop: np.ndarray
    timesteps: np.ndarray
    x0_error_guided: np.ndarray
    x0_error_unguided: np.ndarray
    x0_guided_at_stop: Tensor
    x0_unguided_at_stop: Tensor

    @property
    def survival(self) -> float:
        """``guided_change_survival`` of this pair of runs (the registered measurement)."""
        return guided_change_survival(self.space, self.x0_guided_at_stop,
                                      self.x0_unguided_at_stop, self.guided, self.unguided)

    @property
    def best_step_error(self) -> float:
        """The lowest batch-mean goal error of the guided x̂0 over all steps (m)."""
        return float(self.x0_error_guided.mean(axis=1).min())

    @property
    def error_kept_from_stop(self) -> float:
        """``goal_error_kept`` relative to the guided x̂0 at the stop step."""
        return goal_error_kept(self.error_unguided, self.error_at_stop, self.error_guided)

    @property
    def error_kept_from_best(self) -> float:
        """``goal_error_kept`` relative to the guided x̂0's best step."""
        return goal_error_kept(self.error_unguided, self.best_step_error, self.error_guided)


def _x0_errors(space: FeatureSpace, trajectory: SampleTrajectory, targets: np.ndarray,
               frame: int) -> np.ndarray:
    return np.stack([goal_error(space, x0, targets, frame) for x0 in trajectory.pred_x0])


def goal_reaching_experiment(trained: TrainedGMD, targets_xz: np.ndarray, *, seed: int,
                             strength: float = GMD_GUIDANCE_STRENGTH,
                             stop_guidance_at: int | None = None, frame: int = -1,
                             clip_x0: float | None | Literal["auto"] = "auto",
                             ) -> GoalReachingResult:
    """Sample len(targets) motions toward their targets (one per sample) with goal guidance
    and without, from the same seed, recording x̂0's goal error at every step."""
    targets = np.asarray(targets_xz, dtype=np.float32).reshape(-1, 2)
    stop = default_stop_step(trained.num_timesteps) if stop_guidance_at is None else int(
        stop_guidance_at)
    guidance = goal_guidance(trained, targets, frame=frame, strength=strength)
    guided, guided_path = sample(trained, len(targets), seed=seed, guidance=guidance,
                                 stop_guidance_at=stop, return_trajectory=True, clip_x0=clip_x0)
    unguided, unguided_path = sample(trained, len(targets), seed=seed, return_trajectory=True,
                                     clip_x0=clip_x0)
    steps = np.asarray(guided_path.timesteps)
    x0_guided = _x0_errors(trained.space, guided_path, targets, frame)
    x0_unguided = _x0_errors(trained.space, unguided_path, targets, frame)
    # the last guided step is t = stop (guidance acts while t ≥ stop); none at all if stop = T
    k = int(np.flatnonzero(steps == min(stop, trained.num_timesteps - 1))[0])
    return GoalReachingResult(
        targets=targets, stop_guidance_at=stop, strength=float(strength), space=trained.space,
        guided=guided.cpu(), unguided=unguided.cpu(),
        error_guided=goal_error(trained, guided, targets, frame),
        error_unguided=goal_error(trained, unguided, targets, frame), error_at_stop=x0_guided[k],
        timesteps=steps, x0_error_guided=x0_guided, x0_error_unguided=x0_unguided,
        x0_guided_at_stop=guided_path.pred_x0[k], x0_unguided_at_stop=unguided_path.pred_x0[k])


def goal_targets(windows: MotionWindows, n: int, *, seed: int, frame: int = -1,
                 min_distance: float = 0.0) -> np.ndarray:
    """n goal locations (n, 2): the root x/z at ``frame`` of n windows drawn with ``seed``
    among those whose root ends at least ``min_distance`` (m) from its start (e.g. test
    windows: places a motion of this data set does reach in that time)."""
    space = windows.space("trajectory")
    with torch.no_grad():
        ends = space.root_xz(windows.trajectory())[:, frame].numpy().astype(np.float32)
    eligible = np.flatnonzero(np.linalg.norm(ends, axis=1) >= min_distance)
    if n > len(eligible):
        raise ValueError(f"asked for {n} targets but only {len(eligible)} of {len(windows)} "
                         f"windows end ≥ {min_distance} m from their start")
    return ends[np.random.default_rng(seed).choice(eligible, n, replace=False)]


def evaluator_inputs(space: TrainedGMD | FeatureSpace,
                     x: Tensor) -> tuple[np.ndarray, list[int]]:
    """(features (B, T, 263) float32 in HumanML3D's relative representation, lengths) of
    motion-task samples, as ``evaluator.Evaluator.embed_motions`` takes them."""
    space = space.space if isinstance(space, TrainedGMD) else space
    with torch.no_grad():
        features = space.relative_features(x.detach().cpu()).numpy().astype(np.float32)
    return features, [features.shape[1]] * features.shape[0]


def describe(spec: GMDModelSpec) -> str:
    """A one-line summary of a spec for notes and figure titles."""
    mults = ",".join(f"{m:g}" for m in spec.channel_mults)
    return (f"{spec.task}/{spec.prediction} UNet1D(base {spec.base_channels}, mults [{mults}]), "
            f"T={spec.diffusion_steps} {spec.schedule}, {spec.train_steps} steps × batch "
            f"{spec.batch_size}, lr {spec.lr:g}, {spec.data.frames} frames "
            f"({spec.data.representation} root)")


def parameter_count(trained: TrainedGMD) -> int:
    """The number of trainable parameters of the model."""
    return sum(p.numel() for p in trained.model.parameters())
