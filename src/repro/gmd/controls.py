"""Positive and null controls beside the GMD model-based experiments: the shared machinery.

A claim's controls (in its claim module) run the *same measurement code* as its experiment, on
the same number of seeds and items, on inputs whose truth is known: an exact model (GMD-A3) or
the stand-in data themselves (GMD-A4, B2, C4, F1) as the "model". They are paired as the
experiment is: within one seed every arm is built from the same draw — the same windows or
trajectories, targets and random noise — wherever the experiment's arms share their starting
noise, items or test set; different seeds get different draws (one per seed and stream,
:func:`control_seed` with arm 0). The **null** control uses that pairing with no effect (the
arms identical, or one placed exactly at a rule's threshold); the **positive** control plants
every part's effect at its registered size δ (``repro.claims.registry_gmd``) as a
deterministic change to one arm of those paired draws, by an exact transformation wherever one
exists (radial scaling about the goal, a world-space scale of the body, a scale of the
offsets) and by a size measured on calibration draws disjoint from the control's where none
does (FID). A part that compares one arm with a constant keeps its draw's own noise: nothing
pairs it. ``record_claim(..., controls=...)`` decides both with the claim's own rule, exactly
(``claim.decide(..., control=True)``: rounding ties are zero, a difference identical in every
seed is decided by its sign).

Here: the seeds of control draws (:func:`control_seed`), the bisection that calibrates a
planted size (:func:`calibrate_increasing`) and the exact plantings (:func:`scale_world`,
:func:`jag`, :func:`offset_unread_features`, :func:`located`, :func:`planted_path`): exact
checks of the measurement code, which the tests run.

**The controls a model-based claim records are A/A runs** (:func:`aa_controls`). An exact
model or the data as the "model" has no between-model noise: its null reads "every difference
within ±0" and can never fire, while two trained models differ by their seeds alone. So the
null of a model-based part is the experiment's *reference arm* against an independently
trained copy of itself: the reference model of seed s in the reference slot, the reference
model of the next seed (cyclic over the run's seeds, :func:`aa_pairs`: no extra training
where a run has two seeds or more; with one, one more copy is trained, :func:`aa_seeds`) in
the treatment slot, both measured on seed s's pairing (the same goals, targets, noise and
items, exactly as the experiment pairs its arms). Where a rule compares an arm with a
multiple of the other (f·a vs b) the copy's reading is placed at that threshold (× f). Its
differences carry the real spread between trained models and are tested with the claim's own
rule: the null passes when it comes out neither reproduced nor partially. The **positive**
control is the same A/A with 2δ (twice the part's registered smallest effect) planted on the
treatment slot's readings in the claim's predicted direction (× e^{±2δ} on a log-ratio part's
readings, ± 2δ on a difference part's): it must be seen.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor

from repro.claims.claim import Path, value
from repro.claims.registry import get_claim
from repro.claims.result import Controls
from repro.gmd.models import TrainedGMD, load_or_train_gmd
from repro.gmd.windows import FeatureSpace, MotionWindows
from repro.motion.features import (
    FEATURE_BLOCKS,
    absolute_to_relative_root,
    relative_to_absolute_root,
)

__all__ = ["AAReadings", "CONTROL_SEED_BASE", "Reading", "Slot", "TENTH_FACTOR", "aa_controls",
           "aa_pairs", "aa_readings", "aa_seeds", "calibrate_increasing", "control_seed",
           "draw_indices", "item_differences", "jag", "located", "offset_unread_features",
           "planted_path", "reference_model", "scale_world"]

#: control randomness lives far from the experiments' seeds (0, 1, 2, …)
CONTROL_SEED_BASE = 1_000_000


#: a registered δ of "10 % of the reference arm's mean" is planted by dividing the other
#: arm's value by 0.9: then E[reference − other] = 0.1·E[reference] exactly
TENTH_FACTOR = 1 / 0.9


#: the absolute-root model channels of the root's world x and z (``FeatureSpace.root_xz``)
_ROOT_X, _ROOT_Z, _ROOT_Y = 1, 2, 3


_RIC = FEATURE_BLOCKS["ric_positions"]


#: features that no joint position reads (rotations, velocities, contacts): an offset there
#: moves the evaluator's embedding and leaves every joint, hence jitter, exactly unchanged
_NOT_JOINTS = slice(_RIC.stop, None)


def control_seed(seed: int, arm: int, stream: int = 0) -> int:
    """The sampling/draw seed of a control (``arm`` < 100, ``seed`` < 1000): distinct for
    every stream, seed and arm, and apart from the experiment's seeds. Paired arms share one
    draw (arm 0); another arm index gives a draw apart from it (e.g. a calibration draw's
    noise)."""
    return CONTROL_SEED_BASE + 100_000 * stream + 100 * int(seed) + arm


def calibrate_increasing(effect: Callable[[float], float], target: float, *, high: float,
                         iterations: int = 30, doublings: int = 20) -> float:
    """The size a ≥ 0 with ``effect(a)`` = ``target`` by bisection on [0, high], for an
    ``effect`` that grows with a (0 when effect(0) ≥ target: nothing left to plant). ``high``
    is doubled until it reaches the target, at most ``doublings`` times (then the largest size
    tried is returned: the caller records the effect it reached)."""
    if effect(0.0) >= target:
        return 0.0
    low = 0.0
    for _ in range(doublings):
        if effect(high) >= target:
            break
        low, high = high, 2 * high
    else:
        return high
    for _ in range(iterations):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if effect(middle) < target else (low, middle)
    return 0.5 * (low + high)


def draw_indices(windows: MotionWindows, n: int, seed: int) -> Tensor:
    """``n`` indices of ``windows`` drawn with ``seed`` (with replacement only when there are
    fewer than ``n``), sorted: one seed's windows, shared by the arms a control pairs."""
    picks = np.random.default_rng(seed).choice(len(windows), n, replace=len(windows) < n)
    return torch.from_numpy(np.sort(picks))


