"""GMD-C4's experiment (notebook 03, GMD appendix C.1): tiny GMD motion models with trajectory
loss scaling k or the Emphasis projection c at matched values (Eq. 5: weight k² ≈ c² on the
trajectory), trained and measured.

- the model layer over ``repro.gmd.models`` and ``guidance``: :class:`ProjectedFeatureSpace`,
  :class:`Variant`, :func:`load_or_train_variant`, x̂0 trajectory imputation
  (:class:`ImputedX0`, :func:`sample_with_trajectory`) and the measurements of its samples;
- :class:`Settings`, every size and step count of GMD-C4; its data (``Settings.base_spec``) is
  also the stand-in data GMD-C1…C3 read, and :func:`setup_summary` prints it beside the checks'
  ``projection.ProjectionSettings``;
- :func:`window_evaluator`, the package's text-to-motion evaluator on the training windows;
- :func:`run_experiment` and its :class:`Results`, which ``c4`` turns into the claim.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor, nn

from repro.gmd.emphasis_projection.projection import (
    EmphasisProjection,
    Kind,
    Precision,
    ProjectionSettings,
)
from repro.gmd.guidance import default_stop_step, sample
from repro.gmd.models import (
    MOTION_TRAINING,
    STANDARD_DIFFUSION_STEPS,
    GMDModelSpec,
    TrainedGMD,
    load_or_train_gmd,
    training_fields,
    trajectory_loss_weights,
)
from repro.gmd.settings import STANDARD_C4_TRAIN_STEPS, seeds_of
from repro.gmd.windows import DataConfig, DataDir, FeatureSpace, MotionWindows
from repro.infra import cache
from repro.infra.context import RunSettings, check_scale
from repro.motion.features import FEATURE_DIM, FPS
from repro.motion.quaternion import qinv, qrot, quat_about_y

__all__ = ["C4_VALUES", "IMPUTED_FEATURES", "ImputedX0", "METHODS", "ProjectedFeatureSpace",
           "Results", "SENSITIVITY_VALUES", "Settings", "TABLE_B1_VARIANTS", "Targets", "Variant",
           "coherence", "draw_targets", "from_normalised", "load_or_train_variant",
           "measure_imputed", "measure_text_to_motion", "project_windows",
           "root_velocity_disagreement", "run_experiment", "sample_with_trajectory",
           "setup_summary", "text_metrics", "to_normalised", "trajectory_error",
           "window_evaluator"]


# ------------------------------------------------------------------------------------------------
# Tiny GMD motion models with trajectory loss scaling or the Emphasis projection (GMD C.1).
#
# A thin layer over ``repro.gmd.models`` and ``guidance`` (which have no projection hook): the
# Emphasis models train on projected windows y = x P (``EmphasisProjection``,
# channels-first) and sample in that space; their :class:`ProjectedFeatureSpace` un-projects
# before un-normalising, so every ``gmd`` measurement (joints, root, foot skating, jitter) works
# on them unchanged.
#
# Trajectory imputation follows GMD's x0-model path for the projected model
# (``gaussian_diffusion.p_sample_loop``, ``impute_at = 'x0'``): at every step with t ≥ stop the
# model's x̂0 is un-projected, its root x/z (features 1, 2, all frames: GMD's "Impute (x,z)")
# overwritten by the target, projected again, and the posterior mean formed from it. Without
# guidance GMD's "combine" of the un-projected means equals this exactly (the posterior mean is
# linear in x̂0). For the un-projected models the same wrapper is GMD's plain x0 imputation.
# ------------------------------------------------------------------------------------------------

Method = Literal["loss_scaling", "emphasis"]


METHODS = ("loss_scaling", "emphasis")


#: GMD imputes the root x and z (features 1, 2) of the absolute representation.
IMPUTED_FEATURES = (1, 2)


#: features 193:196 are the root joint's velocity in the body's facing frame.
ROOT_VELOCITY = slice(193, 196)


#: GMD-C4's registered matched values: 2 and 10 (GMD's released c); its seeds are
#: ``settings.FULL_SEEDS["GMD-C4"]``.
C4_VALUES = (2, 10)


#: the values at which the sensitivity arms (orthogonal matrix, GMD's float32 construction)
#: run: GMD's released c = 10.
SENSITIVITY_VALUES = (10,)


@dataclass(frozen=True)
class ProjectedFeatureSpace(FeatureSpace):
    """A :class:`gmd.FeatureSpace` whose model space is the projected one: y = x P with x the
    z-normalised channels. ``unnormalise`` un-projects first, ``normalise`` projects last."""

    projection: EmphasisProjection | None = None

    def normalise(self, features: Tensor) -> Tensor:
        """Un-normalised features (B, T, C) → projected model space (B, C, T)."""
        return self.projection.project_channels_first(super().normalise(features))

    def unnormalise(self, x: Tensor) -> Tensor:
        """Projected model space (B, C, T) → un-normalised features (B, T, C)."""
        return super().unnormalise(self.projection.unproject_channels_first(x))

    def as_dict(self) -> dict[str, Any]:
        return {**super().as_dict(), "projection": self.projection.as_config()}


def to_normalised(space: FeatureSpace, x: Tensor) -> Tensor:
    """Model-space samples (B, C, T) → z-normalised (un-projected) channels (B, C, T)."""
    if isinstance(space, ProjectedFeatureSpace):
        return space.projection.unproject_channels_first(x)
    return x


def from_normalised(space: FeatureSpace, x: Tensor) -> Tensor:
    """z-normalised channels (B, C, T) → model space (projected when the space is)."""
    if isinstance(space, ProjectedFeatureSpace):
        return space.projection.project_channels_first(x)
    return x


def project_windows(windows: MotionWindows, projection: EmphasisProjection) -> MotionWindows:
    """The windows with x replaced by x P (float32, channels-first) and a fingerprint that
    covers the projection (so the model cache never mixes projected and plain training data)."""
    if projection.dim != windows.x.shape[1]:
        raise ValueError(f"projection has dim {projection.dim}, windows have "
                         f"{windows.x.shape[1]} channels")
    x = projection.project_channels_first(windows.x).to(torch.float32).contiguous()
    digest = cache.fingerprint(f"{windows.fingerprint}|{sorted(projection.as_config().items())}",
                               digits=16)
    return dataclasses.replace(windows, x=x, fingerprint=digest)


@dataclass(frozen=True)
class Variant:
    """One C.1 configuration: trajectory loss scaling by k (weights k² on features 0:4, GMD's
    code) or the Emphasis projection with c (features 0–2 emphasised).

    Emphasis variants carry the matrix's ``kind`` and ``precision``
    (``EmphasisProjection``): the rule's arm is the paper's Gaussian matrix in
    float64; the sensitivity arms outside the rule are ``kind="orthogonal"`` (√n·Q, its own
    models) and ``precision="float32_gmd"`` (GMD's released float32 construction: the Gaussian
    arm's model of the same seed, sampled through GMD's float32 P and P⁻¹)."""

    method: Method
    value: float
    kind: Kind = "gaussian"
    precision: Precision = "float64"

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        if not self.value > 0:
            raise ValueError(f"value must be positive, got {self.value}")
        if self.method == "loss_scaling" and (self.kind, self.precision) != ("gaussian",
                                                                            "float64"):
            raise ValueError("kind and precision describe an Emphasis matrix; loss scaling "
                             "has none")

    @property
    def in_rule(self) -> bool:
        """Whether this is an arm of the rule's kind (loss scaling, or the paper's Gaussian
        float64 Emphasis matrix) rather than a sensitivity arm; the values the rule reads are
        ``Settings.values``."""
        return self.kind == "gaussian" and self.precision == "float64"

    @property
    def label(self) -> str:
        symbol = "k" if self.method == "loss_scaling" else "c"
        name = "loss scaling" if self.method == "loss_scaling" else "Emphasis"
        suffix = {("orthogonal", "float64"): " (orthogonal)",
                  ("gaussian", "float32_gmd"): " (GMD float32)"}
        return f"{name} {symbol}={self.value:g}" + suffix.get((self.kind, self.precision), "")

    def spec(self, base: GMDModelSpec, seed: int) -> GMDModelSpec:
        """``base`` with this seed and, for loss scaling k ≠ 1, GMD's weights k² on 0:4."""
        weights = None
        if self.method == "loss_scaling" and self.value != 1:
            weights = tuple(trajectory_loss_weights(self.value, base.channels))
        return base.replace(seed=seed, feature_weights=weights)

    def projection(self, seed: int, dim: int = FEATURE_DIM) -> EmphasisProjection | None:
        """The Emphasis projection of this variant (matrix seed = model seed), or None."""
        if self.method != "emphasis":
            return None
        return EmphasisProjection(dim=dim, c=self.value, seed=seed, kind=self.kind,
                                  precision=self.precision)


