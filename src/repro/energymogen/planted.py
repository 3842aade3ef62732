"""The sample sets the EnergyMoGen controls (``energymogen.controls``) are built from: ground-
truth motions with a known change planted — a fraction swapped to another item's motion
(R-precision falls linearly in it), passed round within a subset (FID exactly unchanged), the
body's movement scaled about its temporal mean (every consecutive-frame displacement scales),
and the steps into a timeline's transitions amplified (the distance at the transitions scales,
nothing else moves), with both EMG-5 transition measurements planted at once
(:func:`plant_transitions`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from repro.energymogen.studies import transition_speed_ratio
from repro.energymogen.timelines import RealThenClips

__all__ = ["CONTROL_STREAM", "amplify_transition_steps", "permute_motions", "plant_transitions",
           "scale_movement", "swap_motions"]

#: rng stream of every control (disjoint from the experiments' streams)
CONTROL_STREAM = 13013


def swap_motions(features: np.ndarray, fraction: float, rng: np.random.Generator,
                 groups: np.ndarray) -> np.ndarray:
    """``features`` with each item, with probability ``fraction``, replaced by the motion of a
    random item of another group (another held-out pair): a text–motion mismatch. R-precision
    falls linearly in expectation, from the clean value at 0 to the swapped one at 1."""
    out = np.array(features, copy=True)
    for i in np.flatnonzero(rng.uniform(size=len(features)) < fraction):
        others = np.flatnonzero(groups != groups[i])
        out[i] = features[int(rng.choice(others))]
    return out


def permute_motions(features: np.ndarray, fraction: float, rng: np.random.Generator
                    ) -> np.ndarray:
    """``features`` with a random subset (each item with probability ``fraction``) of motions
    passed round within the subset (a random cycle): every chosen item gets another's motion,
    and the set of motions is unchanged, so FID (a function of that set) is exactly unchanged
    while R-precision falls."""
    out = np.array(features, copy=True)
    chosen = rng.permutation(np.flatnonzero(rng.uniform(size=len(features)) < fraction))
    if len(chosen) > 1:
        out[chosen] = features[np.roll(chosen, 1)]
    return out


def scale_movement(features: np.ndarray, factor: float) -> np.ndarray:
    """``features`` whose root height and root-relative joints (features 3:67) move ``factor``
    times as far about their temporal mean: every consecutive-frame displacement of
    ``metrics.ric_joints`` scales by ``factor``, so the transition distance does exactly."""
    out = np.array(features, dtype=np.float64, copy=True)
    block = out[..., 3:67]
    mean = block.mean(axis=-2, keepdims=True)
    out[..., 3:67] = mean + factor * (block - mean)
    return out.astype(np.asarray(features).dtype)


def amplify_transition_steps(features: np.ndarray, transitions: Sequence[int], factor: float
                             ) -> np.ndarray:
    """``features`` (T, 263) whose step into each transition frame p is ``factor`` times as
    large: from p on, features 3:67 (root height, root-relative joints) are shifted by
    (factor − 1)(x_p − x_{p−1}). Every other step is unchanged, so the distance at the
    transitions (``studies.transition_distances_at_cm``) scales by ``factor`` exactly."""
    out = np.array(features, dtype=np.float64, copy=True)
    for p in sorted(int(q) for q in transitions):
        out[p:, 3:67] += (factor - 1.0) * (out[p, 3:67] - out[p - 1, 3:67])
    return out.astype(np.asarray(features).dtype)


def plant_transitions(clips: RealThenClips, factor: float) -> tuple[list[np.ndarray], float]:
    """The clips with both EMG-5 transition measurements ``factor`` × their clean values: the
    steps at the transitions amplified by f (:func:`amplify_transition_steps`) and the whole
    movement scaled by ``factor``/f (:func:`scale_movement`), so the distance at the
    transitions is exactly ``factor`` × and f is found by bisection (the ratio rises
    monotonically in f) so that the speed ratio is ``factor`` × too. Returns (clips, f)."""
    clean = list(clips.features)
    if factor == 1.0:
        return clean, 1.0
    target = factor * transition_speed_ratio(clean, clips.transitions)

    def build(f: float) -> list[np.ndarray]:
        return [scale_movement(amplify_transition_steps(c, p, f), factor / f)
                for c, p in zip(clean, clips.transitions, strict=True)]

    low, high = 0.0, np.log(1e3)
    for _ in range(60):
        mid = 0.5 * (low + high)
        if transition_speed_ratio(build(float(np.exp(mid))), clips.transitions) < target:
            low = mid
        else:
            high = mid
    f = float(np.exp(0.5 * (low + high)))
    return build(f), f
