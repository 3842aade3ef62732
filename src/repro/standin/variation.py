"""Natural variation of the body parts a single-concept clip's concept does not own
(generator version 3): they move freely instead of holding a fixed default.

In HumanML3D a clip captioned "a person walks forward" rarely keeps its arms still, and one
captioned "a person waves the left hand" rarely stands frozen; generator v2 kept every
unowned part at its default (rest arms, idle standing), so a single concept's clips held no
motion outside it. Here each free part follows smooth random curves: a sum of two sinusoids
per coordinate at 0.2–0.8 Hz with a random amplitude per clip. The amplitudes are bounded so
that no free part performs another concept as ``repro.standin.oracles`` measures it (arms swing
at most ≈ 0.45 rad off their default, far from a wave's raised wrist, a clap's touching hands
or a punch's reach; the pelvis bobs at most 2 cm, a tenth of a squat's drop; the root never
travels), which is what keeps a single-concept clip's labels true.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from repro.standin.pose import Track, normalize

__all__ = ["ARM_SWING_MAX", "PELVIS_BOB_MAX", "free_variation"]

#: largest amplitude (per coordinate, added to a unit arm direction) of a free arm's swing
ARM_SWING_MAX = 0.45
#: largest drop (m) of the pelvis when the lower body is free
PELVIS_BOB_MAX = 0.02
_SPINE_MAX = np.array([0.10, 0.15, 0.06])    # rad: pitch, yaw, roll of the spine
_HEAD_MAX = np.array([0.15, 0.35])           # rad: pitch, yaw of the neck


def _smooth_curves(t: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """(T, n) curves in [-1, 1]: per column the mean of two sinusoids at 0.2–0.8 Hz."""
    freq = rng.uniform(0.2, 0.8, (2, n))
    phase = rng.uniform(0, 2 * np.pi, (2, n))
    return 0.5 * np.sin(2 * np.pi * freq[:, None, :] * t[None, :, None] + phase[:, None, :]).sum(0)


def free_variation(track: Track, free_parts: Iterable[str], t: np.ndarray,
                   rng: np.random.Generator) -> None:
    """Let ``free_parts`` of ``track`` move freely, in place: a free arm swings (upper arm and
    forearm by the same offset, so the elbow keeps its bend); a free torso sways (spine and
    neck); free legs bend the knees a little (the pelvis bobs, the feet stay planted). The
    root never moves. Draws from ``rng`` in the order left arm, right arm, torso, legs."""
    free = set(free_parts)
    unknown = free - {"root", "legs", "torso", "left_arm", "right_arm"}
    if unknown:
        raise ValueError(f"unknown body part(s) {sorted(unknown)}")
    for side, part in enumerate(("left_arm", "right_arm")):
        if part not in free:
            continue
        amplitude = rng.uniform(0.1, ARM_SWING_MAX)
        offset = amplitude * _smooth_curves(t, 3, rng)
        track.arms[:, side] = normalize(track.arms[:, side] + offset[:, None, :])
    if "torso" in free:
        track.spine += _SPINE_MAX * rng.uniform(0.3, 1.0) * _smooth_curves(t, 3, rng)
        track.head += _HEAD_MAX * rng.uniform(0.3, 1.0) * _smooth_curves(t, 2, rng)
    if "legs" in free:
        bob = rng.uniform(0.3, 1.0) * PELVIS_BOB_MAX
        track.pelvis_y -= 0.5 * bob * (1 + _smooth_curves(t, 1, rng)[:, 0])