def load_or_train_variant(base: GMDModelSpec, variant: Variant, windows: MotionWindows,
                          seed: int, *, device: str | torch.device = "cpu",
                          projected: MotionWindows | None = None) -> TrainedGMD:
    """The cached or newly trained motion model of ``variant`` with ``seed``.

    ``windows`` are the plain training windows of ``base.data``; an Emphasis variant trains on
    ``project_windows(windows, variant.projection(seed))`` (pass ``projected`` to reuse it)
    and comes back with a :class:`ProjectedFeatureSpace`.
    """
    spec = variant.spec(base, seed)
    projection = variant.projection(seed, windows.x.shape[1])
    if projection is None:
        return load_or_train_gmd(spec, windows, device=device)
    # GMD's float32 construction trains on x·P in float32; the float64 arm's training windows
    # are x·P rounded to float32, the same data to within float32 rounding: its model is the
    # float64 arm's, and only P and P⁻¹ at sampling are GMD's
    trained_on = (projection if variant.precision == "float64" else
                  dataclasses.replace(variant, precision="float64").projection(
                      seed, windows.x.shape[1]))
    data = projected if projected is not None else project_windows(windows, trained_on)
    trained = load_or_train_gmd(spec, data, device=device)
    space = trained.space
    projected_space = ProjectedFeatureSpace(space.task, space.representation, space.mean,
                                            space.std, projection)
    return dataclasses.replace(trained, space=projected_space)


