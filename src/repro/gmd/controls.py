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
:func:`jag`, :func:`offset_unread_features`, :func:`located`, :func:`planted_path`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import torch
from torch import Tensor

from repro.gmd.windows import FeatureSpace, MotionWindows
from repro.motion.features import (
    FEATURE_BLOCKS,
    absolute_to_relative_root,
    relative_to_absolute_root,
)

__all__ = ["CONTROL_SEED_BASE", "TENTH_FACTOR", "calibrate_increasing", "control_seed",
           "draw_indices", "jag", "located", "offset_unread_features", "planted_path",
           "scale_world"]

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