# --- exact planting in the absolute-root representation -----------------------------------

def scale_world(space: FeatureSpace, x: Tensor, factor: float, *,
                horizontal_only: bool = False) -> Tensor:
    """Model-space samples (B, C, T) whose joints are ``factor`` × the original ones.

    Joints are root + q⁻¹·ric with the root's x/z (and y) and the root-relative positions
    ric read directly (``absolute_features_to_joints``); q turns about the vertical, so it
    commutes with a scale. Scaling root x/z/y and ric scales every joint (jitter, a linear
    function of positions, scales by ``factor`` exactly); ``horizontal_only`` scales x and z
    only, so heights and hence foot contacts are kept and the foot speed in contact (foot
    skating) scales by ``factor`` exactly."""
    if space.representation != "absolute":
        raise ValueError("scale_world needs the absolute-root representation")
    features = space.unnormalise(x.detach()).clone()
    features[..., [_ROOT_X, _ROOT_Z]] *= factor
    if not horizontal_only:
        features[..., _ROOT_Y] *= factor
    if space.task == "motion":
        ric = features[..., _RIC].unflatten(-1, (-1, 3))
        axes = [0, 2] if horizontal_only else [0, 1, 2]
        ric[..., axes] *= factor
        features[..., _RIC] = ric.flatten(-2)
    return space.normalise(features)


def offset_unread_features(space: FeatureSpace, x: Tensor, size: float,
                           direction: Tensor) -> Tensor:
    """x with the features no joint reads shifted by ``size`` × their std along a fixed unit
    ``direction`` (every frame, every sample)."""
    features = space.unnormalise(x.detach()).clone()
    std = torch.as_tensor(space.std[_NOT_JOINTS], dtype=features.dtype)
    features[..., _NOT_JOINTS] += size * std * direction.to(features.dtype)
    return space.normalise(features)


def jag(space: FeatureSpace, x: Tensor, amplitude: float, seed: int) -> Tensor:
    """x with white noise of ``amplitude`` metres (a fixed draw of ``seed``) added to every
    position the joints read (root x/z/y and ric): frame-to-frame jaggedness. Relative-root
    windows get it on their root's world x/z (``relative_to_absolute_root`` and back), not on
    its velocity."""
    features = space.unnormalise(x.detach()).clone()
    relative = space.representation == "relative"
    if relative:
        features = relative_to_absolute_root(features)
    generator = torch.Generator().manual_seed(seed)
    for block in (slice(_ROOT_X, _ROOT_Y + 1), _RIC):
        noise = torch.randn(features[..., block].shape, generator=generator)
        features[..., block] += amplitude * noise.to(features.dtype)
    if relative:
        features = absolute_to_relative_root(features)
    return space.normalise(features)