class ImputedX0(nn.Module):
    """x̂0 with the masked z-normalised channels overwritten by ``target`` while t ≥ ``stop``:
    x̂0 ← from_normalised(where(mask, target, to_normalised(x̂0))) (GMD ``impute_at='x0'``)."""

    def __init__(self, model: nn.Module, space: FeatureSpace, mask: Tensor, target: Tensor,
                 stop: int) -> None:
        super().__init__()
        self.model, self.space, self.stop = model, space, int(stop)
        self.register_buffer("mask", mask.bool())
        self.register_buffer("target", target)

    def forward(self, x_t: Tensor, t: Tensor, **kwargs: Any) -> Tensor:
        pred_x0 = self.model(x_t, t, **kwargs)
        if int(t.reshape(-1)[0]) < self.stop:
            return pred_x0
        plain = to_normalised(self.space, pred_x0)
        imputed = torch.where(self.mask, self.target.to(plain.dtype), plain)
        return from_normalised(self.space, imputed).to(pred_x0.dtype)


def sample_with_trajectory(trained: TrainedGMD, target: Tensor, *, seed: int,
                           captions: Sequence[str] | None = None,
                           features: Sequence[int] = IMPUTED_FEATURES,
                           stop: int | None = None) -> Tensor:
    """Samples (B, 263, T) in model space whose root ``features`` are imputed from ``target``
    (B, 263, T) z-normalised, un-projected windows (only those channels are read). x0 models
    only. ``stop`` defaults to GMD's 2 % of T (``guidance.default_stop_step``)."""
    if trained.diffusion.prediction != "x0":
        raise ValueError("x̂0 imputation needs an x0-predicting model")
    mask = torch.zeros_like(target, dtype=torch.bool)
    mask[:, list(features)] = True
    stop = default_stop_step(trained.num_timesteps) if stop is None else int(stop)
    wrapper = ImputedX0(trained.model, trained.space, mask.to(trained.device),
                        target.to(trained.device), stop)
    imputing = dataclasses.replace(trained, model=wrapper)
    return sample(imputing, target.shape[0], seed=seed,
                  text=list(captions) if captions is not None else None)


# ------------------------------------------------------------------------------ measurements

def trajectory_error(space: FeatureSpace, x: Tensor, target_xz: Tensor) -> np.ndarray:
    """Mean over frames of ‖root_xz(x) − target_xz‖ (m) per sample; ``target_xz`` (B, T, 2)."""
    with torch.no_grad():
        xz = space.root_xz(x.detach())
        return (xz - target_xz.to(xz)).norm(dim=-1).mean(dim=-1).cpu().numpy()


