"""Concept motions of the stand-in generator, standing still to clapping (walking, running
and turning are in ``repro.standin.locomotion``).

A concept (wave the right hand, jump, ...) is a small parametric function of time that fills
a :class:`~repro.standin.pose.Track`, which :func:`~repro.standin.pose.solve_pose` turns into
local rotations. Each concept has a sampler, ``sample_*(rng, duration, stop_at_end) →
params`` (the random parameters of one occurrence; ``stop_at_end``: another concept follows,
so come to rest), and a motion, ``motion(t, params) → Track`` at local times ``t`` (s), made
at the origin facing +Z (:func:`place` moves it). ``repro.standin.concepts`` names the
concepts and ``repro.standin.generator`` composes them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from repro.standin.pose import (
    ANKLE_HEIGHT,
    FOREARM,
    FORWARD,
    SHOULDER,
    SIDE_SIGN,
    STANCE_X,
    STAND_HEIGHT,
    UP,
    UPPER_ARM,
    Track,
    arm_direction,
    bend,
    normalize,
    rotate_xz,
    two_bone,
)

__all__ = [
    "GRAVITY", "clap", "ease", "idle", "jump", "kick", "place", "punch", "raise_arms",
    "sample_clap", "sample_jump", "sample_kick", "sample_punch", "sample_raise", "sample_squat",
    "sample_wave", "slerp_directions", "smoothstep", "squat", "wave",
]

#: m/s², for the ballistic flight of a jump.
GRAVITY = 9.81

# ---------------------------------------------------------------------------------- profiles

def smoothstep(x: np.ndarray | float) -> np.ndarray:
    """3x² − 2x³ of x clipped to [0, 1]: 0 below 0, 1 above 1, zero slope at both ends."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def ease(t: np.ndarray, start: float, end: float) -> np.ndarray:
    """0 before ``start``, 1 after ``end``, smoothstep between."""
    return smoothstep((t - start) / max(end - start, 1e-9))