def located(space: FeatureSpace, x: Tensor, frames: Sequence[int], targets: np.ndarray,
            offsets: np.ndarray) -> Tensor:
    """x with its root x/z at ``frames`` set to ``targets`` + ``offsets`` (n, len(frames), 2)."""
    features = space.unnormalise(x.detach()).clone()
    placed = torch.as_tensor(targets + offsets, dtype=features.dtype)
    for k, f in enumerate(frames):
        features[:, f, [_ROOT_X, _ROOT_Z]] = placed[:, k]
    return space.normalise(features)


def planted_path(space: FeatureSpace, x: Tensor, targets: np.ndarray, *, jerk_factor: float,
                 goal_factor: float) -> Tensor:
    """Trajectories (B, 4, T) whose root jerk is ``jerk_factor`` × theirs (the root path
    scaled: jerk is linear in positions) and whose goal errors are ``goal_factor`` × theirs
    (the whole path then translated so its last frame lies at g + goal_factor·(p_last − g);
    a translation leaves the jerk unchanged)."""
    with torch.no_grad():
        last = space.root_xz(x)[:, -1].double()
        scaled = scale_world(space, x, jerk_factor)
        goal = torch.as_tensor(targets, dtype=torch.float64)
        shift = goal + goal_factor * (last - goal) - space.root_xz(scaled)[:, -1].double()
        features = space.unnormalise(scaled).clone()
        features[..., [_ROOT_X, _ROOT_Z]] += shift[:, None, :].to(features.dtype)
    return space.normalise(features)



# ------------------------------------------------------------------------------------------------
# A/A controls: the reference arm against an independently trained copy of itself.
# ------------------------------------------------------------------------------------------------

#: one model's readings on one seed's pairing: name → per-item values (an array whose mean is
#: the per-seed measurement) or one aggregate value (e.g. an FID); None: undefined this seed
Reading = Mapping[str, "np.ndarray | float | None"]


def aa_seeds(seeds: Sequence[int]) -> list[int]:
    """The seeds an A/A control pairs over: the run's, or, for a run of one seed, that seed and
    the next (one more copy of the reference model, trained for the control)."""
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise ValueError("an A/A control needs at least one seed")
    return seeds if len(seeds) > 1 else [seeds[0], seeds[0] + 1]


def aa_pairs(seeds: Sequence[int]) -> list[tuple[int, int]]:
    """(pairing seed s, seed of the copy): the reference model of s against the reference model
    of the next seed, cyclic over :func:`aa_seeds` — every model serves once in each slot."""
    order = aa_seeds(seeds)
    return [(s, order[(i + 1) % len(order)]) for i, s in enumerate(order)]


@dataclass(frozen=True)
class AAReadings:
    """The A/A runs of one claim: per pairing seed s, the reference model of s (``own``) and its
    copy (``copy``, the seed in ``pairs``) measured on s's pairing."""

    pairs: list[tuple[int, int]]
    own: dict[int, Reading]
    copy: dict[int, Reading]


def aa_readings(reading: Callable[[int, int], Reading], seeds: Sequence[int]) -> AAReadings:
    """``reading(model seed, pairing seed)`` — the reference arm's readings of that seed's model
    on that seed's pairing — for every pair of :func:`aa_pairs`."""
    pairs = aa_pairs(seeds)
    own = {s: dict(reading(s, s)) for s, _ in pairs}
    other = {s: dict(reading(c, s)) for s, c in pairs}
    return AAReadings(pairs, own, other)


def _per_seed(item: np.ndarray | float | None) -> float | None:
    if item is None:
        return None
    array = np.asarray(item, dtype=np.float64)
    mean = float(array.mean())
    return mean if np.isfinite(mean) else None


def item_differences(readings: AAReadings, name: str) -> np.ndarray:
    """The copy's per-item readings of ``name`` minus the own model's, pooled over the
    pairings (items of a pairing are paired: the same goal, target or noise draw)."""
    return np.concatenate([np.asarray(readings.copy[s][name], dtype=np.float64).ravel()
                           - np.asarray(readings.own[s][name], dtype=np.float64).ravel()
                           for s, _ in readings.pairs])