def root_velocity_disagreement(features: Tensor | np.ndarray) -> np.ndarray:
    """How far the root trajectory and the body's own velocity features disagree (m/s) per
    sample, for absolute-root features (B, T, 263):

        mean_t ‖(p_{t+1} − p_t)_xz − (r_t⁻¹ · v_t)_xz‖ · fps,   t < T − 1,

    with p_t the root position (features 1, 2), r_t the facing rotation from the heading
    half-angle (feature 0) and v_t the root velocity stored in the facing frame (features
    193:196, HumanML3D's ``local_velocity``). Zero for data made by ``joints_to_features``.
    """
    f = torch.as_tensor(np.asarray(features) if isinstance(features, np.ndarray) else features)
    f = f.detach().to(torch.float64)
    if f.dim() != 3 or f.shape[-1] != FEATURE_DIM:
        raise ValueError(f"features must be (B, T, {FEATURE_DIM}), got {tuple(f.shape)}")
    facing = quat_about_y(2.0 * f[..., 0])
    world = qrot(qinv(facing), f[..., ROOT_VELOCITY])[..., [0, 2]]
    step = f[:, 1:, 1:3] - f[:, :-1, 1:3]
    return ((step - world[:, :-1]).norm(dim=-1).mean(dim=-1) * FPS).numpy()


# ------------------------------------------------------------------------------ the experiment

#: the two models of Table B.1's "Ours (abs)" and "Ours xproj" rows.
TABLE_B1_VARIANTS = (Variant("loss_scaling", 1), Variant("emphasis", 10))