def _keyframes(t: np.ndarray, times: Sequence[float], values: np.ndarray) -> np.ndarray:
    """Piecewise smoothstep interpolation through (times[k], values[k]); held outside."""
    times = np.asarray(times, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    k = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    w = smoothstep((t - times[k]) / np.maximum(times[k + 1] - times[k], 1e-9))
    w = w.reshape(w.shape + (1,) * (values.ndim - 1))
    return values[k] + w * (values[k + 1] - values[k])


# ---------------------------------------------------------------------- standing and placing

def _rest_arms(n: int) -> np.ndarray:
    arms = np.empty((n, 2, 2, 3))
    for side in (0, 1):
        upper = arm_direction(side, 0.05, 0.14)
        arms[:, side, 0] = upper
        arms[:, side, 1] = bend(upper, 0.25, FORWARD)
    return arms


def idle(t: np.ndarray, sway_phase: float = 0.0) -> Track:
    """Standing: feet planted under the hips, a slight breathing sway."""
    n = len(t)
    sway = np.sin(2 * np.pi * 0.3 * t + sway_phase)
    ankles = np.zeros((n, 2, 3))
    ankles[:, :, 0] = SIDE_SIGN * STANCE_X
    ankles[:, :, 1] = ANKLE_HEIGHT
    spine = np.zeros((n, 3))
    spine[:, 0] = 0.03 + 0.01 * sway
    return Track(root_xz=np.zeros((n, 2)), heading=np.zeros(n),
                 pelvis_y=STAND_HEIGHT - 0.004 * (1 + sway), pelvis_tilt=np.zeros((n, 3)),
                 ankles=ankles, foot_yaw=np.zeros((n, 2)), foot_pitch=np.zeros((n, 2)),
                 spine=spine, head=np.zeros((n, 2)), arms=_rest_arms(n),
                 upright=np.zeros((n, 2)))


def place(track: Track, origin_xz: np.ndarray, heading: float) -> Track:
    """Move a track made at the origin facing +Z to start at ``origin_xz`` facing ``heading``."""
    out = track.copy()
    out.root_xz = rotate_xz(track.root_xz, heading) + origin_xz
    out.heading = track.heading + heading
    out.ankles[..., [0, 2]] = rotate_xz(track.ankles[..., [0, 2]], heading) + origin_xz
    out.foot_yaw = track.foot_yaw + heading
    return out


# -------------------------------------------------------------------- jump, squat, kick

def sample_jump(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
    """Parameters of :func:`jump`: 1–3 jumps (as many as fit) with 0.35–0.5 s of flight, the
    crouch depth, the tuck of the feet and up to 0.3 m of forward travel in all."""
    start = rng.uniform(0.1, 0.3)
    flight = rng.uniform(0.35, 0.5)
    one = 0.35 + 0.15 + flight + 0.6
    gaps = rng.uniform(0.05, 0.25)
    count = int(max(1, min(3, (duration - start - 0.1) // (one + gaps))))
    return {"start": start, "count": count, "gap": gaps, "flight": flight,
            "crouch": rng.uniform(0.08, 0.13), "tuck": rng.uniform(0.05, 0.12),
            "distance": rng.uniform(0.0, 0.3) / count, "arm_swing": rng.uniform(0.5, 0.8),
            "sway": rng.uniform(0, 2 * np.pi)}


def _hermite(s: np.ndarray, y0: float, v0: float, y1: float, v1: float,
             length: float) -> np.ndarray:
    """Cubic Hermite on s ∈ [0, 1] with end values y and end velocities v (per second)."""
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * y0 + h10 * v0 * length + h01 * y1 + h11 * v1 * length


def jump(t: np.ndarray, p: Mapping[str, Any]) -> Track:
    """Crouch (0.35 s), push off (0.15 s, reaching take-off speed v₀ = g·T_f/2), ballistic
    flight y = y₀ + v₀s − g s²/2 for T_f, landing absorption (0.25 s), recovery (0.35 s).
    In flight the feet follow the pelvis and tuck up; a jump may travel a little forward."""
    track = idle(t, p["sway"])
    flight, crouch = p["flight"], p["crouch"]
    v0 = GRAVITY * flight / 2
    takeoff_y = STAND_HEIGHT + 0.01
    one = 0.35 + 0.15 + flight + 0.6
    y = track.pelvis_y.copy()
    feet_up = np.zeros_like(t)
    forward = np.zeros_like(t)
    arm = np.zeros_like(t)
    lean = np.zeros_like(t)
    for j in range(p["count"]):
        t0 = p["start"] + j * (one + p["gap"])
        t1, t2 = t0 + 0.35, t0 + 0.5
        t3 = t2 + flight
        t4, t5 = t3 + 0.25, t3 + 0.6
        down = (t >= t0) & (t < t1)
        y[down] = STAND_HEIGHT - crouch * ease(t[down], t0, t1)
        push = (t >= t1) & (t < t2)
        y[push] = _hermite((t[push] - t1) / 0.15, STAND_HEIGHT - crouch, 0.0, takeoff_y, v0, 0.15)
        air = (t >= t2) & (t < t3)
        s = t[air] - t2
        y[air] = takeoff_y + v0 * s - GRAVITY * s**2 / 2
        feet_up[air] = (y[air] - takeoff_y) + p["tuck"] * np.sin(np.pi * s / flight)
        land = (t >= t3) & (t < t4)
        y[land] = _hermite((t[land] - t3) / 0.25, takeoff_y, -v0, STAND_HEIGHT - 0.7 * crouch,
                           0.0, 0.25)
        rise = (t >= t4) & (t < t5)
        y[rise] = STAND_HEIGHT - 0.7 * crouch * (1 - ease(t[rise], t4, t5))
        forward += p["distance"] * ease(t, t2, t3)
        arm += _keyframes(t, [t0, t1, t2 + 0.1, t3, t4, t5 + 0.2],
                          np.array([0.0, -0.6, 1.0, 0.3, 0.4, 0.0]))
        lean += _keyframes(t, [t0, t1, t2, t3, t4, t5], np.array([0, 1, 0.2, 0.2, 0.7, 0]))
    track.pelvis_y = y
    track.root_xz[:, 1] = forward
    track.ankles[:, :, 1] += feet_up[:, None]
    track.ankles[:, :, 2] += forward[:, None]
    track.spine[:, 0] += 0.35 * lean
    for side in (0, 1):
        upper = arm_direction(side, p["arm_swing"] * arm, 0.14)
        track.arms[:, side, 0] = upper
        track.arms[:, side, 1] = bend(upper, 0.3, FORWARD)
    return track


def sample_squat(rng: np.random.Generator, duration: float,
                 stop_at_end: bool) -> dict[str, Any]:
    """Parameters of :func:`squat`: 1–3 squats (as many as fit), their descent, hold and rise
    times, a depth of 0.28–0.42 m and how far the arms reach forward."""
    start = rng.uniform(0.1, 0.3)
    down, hold, up = rng.uniform(0.6, 0.9), rng.uniform(0.2, 0.6), rng.uniform(0.6, 0.9)
    gap = rng.uniform(0.2, 0.4)
    count = int(max(1, min(3, (duration - start) // (down + hold + up + gap))))
    return {"start": start, "count": count, "down": down, "hold": hold, "up": up, "gap": gap,
            "depth": rng.uniform(0.28, 0.42), "arms_forward": rng.uniform(0.6, 1.2),
            "sway": rng.uniform(0, 2 * np.pi)}


def squat(t: np.ndarray, p: Mapping[str, Any]) -> Track:
    """Pelvis lowered by ``depth`` and moved back while the torso leans forward; feet stay
    planted (slightly wider), knees bend forward by IK; arms reach forward for balance."""
    track = idle(t, p["sway"])
    depth = np.zeros_like(t)
    one = p["down"] + p["hold"] + p["up"] + p["gap"]
    for j in range(p["count"]):
        t0 = p["start"] + j * one
        t1 = t0 + p["down"]
        t2 = t1 + p["hold"]
        depth += ease(t, t0, t1) - ease(t, t2, t2 + p["up"])
    track.pelvis_y = track.pelvis_y - p["depth"] * depth
    track.root_xz[:, 1] = -0.3 * p["depth"] * depth
    track.ankles[:, :, 0] *= 1.3
    track.pelvis_tilt[:, 0] = 0.3 * depth
    track.spine[:, 0] += 0.45 * depth
    for side in (0, 1):
        upper = arm_direction(side, p["arms_forward"] * depth + 0.05, 0.14)
        track.arms[:, side, 0] = upper
        track.arms[:, side, 1] = bend(upper, 0.2, FORWARD)
    return track


def sample_kick(side: int) -> Callable[..., dict[str, Any]]:
    """The parameter sampler of :func:`kick` with leg ``side`` (0 left, 1 right): one kick, two
    if they fit, with the wind-up time, a reach of 0.55–0.7 m and ankle height 0.35–0.55 m."""

    def sample(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
        start, windup, gap = rng.uniform(0.1, 0.4), rng.uniform(0.25, 0.4), rng.uniform(0.2, 0.5)
        one = windup + 0.68                       # lift, wind-up, strike, return, plant
        count = 2 if start + 2 * one + gap <= duration else 1
        return {"side": side, "start": start, "count": count, "windup": windup, "gap": gap,
                "reach": rng.uniform(0.55, 0.7), "height": rng.uniform(0.35, 0.55),
                "sway": rng.uniform(0, 2 * np.pi)}

    return sample


def kick(t: np.ndarray, p: Mapping[str, Any]) -> Track:
    """Wind-up (foot back and up), strike in 0.18 s to ``reach`` in front of the hip at ankle
    height ``height``, return and plant; the pelvis shifts over the standing foot."""
    track = idle(t, p["sway"])
    side = p["side"]
    windup = p["windup"]
    home = track.ankles[0, side].copy()
    offsets = np.zeros((len(t), 3))
    weight = np.zeros_like(t)
    lean = np.zeros_like(t)
    for j in range(p["count"]):
        t0 = p["start"] + j * (windup + 0.68 + p["gap"])
        times = [t0, t0 + 0.15, t0 + 0.15 + windup, t0 + 0.33 + windup, t0 + 0.55 + windup,
                 t0 + 0.68 + windup]
        keys = np.array([[0, 0, 0], [0, 0.03, 0], [0, 0.12, -0.22],
                         [0, p["height"] - home[1], p["reach"]], [0, 0.08, 0.1], [0, 0, 0]])
        offsets += _keyframes(t, times, keys)
        weight += _keyframes(t, times, np.array([0, 1, 1, 1, 1, 0.0]))
        lean += _keyframes(t, times, np.array([0, 0, 0.2, 1, 0.3, 0.0]))
    track.ankles[:, side] += offsets
    track.root_xz[:, 0] = -SIDE_SIGN[side] * 0.06 * weight
    track.pelvis_y = track.pelvis_y - 0.03 * weight
    track.spine[:, 0] -= 0.25 * lean
    for arm_side in (0, 1):
        upper = arm_direction(arm_side, 0.1, 0.14 + 0.35 * weight)
        track.arms[:, arm_side, 0] = upper
        track.arms[:, arm_side, 1] = bend(upper, 0.3, FORWARD)
    return track


# -------------------------------------------------------------------------------------- arms

def slerp_directions(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Great-circle interpolation of unit vectors, weight ``w`` (…,) toward b."""
    a, b = np.broadcast_arrays(a, b)
    dot = np.clip((a * b).sum(-1), -1.0, 1.0)
    omega = np.arccos(dot)[..., None]
    w = np.asarray(w, float)[..., None]
    small = omega < 1e-6
    sin_omega = np.where(small, 1.0, np.sin(omega))
    out = np.where(small, a + w * (b - a),
                   (np.sin((1 - w) * omega) * a + np.sin(w * omega) * b) / sin_omega)
    return normalize(out)


def _blend_arm(track: Track, side: int, target: np.ndarray, weight: np.ndarray) -> None:
    """Move arm ``side`` from its current directions toward ``target`` (T, 2, 3)."""
    track.arms[:, side] = slerp_directions(track.arms[:, side], target, weight[:, None])


def sample_wave(sides: tuple[int, ...]) -> Callable[..., dict[str, Any]]:
    """The parameter sampler of :func:`wave` with the arms ``sides`` (0 left, 1 right): 2–3 Hz,
    ± 0.45–0.7 rad, the arm's elevation and raising time; half the clips of ≥ 2.8 s lower
    the arm at the end."""

    def sample(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
        lower = bool(rng.random() < 0.5) and duration >= 2.8
        return {"sides": list(sides), "frequency": rng.uniform(2.0, 3.0),
                "amplitude": rng.uniform(0.45, 0.7), "phase": rng.uniform(0, 2 * np.pi),
                "elevation": rng.uniform(0.15, 0.6), "raise_time": rng.uniform(0.3, 0.5),
                "start": rng.uniform(0.0, 0.2), "lower_at": duration - 0.4 if lower else None}

    return sample


def wave(t: np.ndarray, p: Mapping[str, Any]) -> Track:
    """Upper arm out to the side and up by ``elevation``, forearm up, rocking side to side
    about the forward axis by ± ``amplitude`` at ``frequency`` Hz. The arm is raised (and
    lowered) through a sideways pose, not through the front."""
    track = idle(t)                      # only the arms are used
    half = p["raise_time"] / 2
    level = ease(t, p["start"], p["start"] + half) + ease(t, p["start"] + half,
                                                              p["start"] + 2 * half)
    if p["lower_at"] is not None:
        lower = p["lower_at"]
        level = level - ease(t, lower, lower + 0.2) - ease(t, lower + 0.2, lower + 0.4)
    rock = p["amplitude"] * np.sin(2 * np.pi * p["frequency"] * t + p["phase"])
    for side in p["sides"]:
        e = p["elevation"]
        upper = normalize(np.array([SIDE_SIGN[side] * math.cos(e), math.sin(e), 0.3]))
        forearm = normalize(np.stack((np.sin(rock), np.cos(rock), np.full_like(t, 0.15)), -1))
        target = np.stack((np.broadcast_to(upper, forearm.shape), forearm), 1)
        sideways = normalize(np.array([[SIDE_SIGN[side], -0.1, 0.1],
                                       [SIDE_SIGN[side] * 0.7, 0.7, 0.1]]))
        rest = track.arms[:, side].copy()
        first = slerp_directions(rest, sideways, np.clip(level, 0, 1)[:, None])
        track.arms[:, side] = slerp_directions(first, target, np.clip(level - 1, 0, 1)[:, None])
        track.upright[:, side] = 1.0                  # "up" is against gravity
    return track


def sample_raise(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
    """Parameters of :func:`raise_arms`: raising and lowering times, abduction 2.8–3.05 rad;
    lowered at the end if there is time (always when ``stop_at_end``)."""
    start, up = rng.uniform(0.0, 0.3), rng.uniform(0.5, 0.9)
    down = rng.uniform(0.5, 0.9)
    lower = duration - start - up - down >= 0.8
    if stop_at_end:        # followed by another concept: always lower, keeping a 0.6-s hold
        lower = True
        up = down = min(up, down, (duration - start - 0.7) / 2)
    return {"start": start, "up": up, "down": down,
            "lower_at": duration - down - 0.1 if lower else None,
            "abduct": rng.uniform(2.8, 3.05), "flex": rng.uniform(0.0, 0.3)}


def raise_arms(t: np.ndarray, p: Mapping[str, Any]) -> Track:
    """Both arms raised sideways (abduction to ≈ 160–175°) above the head, held, and lowered
    again at the end if there is time (the wrists pass the head for ≥ 0.5 s either way)."""
    track = idle(t)                      # only the arms are used
    level = ease(t, p["start"], p["start"] + p["up"])
    if p["lower_at"] is not None:
        level = level * (1 - ease(t, p["lower_at"], p["lower_at"] + p["down"]))
    for side in (0, 1):
        upper = arm_direction(side, p["flex"] * level, 0.14 + (p["abduct"] - 0.14) * level)
        track.arms[:, side, 0] = upper
        track.arms[:, side, 1] = bend(upper, 0.15, UP)
    track.upright[:] = 1.0                            # "up" is against gravity
    return track


def _arm_ik(side: int, wrist: np.ndarray) -> np.ndarray:
    """Upper-arm and forearm directions (T, 2, 3) reaching ``wrist`` (torso frame,
    relative to spine3), elbow pointing down and out."""
    hint = np.array([SIDE_SIGN[side] * 0.5, -1.0, -0.2])
    upper, lower = two_bone(wrist - SHOULDER[side], UPPER_ARM[side], FOREARM[side], hint)
    return np.stack((upper, lower), axis=-2)


def sample_clap(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
    """Parameters of :func:`clap`: 1.6–2.6 Hz, the hands' height, distance in front and
    opening."""
    return {"frequency": rng.uniform(1.6, 2.6), "height": rng.uniform(-0.1, 0.05),
            "distance": rng.uniform(0.25, 0.33), "open": rng.uniform(0.14, 0.24),
            "start": rng.uniform(0.0, 0.2)}


def clap(t: np.ndarray, p: Mapping[str, Any]) -> Track:
    """Hands brought in front of the chest, the wrists closing to 6 cm (touching palms) and
    opening to 2 × ``open`` at ``frequency`` Hz."""
    track = idle(t)                      # only the arms are used
    ready = ease(t, p["start"], p["start"] + 0.4)
    local = np.maximum(t - p["start"] - 0.4, 0.0)
    half_gap = 0.03 + (p["open"] - 0.03) * 0.5 * (1 + np.cos(2 * np.pi * p["frequency"] * local))
    half_gap = np.where(t < p["start"] + 0.4, p["open"], half_gap)
    for side in (0, 1):
        wrist = np.stack((SIDE_SIGN[side] * half_gap, np.full_like(t, p["height"]),
                          np.full_like(t, p["distance"])), -1)
        _blend_arm(track, side, _arm_ik(side, wrist), ready)
    return track


def sample_punch(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
    """Parameters of :func:`punch`: 1–4 punches (as many as fit), the strike time, the pause
    between punches, a reach of 0.46–0.51 m and the height."""
    start, pause, strike = rng.uniform(0.0, 0.2), rng.uniform(0.15, 0.35), rng.uniform(0.1, 0.14)
    period = strike + 0.3 + pause                 # extend, hold, retract, pause
    count = int(max(1, min(4, (duration - start - 0.35) // period)))
    return {"start": start, "pause": pause, "count": count, "reach": rng.uniform(0.46, 0.51),
            "strike": strike, "height": rng.uniform(-0.05, 0.05)}


def punch(t: np.ndarray, p: Mapping[str, Any]) -> Track:
    """Right fist raised to a guard in front of the chin, then ``count`` straight punches:
    extend in ``strike`` s to ``reach`` in front of the shoulder, hold 0.05 s, retract."""
    track = idle(t)                      # only the arms are used
    side = 1
    guard = np.array([-0.12, 0.1, 0.22])
    strike = SHOULDER[side] + np.array([0.03, p["height"], p["reach"]])
    extension = np.zeros_like(t)
    for j in range(p["count"]):
        t0 = p["start"] + 0.35 + j * (0.3 + p["strike"] + p["pause"])
        extension += _keyframes(t, [t0, t0 + p["strike"], t0 + p["strike"] + 0.05,
                                    t0 + p["strike"] + 0.3], np.array([0.0, 1, 1, 0]))
    wrist = guard + extension[:, None] * (strike - guard)
    ready = ease(t, p["start"], p["start"] + 0.35)
    _blend_arm(track, side, _arm_ik(side, wrist), ready)
    return track