@dataclass(frozen=True)
class Slot:
    """One compared quantity of a claim's A/A control. The null fills the reference arm's
    measurement ``reference`` with the own model's reading ``reading`` and the treatment arm's
    ``treatment`` with the copy's, × ``factor`` (a rule comparing f·a with b places the copy at
    that threshold; 1 for a plain comparison). The positive control plants 2δ of ``part``
    (None: nothing planted on this slot) on the treatment slot: × e^{sign·2δ} (``scale`` "log",
    a log-ratio part) or + sign·2δ ("difference"); ``sign`` +1 where the claim predicts the
    treatment arm's reading larger, −1 smaller."""

    treatment: Path
    reference: Path
    reading: str
    factor: float = 1.0
    part: str | None = None
    sign: int = 1
    scale: Literal["log", "difference"] = "log"


def _put(measured: dict[str, Any], path: Path, values: list[float | None]) -> None:
    if isinstance(path, str):
        measured[path] = values
        return
    out = measured
    for key in path[:-1]:
        out = out.setdefault(key, {})
    out[path[-1]] = values


def _delta(claim_id: str, part_name: str, measured: Mapping[str, Any]) -> float:
    part = next(p for p in get_claim(claim_id).parts if p.name == part_name)
    return max(abs(c.smallest_effect) for c in part.compare(measured))


def aa_controls(claim_id: str, readings: AAReadings, slots: Sequence[Slot], *,
                reference_arm: str, extra: Mapping[str, Any] | None = None) -> Controls:
    """The claim's A/A controls from ``readings`` (module docstring): the null (the reference
    arm ``reference_arm``, in words, against its independently trained copy; ``extra``: the
    measurements the rule reads that no slot fills, e.g. the values a claim runs) and the
    positive (that null with 2δ planted per ``slots``). ``planted`` records the pairs, each
    planted 2δ and the between-model spread of every reading."""
    null: dict[str, Any] = copy.deepcopy(dict(extra or {}))
    for slot in slots:
        _put(null, slot.reference, [_per_seed(readings.own[s][slot.reading])
                                    for s, _ in readings.pairs])
        copied = [_per_seed(readings.copy[s][slot.reading]) for s, _ in readings.pairs]
        _put(null, slot.treatment, [None if v is None else slot.factor * v for v in copied])
    positive = copy.deepcopy(null)
    planted: dict[str, float] = {}
    for slot in slots:
        if slot.part is None:
            continue
        delta = _delta(claim_id, slot.part, null)
        planted[slot.part] = 2 * delta
        values = value(positive, slot.treatment)
        moved = [None if v is None else
                 (v * float(np.exp(slot.sign * 2 * delta)) if slot.scale == "log"
                  else v + slot.sign * 2 * delta) for v in values]
        _put(positive, slot.treatment, moved)
    spread = {}
    for name in sorted({slot.reading for slot in slots}):
        gaps = [(_per_seed(readings.copy[s][name]), _per_seed(readings.own[s][name]))
                for s, _ in readings.pairs]
        gaps_ok = [a - b for a, b in gaps if a is not None and b is not None]
        spread[name] = float(np.std(gaps_ok, ddof=1)) if len(gaps_ok) > 1 else 0.0
    pairs = ", ".join(f"{s}↔{c}" for s, c in readings.pairs)
    return Controls(
        null=null, positive=positive, exact=False,
        planted={"design": "A/A: the reference arm against an independently trained copy",
                 "reference_arm": reference_arm, "pairs": [list(p) for p in readings.pairs],
                 "planted_2delta": planted, "between_model_spread": spread},
        null_text=(f"A/A: the {reference_arm} model of seed s against an independently "
                   f"trained copy (the next seed's; pairs {pairs}), paired as the experiment "
                   "(the same items and noise within a seed); no plant, the claim's own rule"),
        positive_text=("the same A/A with twice each part's δ planted on the copy's readings "
                       "in the claim's predicted direction ("
                       + ", ".join(f"{k}: {v:.3g}" for k, v in planted.items()) + ")"))


def reference_model(models: Mapping[int, TrainedGMD], seed: int) -> TrainedGMD:
    """The reference arm's model of ``seed`` (keyed by seed): the run's own, or, for the copy
    an A/A control of a one-seed run needs (:func:`aa_seeds`), the same spec trained with
    ``seed`` (cached like every model)."""
    if seed in models:
        return models[seed]
    first = next(iter(models.values()))
    return load_or_train_gmd(first.spec.replace(seed=seed), device=first.device)