@dataclass(frozen=True)
class Settings(RunSettings):
    """Every size and step count of GMD-C4 in notebook 03, fixed before any verdict was seen.

    Paper scale (the power plan in the GMD-C4 registry entry): loss scaling k and Emphasis
    c at the matched values v ∈ {2, 10} × 6 seeds = 24 text-conditioned x0 motion models in
    the rule (GMD's motion model predicts x0); outside it the orthogonal-matrix sensitivity arm
    at ``sensitivity_values`` (c = 10) and Table B.1's plain model (k = 1), 6 models each
    (GMD's float32 construction samples the Gaussian arm's models): 36 models, on the
    48-frame absolute-root windows the other GMD notebooks use;
    T = 50 cosine, ``models.MOTION_ARCHITECTURE`` trained to convergence with
    ``train_steps`` the cap (``models.training_fields``). Quick mode shrinks everything
    (UNet1D base 16 × (1, 2), a test of the code, never a result).
    """

    scale: str
    seeds: int
    stand_in_clips: int
    stride: int
    diffusion_steps: int
    train_steps: int
    samples: int
    evaluator_steps: int
    values: tuple[int, ...] = C4_VALUES
    sensitivity_values: tuple[int, ...] = SENSITIVITY_VALUES
    #: the orthogonal-matrix sensitivity arm (its own models) and Table B.1's plain model
    #: (k = 1): paper scale only (docs/COMPUTE.md §3d)
    orthogonal_arm: bool = True
    table_b1_plain: bool = True

    @classmethod
    def for_scale(cls, scale: str, *, train_steps: int | None = None) -> Settings:
        """The settings of ``scale``; ``train_steps`` (None: the scale's) overrides the
        training steps of every model (outside the notebook's budget). The standard scale
        runs both matched values (k = 2 against Gaussian c = 2, k = 10 against c = 10, GMD's
        released c and Table B.1's Emphasis model) on ``seeds_of("GMD-C4", "standard")`` seeds
        at T = 100 trained ``STANDARD_C4_TRAIN_STEPS``, and GMD's float32 construction (no
        training); the orthogonal arm and Table B.1's plain row are the paper scale's."""
        check_scale(scale)
        if scale == "quick":
            return cls(scale=scale, seeds=1, stand_in_clips=200, stride=8, diffusion_steps=20,
                       train_steps=10 if train_steps is None else int(train_steps), samples=32,
                       evaluator_steps=50)
        if scale == "standard":
            return cls(scale=scale, seeds=seeds_of("GMD-C4", scale), stand_in_clips=2000,
                       stride=24, diffusion_steps=STANDARD_DIFFUSION_STEPS,
                       train_steps=(STANDARD_C4_TRAIN_STEPS if train_steps is None
                                    else int(train_steps)),
                       samples=64, evaluator_steps=500, orthogonal_arm=False,
                       table_b1_plain=False)
        return cls(scale=scale, seeds=seeds_of("GMD-C4", scale), stand_in_clips=2000,
                   stride=24, diffusion_steps=50,
                   train_steps=(MOTION_TRAINING.step_cap if train_steps is None
                                else int(train_steps)),
                   samples=64, evaluator_steps=500)

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @property
    def paper_only(self) -> list[str]:
        """What this scale leaves to the paper scale, in words (the notebook prints it)."""
        left = [f"the rule's part at v = {v}" for v in C4_VALUES if v not in self.values]
        if not self.orthogonal_arm:
            left.append("the orthogonal-matrix arm")
        if not self.table_b1_plain:
            left.append("Table B.1's plain model (k = 1)")
        return left

    def data(self, data_dir: DataDir = None,
             representation: str = "absolute") -> DataConfig:
        return DataConfig(data_dir=data_dir, stand_in_clips=self.stand_in_clips,
                          stride=self.stride, representation=representation)

    def base_spec(self, data_dir: DataDir = None) -> GMDModelSpec:
        """The shared spec; ``Variant.spec`` adds the seed and the loss weights."""
        tiny = {"base_channels": 16, "channel_mults": (1, 2)} if self.quick else {}
        return GMDModelSpec(task="motion", prediction="x0", text_conditioned=True,
                            data=self.data(data_dir), diffusion_steps=self.diffusion_steps,
                            **tiny, **training_fields("motion", scale=self.scale,
                                                      step_cap=self.train_steps))

    def variants(self) -> list[Variant]:
        """The rule's variants: loss scaling and the Gaussian Emphasis matrix at each value."""
        return [Variant(method, v) for method in METHODS for v in self.values]

    def outside_rule_variants(self) -> list[Variant]:
        """Arms the rule does not read: the orthogonal matrix and GMD's float32 construction
        of the Gaussian one at each of ``sensitivity_values``, and Table B.1's models
        (``TABLE_B1_VARIANTS``: the plain model k = 1) where the values do not include them."""
        arms = ((("orthogonal", "float64"),) if self.orthogonal_arm else ()) + (
            ("gaussian", "float32_gmd"),)
        sensitivity = [Variant("emphasis", v, kind=kind, precision=precision)
                       for v in self.sensitivity_values for kind, precision in arms]
        rule = self.variants()
        table = [v for v in TABLE_B1_VARIANTS if v not in rule
                 and (self.table_b1_plain or v != Variant("loss_scaling", 1))]
        return sensitivity + table

    @property
    def trained_models(self) -> int:
        """Models the run trains: every variant × seed except GMD's float32 arm, which
        samples the Gaussian arm's models."""
        arms = [v for v in self.variants() + self.outside_rule_variants()
                if v.precision == "float64"]
        return self.seeds * len(arms)


@dataclass
class Targets:
    """The test windows every model is asked to follow (same for all variants of a seed):
    ``x`` (n, 263, T) z-normalised absolute-root windows, their root paths ``xz`` (n, T, 2),
    one caption each, and their relative-root features (n, T, 263) for the evaluator."""

    x: Tensor
    xz: Tensor
    captions: list[str]
    relative: np.ndarray

    def __len__(self) -> int:
        return int(self.x.shape[0])


def draw_targets(test: MotionWindows, n: int, *, seed: int) -> Targets:
    """n test windows drawn with ``seed`` (in window order), one caption each."""
    rng = np.random.default_rng(seed)
    picks = np.sort(rng.choice(len(test), min(n, len(test)), replace=False))
    captions = [test.captions[i][rng.integers(len(test.captions[i]))] for i in picks]
    x = test.x[torch.from_numpy(picks)]
    space = test.space("motion")
    with torch.no_grad():
        xz = space.root_xz(x)
        relative = space.relative_features(x).numpy().astype(np.float32)
    return Targets(x, xz, captions, relative)


def coherence(space: FeatureSpace, x: Tensor) -> dict[str, float]:
    """Motion-coherence measurements of samples (B, 263, T) in ``space``: foot skating (m/s,
    ``metrics.foot_skating``), GMD's skating ratio, root–velocity-feature disagreement (m/s,
    :func:`root_velocity_disagreement`) and joint acceleration / jerk (``metrics.jitter``)."""
    from repro.core import metrics
    with torch.no_grad():
        features = space.unnormalise(x.detach())
        joints = space.joints(x.detach()).double().numpy()
    jitter = metrics.jitter(joints, fps=FPS)
    return {"foot_skating": metrics.foot_skating(joints, fps=FPS),
            "foot_skating_ratio": metrics.foot_skating_ratio(joints, fps=FPS),
            "root_velocity_disagreement": float(root_velocity_disagreement(features).mean()),
            "acceleration": jitter.acceleration, "jerk": jitter.jerk}


def measure_imputed(trained: TrainedGMD, targets: Targets, *, seed: int,
                    evaluator: Any | None = None) -> tuple[dict[str, float], Tensor]:
    """Sample one motion per target with its root x/z imputed (GMD's trajectory-conditioned
    generation) and its caption; return the coherence measurements, the trajectory error
    (m) and, with an ``evaluator``, FID / R-precision top-3 / Diversity against the targets'
    ground truth — and the samples (model space)."""
    x = sample_with_trajectory(trained, targets.x, seed=seed, captions=targets.captions)
    result = coherence(trained.space, x)
    result["trajectory_error"] = float(trajectory_error(trained.space, x, targets.xz).mean())
    if evaluator is not None:
        result.update(text_metrics(trained, x, targets, evaluator, seed=seed))
    return result, x


def text_metrics(trained: TrainedGMD, x: Tensor, targets: Targets, evaluator: Any, *,
                 seed: int) -> dict[str, float]:
    """FID, R-precision top-3 and Diversity (``evaluator.evaluate_generated``) of samples
    (B, 263, T) against the targets' ground-truth windows, captions = the targets'."""
    from repro.models.evaluator import evaluate_generated

    with torch.no_grad():
        generated = trained.space.relative_features(x.detach()).numpy().astype(np.float32)
    lengths = np.full(len(targets), generated.shape[1])
    result = evaluate_generated(evaluator, generated, lengths, targets.captions,
                                targets.relative, lengths, seed=seed)
    return {"fid": result["fid"], "r_precision_top3": result["r_precision_top3"],
            "diversity": result["diversity"]}


def measure_text_to_motion(trained: TrainedGMD, targets: Targets, evaluator: Any, *,
                           seed: int) -> dict[str, float]:
    """Table B.1's text-to-motion setting (no trajectory): one sample per caption, FID /
    R-precision top-3 / Diversity against the targets' windows, plus coherence."""
    x = sample(trained, len(targets), seed=seed, text=targets.captions)
    return {**text_metrics(trained, x, targets, evaluator, seed=seed),
            **coherence(trained.space, x)}


def window_evaluator(train: MotionWindows, steps: int) -> Any:
    """The package's contrastive evaluator (``evaluator.load_or_train_evaluator``,
    ``EvaluatorConfig().replace(steps=steps)``) on the relative-root features of the training
    windows, one caption list per window. Pass the *relative*-root windows of the same data
    (``Settings.data(..., "relative")``): notebook 02 trains exactly this evaluator, so the
    two notebooks share one cache entry."""
    from repro.models.evaluator import EvaluatorConfig, load_or_train_evaluator

    with torch.no_grad():
        relative = train.space("motion").relative_features(train.x).numpy()
    return load_or_train_evaluator(relative, np.full(len(relative), train.frames),
                                   train.captions, EvaluatorConfig().replace(steps=steps))


@dataclass
class Results:
    """GMD-C4 measurements. ``imputed[label][metric]`` and ``text_to_motion[label][metric]``
    are per-seed lists (seed order of ``seeds``); ``imputed`` covers the rule's ``variants``
    and the ``outside_rule`` arms; ``ground_truth[metric]`` per-seed lists of the targets' own
    values; ``condition_numbers[label]`` κ(P) of every Emphasis variant's matrix per seed;
    ``samples[label]`` the first seed's imputed samples (model space); ``outside_rule`` the
    arms the rule does not read (``Settings.outside_rule_variants``);
    ``train_seconds[label]`` per-seed load-or-train times."""

    seeds: list[int]
    variants: list[Variant]
    imputed: dict[str, dict[str, list[float]]]
    text_to_motion: dict[str, dict[str, list[float]]]
    ground_truth: dict[str, list[float]]
    samples: dict[str, Tensor]
    targets: Targets
    train_seconds: dict[str, list[float]]
    models: dict[str, TrainedGMD]
    outside_rule: list[Variant] = dataclasses.field(default_factory=list)
    condition_numbers: dict[str, list[float]] = dataclasses.field(default_factory=dict)

    def per_value(self, method: Method, metric: str) -> dict[str, list[float]]:
        """{str(value): per-seed list} of one method's metric in the rule's arms (the
        ledger's layout)."""
        return {f"{v.value:g}": self.imputed[v.label][metric] for v in self.variants
                if v.method == method and v.in_rule}

    def kappa_per_value(self) -> dict[str, list[float]]:
        """{str(c): per-seed κ(P)} of the rule's Gaussian Emphasis matrices."""
        return {f"{v.value:g}": self.condition_numbers[v.label] for v in self.variants
                if v.method == "emphasis" and v.in_rule}


def run_experiment(settings: Settings, base: GMDModelSpec, train: MotionWindows,
                   test: MotionWindows, evaluator: Any, seeds: Sequence[int], *,
                   device: str | torch.device = "cpu", log=print) -> Results:
    """Train (or load) every variant (the rule's and the arms outside it) for every seed,
    record κ(P) of every Emphasis matrix, then measure: trajectory-conditioned
    samples (root x/z imputed from ``settings.samples`` test windows drawn with the seed, same
    targets and sampling noise for every variant of a seed) and, for the two Table B.1
    models, text-only samples for the same captions."""
    import time

    rule = settings.variants()
    variants = rule + settings.outside_rule_variants()
    imputed: dict[str, dict[str, list[float]]] = {v.label: {} for v in variants}
    text: dict[str, dict[str, list[float]]] = {v.label: {} for v in TABLE_B1_VARIANTS}
    truth: dict[str, list[float]] = {}
    seconds: dict[str, list[float]] = {v.label: [] for v in variants}
    kappas: dict[str, list[float]] = {v.label: [] for v in variants if v.method == "emphasis"}
    samples: dict[str, Tensor] = {}
    models: dict[str, TrainedGMD] = {}
    first_targets = None
    for seed in seeds:
        targets = draw_targets(test, settings.samples, seed=seed)
        if first_targets is None:
            first_targets = targets
        for name, value in coherence(test.space("motion"), targets.x).items():
            truth.setdefault(name, []).append(value)
        for variant in variants:
            start = time.perf_counter()
            trained = load_or_train_variant(base, variant, train, seed, device=device)
            seconds[variant.label].append(time.perf_counter() - start)
            if variant.label in kappas:
                kappas[variant.label].append(trained.space.projection.condition_number)
            measured, x = measure_imputed(trained, targets, seed=seed, evaluator=evaluator)
            for name, value in measured.items():
                imputed[variant.label].setdefault(name, []).append(value)
            if seed == seeds[0]:
                samples[variant.label], models[variant.label] = x.cpu(), trained
            if variant in TABLE_B1_VARIANTS:
                for name, value in measure_text_to_motion(trained, targets, evaluator,
                                                          seed=seed).items():
                    text[variant.label].setdefault(name, []).append(value)
            log(f"seed {seed} {variant.label}: {time.perf_counter() - start:.1f} s, foot "
                f"skating {measured['foot_skating']:.3f} m/s")
    return Results(list(seeds), rule, imputed, text, truth, samples, first_targets,
                   seconds, models, outside_rule=variants[len(rule):],
                   condition_numbers=kappas)


# ------------------------------------------------------------------------------ the set-up

def setup_summary(settings: Settings, checks: ProjectionSettings, seeds: Sequence[int], *,
                  scale: str, threads: int) -> str:
    """What notebook 03 prints after its set-up: both settings, the seeds and threads, and
    what GMD-C4 leaves to the paper scale at ``scale`` (``Settings.paper_only``), if any."""
    lines = [str(settings), str(checks), f"seeds: {list(seeds)} | torch threads: {threads}"]
    if settings.paper_only:
        lines.append(f"not run at the {scale} scale: " + "; ".join(settings.paper_only))
    return "\n".join(lines)
