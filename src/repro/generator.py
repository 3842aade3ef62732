"""Procedural, concept-driven stand-in motion, written in HumanML3D's folder layout.

Every clip is made by forward kinematics (``skeleton.forward_kinematics``) from a root
trajectory and per-joint local rotations on HumanML3D's target skeleton, so bone lengths are
exactly those of REFERENCE.md in every frame. Clips last 2–6 s at 20 fps (41–121 raw frames,
hence 40–120 feature frames: inside the loaders' 40 ≤ T < 200).

How a pose is made. A concept (walk forward, wave the right hand, ...) is a small parametric
function of time that fills a :class:`_Track`: the root trajectory (x/z, heading, pelvis
height), world targets for the two ankles, spine and head angles, and unit directions of
the upper arms and forearms (in the torso frame, or in the heading frame where "up" means
against gravity: raising and waving). :func:`_solve_pose` turns a track into local
rotations: two-bone inverse kinematics for the legs (hip–knee–ankle, knee bending forward) and
shortest-arc rotations for the arm bones. Walking is a gait planner: each foot is planted at
the root's position at mid-stance (so stride length = speed × cycle time and stance feet do
not slide) and swings along an arc to its next plant; the pelvis is lowered where a stance
leg could not otherwise reach its plant.

Conventions: Y up, a heading of 0 faces +Z, a positive heading change turns left (toward +X,
the body's left). Rest pose: feet point forward and 20° down so the toes (joints 10, 11)
touch the floor while the ankles stand 5 cm above it; the collar bones point up and out;
the head points up; arms hang slightly away from the body.

Composition by body part (``root``, ``legs``, ``torso``, ``left_arm``, ``right_arm``):
simultaneous concepts must own disjoint parts (a locomotion concept owns root + legs and
gives arm swing as a secondary default that an arm concept replaces). Sequential concepts
are evaluated one after the other, each starting where the previous one left the root, and
cross-faded over :data:`BLEND_FRAMES` frames around each transition.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d, minimum_filter1d

from . import paths, storage
from .cache import config_hash
from .features import FEATURE_BLOCKS, FEATURE_DIM, FPS, joints_to_features
from .quaternion import axis_angle_to_quat, qbetween, qinv, qmul, qrot, quat_about_y
from .skeleton import BONE_LENGTHS, NUM_JOINTS, OFFSETS, forward_kinematics

__all__ = [
    "BODY_PARTS", "COMPOSITIONS", "CONCEPTS", "DATASET_MARKER", "GENERATOR_VERSION", "SPLITS",
    "Clip", "ClipSpec", "Concept", "DatasetConfig", "block_averaged_std", "can_be_simultaneous",
    "ensure_dataset", "generate_clip", "generate_clips", "humanml3d_text_line",
    "regenerate_stubs", "sample_clip_spec", "tag_caption", "write_dataset",
]

#: bump when the generated motion or texts change, so cached datasets are regenerated
#: (tests/test_generator_version.py pins what each version generates). 2: the motion fixes
#: made after the first datasets were cached under 1.
GENERATOR_VERSION = "2"
MIN_DURATION, MAX_DURATION = 2.0, 6.0
#: cross-fade length at a sequential transition (frames, centred on the boundary).
BLEND_FRAMES = 8
GRAVITY = 9.81
BODY_PARTS = ("root", "legs", "torso", "left_arm", "right_arm")
COMPOSITIONS = ("single", "simultaneous", "sequential")

# ------------------------------------------------------------------------ skeleton geometry

_SIGN = np.array([1.0, -1.0])                 # +X is the body's left: left = 0, right = 1
_HIP_OFFSET = OFFSETS[[1, 2]]
_THIGH = BONE_LENGTHS[[4, 5]]
_SHIN = BONE_LENGTHS[[7, 8]]
_UPPER_ARM = BONE_LENGTHS[[18, 19]]
_FOREARM = BONE_LENGTHS[[20, 21]]
_FOOT_TILT = math.radians(20.0)
#: ankle height when the foot (ankle → toe joint) points 20° down with the toe on the floor.
ANKLE_HEIGHT = BONE_LENGTHS[[10, 11]] * math.sin(_FOOT_TILT)
#: standing pelvis height: both legs 98.5 % extended (left and right legs differ by 1 cm).
STAND_HEIGHT = float(np.min(ANKLE_HEIGHT + 0.985 * (_THIGH + _SHIN)))
_STANCE_X = 0.11                              # half distance between standing ankles
_COLLAR_DIRECTION = np.array([[0.3, 0.95, 0.0], [-0.3, 0.95, 0.0]])
_COLLAR_DIRECTION /= np.linalg.norm(_COLLAR_DIRECTION, axis=1, keepdims=True)
#: shoulder joints (16, 17) relative to spine3 in the torso frame (x left, y up, z forward).
_SHOULDER = OFFSETS[[13, 14]] + BONE_LENGTHS[[16, 17], None] * _COLLAR_DIRECTION
_NECK_DIRECTION = np.array([0.0, math.cos(math.radians(15)), math.sin(math.radians(15))])

_UP = np.array([0.0, 1.0, 0.0])
_FORWARD = np.array([0.0, 0.0, 1.0])
_KNEE_HINT = np.array([0.0, 0.5, 1.0])        # knees bend forward (and up when the leg is raised)


# ---------------------------------------------------------------------------------- profiles

def _smoothstep(x: np.ndarray | float) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _ease(t: np.ndarray, start: float, end: float) -> np.ndarray:
    """0 before ``start``, 1 after ``end``, smoothstep between."""
    return _smoothstep((t - start) / max(end - start, 1e-9))


def _keyframes(t: np.ndarray, times: Sequence[float], values: np.ndarray) -> np.ndarray:
    """Piecewise smoothstep interpolation through (times[k], values[k]); held outside."""
    times = np.asarray(times, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    k = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    w = _smoothstep((t - times[k]) / np.maximum(times[k + 1] - times[k], 1e-9))
    w = w.reshape(w.shape + (1,) * (values.ndim - 1))
    return values[k] + w * (values[k + 1] - values[k])


def _normalize(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _arm_direction(side: int, flex: np.ndarray | float, abduct: np.ndarray | float) -> np.ndarray:
    """Upper-arm direction in the torso frame: hanging (−Y) turned forward by ``flex`` then
    out to the side by ``abduct`` (radians): (±cos f sin a, −cos f cos a, sin f)."""
    flex, abduct = np.broadcast_arrays(np.asarray(flex, float), np.asarray(abduct, float))
    return np.stack((_SIGN[side] * np.cos(flex) * np.sin(abduct),
                     -np.cos(flex) * np.cos(abduct), np.sin(flex)), axis=-1)


def _bend(upper: np.ndarray, angle: np.ndarray | float, toward: np.ndarray) -> np.ndarray:
    """The direction ``upper`` turned by ``angle`` toward ``toward`` (elbow flexion)."""
    toward = np.broadcast_to(toward, upper.shape)
    perpendicular = _normalize(toward - (toward * upper).sum(-1, keepdims=True) * upper)
    angle = np.asarray(angle, float)[..., None]
    return np.cos(angle) * upper + np.sin(angle) * perpendicular


def _two_bone(target: np.ndarray, first: float, second: float,
              hint: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two-bone inverse kinematics: unit directions of both bones whose chain ends at
    ``target`` (relative to the chain's root), bending toward ``hint``. By the law of
    cosines the first bone leaves the root–target line at α, cos α = (l₁² + d² − l₂²)/(2 l₁ d);
    d is clamped to the reachable range."""
    distance = np.linalg.norm(target, axis=-1, keepdims=True)
    along = target / np.maximum(distance, 1e-12)
    d = np.clip(distance, abs(first - second) + 1e-4, (first + second) * (1 - 1e-4))
    cos_alpha = np.clip((first**2 + d**2 - second**2) / (2 * first * d), -1.0, 1.0)
    hint = np.broadcast_to(hint, target.shape)
    normal = _normalize(hint - (hint * along).sum(-1, keepdims=True) * along)
    upper = cos_alpha * along + np.sqrt(1 - cos_alpha**2) * normal
    lower = _normalize(along * d - first * upper)
    return upper, lower


def _rotate_xz(xz: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    """Rotate (x, z) pairs about +Y by ``angle``: (x cos θ + z sin θ, −x sin θ + z cos θ)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack((xz[..., 0] * c + xz[..., 1] * s, -xz[..., 0] * s + xz[..., 1] * c), -1)


# ------------------------------------------------------------------------------------ tracks

@dataclass
class _Track:
    """Everything a pose needs, per frame; world coordinates unless noted."""

    root_xz: np.ndarray      # (T, 2)
    heading: np.ndarray      # (T,) yaw about +Y
    pelvis_y: np.ndarray     # (T,)
    pelvis_tilt: np.ndarray  # (T, 3) pitch, yaw, roll relative to the heading
    ankles: np.ndarray       # (T, 2, 3) left/right ankle targets
    foot_yaw: np.ndarray     # (T, 2) world yaw of each foot
    foot_pitch: np.ndarray   # (T, 2) extra toe-down pitch beyond the rest 20° (heel off)
    spine: np.ndarray        # (T, 3) pitch (forward +), yaw, roll, spread over the 3 spine joints
    head: np.ndarray         # (T, 2) pitch, yaw of the neck
    arms: np.ndarray         # (T, 2, 2, 3) left/right × upper arm/forearm directions, torso frame
    upright: np.ndarray      # (T, 2) per arm: 1 = ``arms`` are in the heading frame instead

    def copy(self) -> _Track:
        return _Track(**{f.name: getattr(self, f.name).copy() for f in fields(self)})


_PART_FIELDS = {
    "root": ("root_xz", "heading", "pelvis_y", "pelvis_tilt"),
    "legs": ("ankles", "foot_yaw", "foot_pitch"),
    "torso": ("spine", "head"),
}


def _take_part(dst: _Track, src: _Track, part: str) -> None:
    if part in ("left_arm", "right_arm"):
        side = 0 if part == "left_arm" else 1
        dst.arms[:, side] = src.arms[:, side]
        dst.upright[:, side] = src.upright[:, side]
        return
    for name in _PART_FIELDS[part]:
        setattr(dst, name, getattr(src, name).copy())


def _rest_arms(n: int) -> np.ndarray:
    arms = np.empty((n, 2, 2, 3))
    for side in (0, 1):
        upper = _arm_direction(side, 0.05, 0.14)
        arms[:, side, 0] = upper
        arms[:, side, 1] = _bend(upper, 0.25, _FORWARD)
    return arms


def _idle(t: np.ndarray, sway_phase: float = 0.0) -> _Track:
    """Standing: feet planted under the hips, a slight breathing sway."""
    n = len(t)
    sway = np.sin(2 * np.pi * 0.3 * t + sway_phase)
    ankles = np.zeros((n, 2, 3))
    ankles[:, :, 0] = _SIGN * _STANCE_X
    ankles[:, :, 1] = ANKLE_HEIGHT
    spine = np.zeros((n, 3))
    spine[:, 0] = 0.03 + 0.01 * sway
    return _Track(root_xz=np.zeros((n, 2)), heading=np.zeros(n),
                  pelvis_y=STAND_HEIGHT - 0.004 * (1 + sway), pelvis_tilt=np.zeros((n, 3)),
                  ankles=ankles, foot_yaw=np.zeros((n, 2)), foot_pitch=np.zeros((n, 2)),
                  spine=spine, head=np.zeros((n, 2)), arms=_rest_arms(n),
                  upright=np.zeros((n, 2)))


def _place(track: _Track, origin_xz: np.ndarray, heading: float) -> _Track:
    """Move a track made at the origin facing +Z to start at ``origin_xz`` facing ``heading``."""
    out = track.copy()
    out.root_xz = _rotate_xz(track.root_xz, heading) + origin_xz
    out.heading = track.heading + heading
    out.ankles[..., [0, 2]] = _rotate_xz(track.ankles[..., [0, 2]], heading) + origin_xz
    out.foot_yaw = track.foot_yaw + heading
    return out


# ------------------------------------------------------------------------------ locomotion

def _integrate(rate: np.ndarray, dt: float, zero_index: int) -> np.ndarray:
    """Trapezoid cumulative integral along axis 0, shifted to be 0 at ``zero_index``."""
    steps = 0.5 * (rate[1:] + rate[:-1]) * dt
    total = np.concatenate((np.zeros((1,) + rate.shape[1:]), np.cumsum(steps, axis=0)))
    return total - total[zero_index]


def _velocity(p: Mapping[str, Any]) -> Callable[[np.ndarray], np.ndarray]:
    """Body-frame (forward, left) speed and yaw rate at local times τ: zero before τ = 0,
    smoothstep ramps in over ``ramp_in`` and, if ``stop_at`` is set, out before it. A turn
    adds a raised-cosine yaw rate (integral = ``turn_angle``) over its window."""

    def velocity(tau: np.ndarray) -> np.ndarray:
        ramp = _ease(tau, 0.0, p["ramp_in"]) * (tau >= 0)
        if p.get("stop_at") is not None:
            ramp = ramp * _ease(p["stop_at"] - tau, 0.0, 0.5)
        out = np.stack((p["v_forward"] * ramp, p["v_left"] * ramp, p["omega"] * ramp), -1)
        if p.get("turn_angle"):
            start, length = p["turn_start"], p["turn_time"]
            inside = (tau >= start) & (tau <= start + length)
            shape = 1 - np.cos(2 * np.pi * (tau - start) / length)
            out[:, 2] += np.where(inside, p["turn_angle"] / length * shape, 0.0)
        return out

    return velocity


def _foot_path(t: np.ndarray, side: int, p: Mapping[str, Any],
               root_at: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
               effort: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Ankle target (T, 3), foot yaw and extra pitch (T,), planted mask (T,) of one foot.

    Stance k lasts from landing (k − φ₀)·cycle to lift-off (k + duty − φ₀)·cycle, planted
    at P_k (its mid-stance root position plus ± ``width`` sideways). From a standing start
    the swing in progress at τ = 0 lifts off at 0 and lands no sooner than 60 % of a swing
    time later (but before the next lift-off). Late in stance the heel comes up: the foot
    pitches about its toe.
    """
    cycle, duty = p["cycle"], p["duty"]
    offset = p["phase"] + 0.5 * side
    first = math.floor(float(t.min()) / cycle + offset) - 2
    ks = np.arange(first, math.floor(float(t.max()) / cycle + offset) + 3)
    plant_xz, plant_yaw = root_at((ks + duty / 2 - offset) * cycle)
    plant_xz = plant_xz + _rotate_xz(np.array([_SIGN[side] * p["width"], 0.0]), plant_yaw)
    lift_off = (ks + duty - offset) * cycle
    landing = (ks + 1 - offset) * cycle
    under_way = (lift_off < 0) & (landing > 0)
    lift_off = np.where(under_way, 0.0, lift_off)
    soonest = np.minimum(0.6 * (1 - duty) * cycle, landing + 0.8 * duty * cycle)
    landing = np.where(under_way, np.maximum(landing, soonest), landing)

    i = np.clip(np.searchsorted(lift_off, t, side="right") - 1, 0, len(ks) - 2)
    u = np.clip((t - lift_off[i]) / (landing[i] - lift_off[i]), 0.0, 1.0)
    planted = (t < lift_off[i]) | (t >= landing[i])
    here, there = plant_xz[i], plant_xz[i + 1]
    yaw = plant_yaw[i] + _smoothstep(u) * (plant_yaw[i + 1] - plant_yaw[i])
    step = np.linalg.norm(there - here, axis=-1) + 0.15 * np.abs(plant_yaw[i + 1] - plant_yaw[i])
    short = np.clip(step / 0.25, 0.0, 1.0)
    ankle = np.empty((len(t), 3))
    ankle[:, [0, 2]] = here + _smoothstep(u)[:, None] * (there - here)
    ankle[:, 1] = ANKLE_HEIGHT[side] + (p["lift"] * short * (0.5 + 0.5 * effort)
                                        * np.sin(np.pi * u ** p["lift_shape"]))
    # the stance after landing i runs to lift-off i + 1; the heel rises in its last 45 %.
    stance_end = np.append(lift_off[1:], np.inf)[i]
    stance_part = np.where(t >= landing[i], (t - landing[i]) / (stance_end - landing[i]), 0.0)
    roll = np.where(planted, _ease(stance_part, 0.55, 1.0), 1 - _ease(u, 0.0, 0.5))
    pitch = p["heel_off"] * roll * short * effort
    length = BONE_LENGTHS[10 + side]
    ahead = length * (math.cos(_FOOT_TILT) - np.cos(_FOOT_TILT + pitch))
    ankle[:, [0, 2]] += ahead[:, None] * np.stack((np.sin(yaw), np.cos(yaw)), -1)
    ankle[:, 1] += length * (np.sin(_FOOT_TILT + pitch) - math.sin(_FOOT_TILT))
    return ankle, yaw, pitch, planted


def _locomotion(t: np.ndarray, p: Mapping[str, Any]) -> _Track:
    """Gait from a velocity profile: plants at the mid-stance root position, arc swings.

    Foot s has phase φ = τ/cycle + phase + s/2 (mod 1), stance while φ < duty (see
    :func:`_foot_path`). Stance k is planted at P_k = root(m_k) + R(heading(m_k))·(±width, 0),
    m_k its mid-stance time, so the foot stays put while the root passes over it. The swing
    goes from P_k to P_{k+1} (smoothstep in x/z, lift · sin(π u^γ) in height; γ < 1 lifts the
    heel early, as in running), the lift scaled down for short steps and slow movement.
    The pelvis is lowered wherever a stance leg (``reach`` × its length) would fall short.
    """
    velocity = _velocity(p)
    cycle = p["cycle"]
    dt = 0.01
    lo = min(float(t.min()), 0.0) - 2 * cycle
    grid = np.arange(lo, float(t.max()) + 2 * cycle + dt, dt)
    zero = int(np.argmin(np.abs(grid)))
    rates = velocity(grid)
    heading_g = _integrate(rates[:, 2], dt, zero)
    world_v = _rotate_xz(np.stack((rates[:, 1], rates[:, 0]), -1), heading_g)
    xz_g = _integrate(world_v, dt, zero)

    def root_at(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xz = np.stack([np.interp(tau, grid, xz_g[:, i]) for i in (0, 1)], -1)
        return xz, np.interp(tau, grid, heading_g)

    n = len(t)
    root_xz, heading = root_at(t)
    rates = velocity(t)
    activity = np.clip(np.hypot(rates[:, 0], rates[:, 1]) + 0.3 * np.abs(rates[:, 2]), 0.0, 1.0)
    cruise = math.hypot(p["v_forward"], p["v_left"])
    # steps grow with speed: a standing start begins with low, short-looking steps.
    effort = np.hypot(rates[:, 0], rates[:, 1]) / cruise if cruise > 0 else activity
    ankles = np.zeros((n, 2, 3))
    foot_yaw = np.zeros((n, 2))
    foot_pitch = np.zeros((n, 2))
    stance = np.zeros((n, 2), dtype=bool)
    phase = np.zeros((n, 2))
    for side in (0, 1):
        ankles[:, side], foot_yaw[:, side], foot_pitch[:, side], stance[:, side] = _foot_path(
            t, side, p, root_at, effort)
        phase[:, side] = (t / cycle + p["phase"] + 0.5 * side) % 1.0

    hips = root_xz[:, None, :] + _rotate_xz(
        np.broadcast_to(_HIP_OFFSET[:, [0, 2]], (n, 2, 2)), heading[:, None])
    reach = np.hypot(*(ankles[:, :, [0, 2]] - hips).transpose(2, 0, 1))
    legs = p["reach"] * (_THIGH + _SHIN)
    highest = ANKLE_HEIGHT + np.sqrt(np.clip(legs**2 - reach**2, 0.0, None))
    highest = np.where(stance, highest, np.inf).min(axis=1)
    pelvis_y = np.minimum(STAND_HEIGHT, highest)
    pelvis_y = gaussian_filter1d(minimum_filter1d(pelvis_y, 3, mode="nearest"), 1.0,
                                 mode="nearest")

    swing = np.cos(2 * np.pi * phase)             # +1 when that foot touches down (forward)
    tilt = np.zeros((n, 3))
    tilt[:, 1] = 0.06 * activity * swing[:, 0]    # pelvis yaws with the forward leg
    spine = np.zeros((n, 3))
    spine[:, 0] = 0.03 + p["lean"] * activity
    spine[:, 1] = -tilt[:, 1]                     # shoulders counter-rotate
    arms = np.empty((n, 2, 2, 3))
    for side in (0, 1):
        flex = -p["arm_swing"] * activity * swing[:, side]   # opposite arm to the leg
        upper = _arm_direction(side, flex, 0.14)
        arms[:, side, 0] = upper
        arms[:, side, 1] = _bend(upper, p["elbow"], _FORWARD)
    return _Track(root_xz=root_xz, heading=heading, pelvis_y=pelvis_y, pelvis_tilt=tilt,
                  ankles=ankles, foot_yaw=foot_yaw, foot_pitch=foot_pitch, spine=spine,
                  head=np.zeros((n, 2)), arms=arms, upright=np.zeros((n, 2)))


def _gait(rng: np.random.Generator, *, cycle: tuple[float, float], duty: float = 0.6,
          lift: tuple[float, float] = (0.09, 0.13), width: float = _STANCE_X,
          reach: float = 0.985, arm_swing: tuple[float, float] = (0.25, 0.45),
          elbow: tuple[float, float] = (0.25, 0.45), lean: float = 0.0,
          lift_shape: float = 1.0, heel_off: float = 0.6) -> dict[str, Any]:
    return {"cycle": rng.uniform(*cycle), "duty": duty, "lift": rng.uniform(*lift),
            "heel_off": heel_off,
            # from standing, one foot (chosen here) lands at τ = 0 and the other steps first
            "width": width, "reach": reach, "phase": float(rng.choice([0.0, 0.5])),
            "arm_swing": rng.uniform(*arm_swing), "elbow": rng.uniform(*elbow), "lean": lean,
            "lift_shape": lift_shape, "ramp_in": rng.uniform(0.2, 0.6)}


def _stop(duration: float, stop_at_end: bool) -> float | None:
    return duration if stop_at_end else None


def _sample_walk(direction: str) -> Callable[..., dict[str, Any]]:
    def sample(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
        if direction == "forward":
            p = _gait(rng, cycle=(0.95, 1.15))
            v = (rng.uniform(0.9, 1.5), 0.0)
        elif direction == "backward":
            p = _gait(rng, cycle=(0.9, 1.1), lift=(0.07, 0.1), arm_swing=(0.1, 0.25))
            v = (-rng.uniform(0.55, 0.9), 0.0)
        else:
            p = _gait(rng, cycle=(0.9, 1.1), lift=(0.07, 0.1), arm_swing=(0.0, 0.1))
            speed = rng.uniform(0.45, 0.7)
            # feet never cross: half-width grows with the lateral stride (speed × cycle)
            p["width"] = 0.17 + speed * p["cycle"] / 4
            v = (0.0, speed if direction == "left" else -speed)
        p.update(v_forward=v[0], v_left=v[1], omega=0.0, stop_at=_stop(duration, stop_at_end))
        return p

    return sample


def _sample_run(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
    p = _gait(rng, cycle=(0.65, 0.78), duty=0.35, lift=(0.17, 0.23), reach=0.95,
              arm_swing=(0.3, 0.45), elbow=(1.6, 1.8), lean=0.15, lift_shape=0.5)
    p.update(v_forward=rng.uniform(2.4, 3.4), v_left=0.0, omega=0.0,
             stop_at=_stop(duration, stop_at_end), ramp_in=rng.uniform(0.3, 0.5))
    return p


def _sample_turn(direction: str) -> Callable[..., dict[str, Any]]:
    def sample(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
        p = _gait(rng, cycle=(0.75, 0.9), lift=(0.06, 0.09), arm_swing=(0.0, 0.1))
        angle = math.radians(rng.uniform(90, 180))
        length = min(angle / math.radians(rng.uniform(100, 160)), duration - 0.4)
        start = rng.uniform(0.1, max(0.1, duration - length - 0.3))
        p.update(v_forward=0.0, v_left=0.0, omega=0.0, stop_at=None,
                 turn_angle=angle if direction == "left" else -angle,
                 turn_start=start, turn_time=length)
        return p

    return sample


def _sample_circle(rng: np.random.Generator, duration: float,
                   stop_at_end: bool) -> dict[str, Any]:
    p = _gait(rng, cycle=(0.95, 1.1), arm_swing=(0.2, 0.35))
    total = math.radians(rng.uniform(330, 390)) * rng.choice([-1.0, 1.0])
    moving = duration - p["ramp_in"] / 2 - (0.25 if stop_at_end else 0.0)
    p.update(v_forward=rng.uniform(0.9, 1.3), v_left=0.0, omega=total / moving,
             stop_at=_stop(duration, stop_at_end))
    return p


# -------------------------------------------------------------------- jump, squat, kick

def _sample_jump(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
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


def _jump(t: np.ndarray, p: Mapping[str, Any]) -> _Track:
    """Crouch (0.35 s), push off (0.15 s, reaching take-off speed v₀ = g·T_f/2), ballistic
    flight y = y₀ + v₀s − g s²/2 for T_f, landing absorption (0.25 s), recovery (0.35 s).
    In flight the feet follow the pelvis and tuck up; a jump may travel a little forward."""
    track = _idle(t, p["sway"])
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
        y[down] = STAND_HEIGHT - crouch * _ease(t[down], t0, t1)
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
        y[rise] = STAND_HEIGHT - 0.7 * crouch * (1 - _ease(t[rise], t4, t5))
        forward += p["distance"] * _ease(t, t2, t3)
        arm += _keyframes(t, [t0, t1, t2 + 0.1, t3, t4, t5 + 0.2],
                          np.array([0.0, -0.6, 1.0, 0.3, 0.4, 0.0]))
        lean += _keyframes(t, [t0, t1, t2, t3, t4, t5], np.array([0, 1, 0.2, 0.2, 0.7, 0]))
    track.pelvis_y = y
    track.root_xz[:, 1] = forward
    track.ankles[:, :, 1] += feet_up[:, None]
    track.ankles[:, :, 2] += forward[:, None]
    track.spine[:, 0] += 0.35 * lean
    for side in (0, 1):
        upper = _arm_direction(side, p["arm_swing"] * arm, 0.14)
        track.arms[:, side, 0] = upper
        track.arms[:, side, 1] = _bend(upper, 0.3, _FORWARD)
    return track


def _sample_squat(rng: np.random.Generator, duration: float,
                  stop_at_end: bool) -> dict[str, Any]:
    start = rng.uniform(0.1, 0.3)
    down, hold, up = rng.uniform(0.6, 0.9), rng.uniform(0.2, 0.6), rng.uniform(0.6, 0.9)
    gap = rng.uniform(0.2, 0.4)
    count = int(max(1, min(3, (duration - start) // (down + hold + up + gap))))
    return {"start": start, "count": count, "down": down, "hold": hold, "up": up, "gap": gap,
            "depth": rng.uniform(0.28, 0.42), "arms_forward": rng.uniform(0.6, 1.2),
            "sway": rng.uniform(0, 2 * np.pi)}


def _squat(t: np.ndarray, p: Mapping[str, Any]) -> _Track:
    """Pelvis lowered by ``depth`` and moved back while the torso leans forward; feet stay
    planted (slightly wider), knees bend forward by IK; arms reach forward for balance."""
    track = _idle(t, p["sway"])
    depth = np.zeros_like(t)
    one = p["down"] + p["hold"] + p["up"] + p["gap"]
    for j in range(p["count"]):
        t0 = p["start"] + j * one
        t1 = t0 + p["down"]
        t2 = t1 + p["hold"]
        depth += _ease(t, t0, t1) - _ease(t, t2, t2 + p["up"])
    track.pelvis_y = track.pelvis_y - p["depth"] * depth
    track.root_xz[:, 1] = -0.3 * p["depth"] * depth
    track.ankles[:, :, 0] *= 1.3
    track.pelvis_tilt[:, 0] = 0.3 * depth
    track.spine[:, 0] += 0.45 * depth
    for side in (0, 1):
        upper = _arm_direction(side, p["arms_forward"] * depth + 0.05, 0.14)
        track.arms[:, side, 0] = upper
        track.arms[:, side, 1] = _bend(upper, 0.2, _FORWARD)
    return track


def _sample_kick(side: int) -> Callable[..., dict[str, Any]]:
    def sample(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
        start, windup, gap = rng.uniform(0.1, 0.4), rng.uniform(0.25, 0.4), rng.uniform(0.2, 0.5)
        one = windup + 0.68                       # lift, wind-up, strike, return, plant
        count = 2 if start + 2 * one + gap <= duration else 1
        return {"side": side, "start": start, "count": count, "windup": windup, "gap": gap,
                "reach": rng.uniform(0.55, 0.7), "height": rng.uniform(0.35, 0.55),
                "sway": rng.uniform(0, 2 * np.pi)}

    return sample


def _kick(t: np.ndarray, p: Mapping[str, Any]) -> _Track:
    """Wind-up (foot back and up), strike in 0.18 s to ``reach`` in front of the hip at ankle
    height ``height``, return and plant; the pelvis shifts over the standing foot."""
    track = _idle(t, p["sway"])
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
    track.root_xz[:, 0] = -_SIGN[side] * 0.06 * weight
    track.pelvis_y = track.pelvis_y - 0.03 * weight
    track.spine[:, 0] -= 0.25 * lean
    for arm_side in (0, 1):
        upper = _arm_direction(arm_side, 0.1, 0.14 + 0.35 * weight)
        track.arms[:, arm_side, 0] = upper
        track.arms[:, arm_side, 1] = _bend(upper, 0.3, _FORWARD)
    return track


# -------------------------------------------------------------------------------------- arms

def _slerp_directions(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Great-circle interpolation of unit vectors, weight ``w`` (…,) toward b."""
    a, b = np.broadcast_arrays(a, b)
    dot = np.clip((a * b).sum(-1), -1.0, 1.0)
    omega = np.arccos(dot)[..., None]
    w = np.asarray(w, float)[..., None]
    small = omega < 1e-6
    sin_omega = np.where(small, 1.0, np.sin(omega))
    out = np.where(small, a + w * (b - a),
                   (np.sin((1 - w) * omega) * a + np.sin(w * omega) * b) / sin_omega)
    return _normalize(out)


def _blend_arm(track: _Track, side: int, target: np.ndarray, weight: np.ndarray) -> None:
    """Move arm ``side`` from its current directions toward ``target`` (T, 2, 3)."""
    track.arms[:, side] = _slerp_directions(track.arms[:, side], target, weight[:, None])


def _sample_wave(sides: tuple[int, ...]) -> Callable[..., dict[str, Any]]:
    def sample(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
        lower = bool(rng.random() < 0.5) and duration >= 2.8
        return {"sides": list(sides), "frequency": rng.uniform(2.0, 3.0),
                "amplitude": rng.uniform(0.45, 0.7), "phase": rng.uniform(0, 2 * np.pi),
                "elevation": rng.uniform(0.15, 0.6), "raise_time": rng.uniform(0.3, 0.5),
                "start": rng.uniform(0.0, 0.2), "lower_at": duration - 0.4 if lower else None}

    return sample


def _wave(t: np.ndarray, p: Mapping[str, Any]) -> _Track:
    """Upper arm out to the side and up by ``elevation``, forearm up, rocking side to side
    about the forward axis by ± ``amplitude`` at ``frequency`` Hz. The arm is raised (and
    lowered) through a sideways pose, not through the front."""
    track = _idle(t)                      # only the arms are used
    half = p["raise_time"] / 2
    level = _ease(t, p["start"], p["start"] + half) + _ease(t, p["start"] + half,
                                                              p["start"] + 2 * half)
    if p["lower_at"] is not None:
        lower = p["lower_at"]
        level = level - _ease(t, lower, lower + 0.2) - _ease(t, lower + 0.2, lower + 0.4)
    rock = p["amplitude"] * np.sin(2 * np.pi * p["frequency"] * t + p["phase"])
    for side in p["sides"]:
        e = p["elevation"]
        upper = _normalize(np.array([_SIGN[side] * math.cos(e), math.sin(e), 0.3]))
        forearm = _normalize(np.stack((np.sin(rock), np.cos(rock), np.full_like(t, 0.15)), -1))
        target = np.stack((np.broadcast_to(upper, forearm.shape), forearm), 1)
        sideways = _normalize(np.array([[_SIGN[side], -0.1, 0.1], [_SIGN[side] * 0.7, 0.7, 0.1]]))
        rest = track.arms[:, side].copy()
        first = _slerp_directions(rest, sideways, np.clip(level, 0, 1)[:, None])
        track.arms[:, side] = _slerp_directions(first, target, np.clip(level - 1, 0, 1)[:, None])
        track.upright[:, side] = 1.0                  # "up" is against gravity
    return track


def _sample_raise(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
    start, up = rng.uniform(0.0, 0.3), rng.uniform(0.5, 0.9)
    down = rng.uniform(0.5, 0.9)
    lower = duration - start - up - down >= 0.8
    if stop_at_end:        # followed by another concept: always lower, keeping a 0.6-s hold
        lower = True
        up = down = min(up, down, (duration - start - 0.7) / 2)
    return {"start": start, "up": up, "down": down,
            "lower_at": duration - down - 0.1 if lower else None,
            "abduct": rng.uniform(2.8, 3.05), "flex": rng.uniform(0.0, 0.3)}


def _raise_arms(t: np.ndarray, p: Mapping[str, Any]) -> _Track:
    """Both arms raised sideways (abduction to ≈ 160–175°) above the head, held, and lowered
    again at the end if there is time (the wrists pass the head for ≥ 0.5 s either way)."""
    track = _idle(t)                      # only the arms are used
    level = _ease(t, p["start"], p["start"] + p["up"])
    if p["lower_at"] is not None:
        level = level * (1 - _ease(t, p["lower_at"], p["lower_at"] + p["down"]))
    for side in (0, 1):
        upper = _arm_direction(side, p["flex"] * level, 0.14 + (p["abduct"] - 0.14) * level)
        track.arms[:, side, 0] = upper
        track.arms[:, side, 1] = _bend(upper, 0.15, _UP)
    track.upright[:] = 1.0                            # "up" is against gravity
    return track


def _arm_ik(side: int, wrist: np.ndarray) -> np.ndarray:
    """Upper-arm and forearm directions (T, 2, 3) reaching ``wrist`` (torso frame,
    relative to spine3), elbow pointing down and out."""
    hint = np.array([_SIGN[side] * 0.5, -1.0, -0.2])
    upper, lower = _two_bone(wrist - _SHOULDER[side], _UPPER_ARM[side], _FOREARM[side], hint)
    return np.stack((upper, lower), axis=-2)


def _sample_clap(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
    return {"frequency": rng.uniform(1.6, 2.6), "height": rng.uniform(-0.1, 0.05),
            "distance": rng.uniform(0.25, 0.33), "open": rng.uniform(0.14, 0.24),
            "start": rng.uniform(0.0, 0.2)}


def _clap(t: np.ndarray, p: Mapping[str, Any]) -> _Track:
    """Hands brought in front of the chest, the wrists closing to 6 cm (touching palms) and
    opening to 2 × ``open`` at ``frequency`` Hz."""
    track = _idle(t)                      # only the arms are used
    ready = _ease(t, p["start"], p["start"] + 0.4)
    local = np.maximum(t - p["start"] - 0.4, 0.0)
    half_gap = 0.03 + (p["open"] - 0.03) * 0.5 * (1 + np.cos(2 * np.pi * p["frequency"] * local))
    half_gap = np.where(t < p["start"] + 0.4, p["open"], half_gap)
    for side in (0, 1):
        wrist = np.stack((_SIGN[side] * half_gap, np.full_like(t, p["height"]),
                          np.full_like(t, p["distance"])), -1)
        _blend_arm(track, side, _arm_ik(side, wrist), ready)
    return track


def _sample_punch(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
    start, pause, strike = rng.uniform(0.0, 0.2), rng.uniform(0.15, 0.35), rng.uniform(0.1, 0.14)
    period = strike + 0.3 + pause                 # extend, hold, retract, pause
    count = int(max(1, min(4, (duration - start - 0.35) // period)))
    return {"start": start, "pause": pause, "count": count, "reach": rng.uniform(0.46, 0.51),
            "strike": strike, "height": rng.uniform(-0.05, 0.05)}


def _punch(t: np.ndarray, p: Mapping[str, Any]) -> _Track:
    """Right fist raised to a guard in front of the chin, then ``count`` straight punches:
    extend in ``strike`` s to ``reach`` in front of the shoulder, hold 0.05 s, retract."""
    track = _idle(t)                      # only the arms are used
    side = 1
    guard = np.array([-0.12, 0.1, 0.22])
    strike = _SHOULDER[side] + np.array([0.03, p["height"], p["reach"]])
    extension = np.zeros_like(t)
    for j in range(p["count"]):
        t0 = p["start"] + 0.35 + j * (0.3 + p["strike"] + p["pause"])
        extension += _keyframes(t, [t0, t0 + p["strike"], t0 + p["strike"] + 0.05,
                                    t0 + p["strike"] + 0.3], np.array([0.0, 1, 1, 0]))
    wrist = guard + extension[:, None] * (strike - guard)
    ready = _ease(t, p["start"], p["start"] + 0.35)
    _blend_arm(track, side, _arm_ik(side, wrist), ready)
    return track


# ------------------------------------------------------------------------------- concepts

@dataclass(frozen=True)
class Concept:
    """One motion concept: the body parts it owns, its minimum duration, and its phrasing
    (third-person and gerund forms, paired, for caption templates)."""

    name: str
    parts: frozenset[str]
    min_duration: float
    phrases: tuple[tuple[str, str], ...]
    sample: Callable[[np.random.Generator, float, bool], dict[str, Any]] = field(repr=False)
    motion: Callable[[np.ndarray, Mapping[str, Any]], _Track] = field(repr=False)

    @property
    def moves_root(self) -> bool:
        return "root" in self.parts


_LOWER = frozenset({"root", "legs", "torso"})


def _sides(word: str) -> tuple[tuple[str, str], ...]:
    return (
        (f"walks to the {word}", f"walking to the {word}"),
        (f"sidesteps to the {word}", f"sidestepping to the {word}"),
        (f"steps sideways to the {word}", f"stepping sideways to the {word}"),
        (f"shuffles {word}", f"shuffling {word}"),
    )


def _turns(word: str) -> tuple[tuple[str, str], ...]:
    return (
        (f"turns {word}", f"turning {word}"),
        (f"turns to the {word}", f"turning to the {word}"),
        (f"pivots to the {word}", f"pivoting to the {word}"),
        (f"turns {word} in place", f"turning {word} in place"),
    )


def _kicks(word: str) -> tuple[tuple[str, str], ...]:
    return (
        (f"kicks with the {word} leg", f"kicking with the {word} leg"),
        (f"kicks forward with the {word} foot", f"kicking forward with the {word} foot"),
        (f"kicks the {word} leg forward", f"kicking the {word} leg forward"),
        (f"does a kick with the {word} foot", f"doing a kick with the {word} foot"),
    )


def _waves(word: str) -> tuple[tuple[str, str], ...]:
    return (
        (f"waves the {word} hand", f"waving the {word} hand"),
        (f"waves with the {word} hand", f"waving with the {word} hand"),
        (f"raises the {word} hand and waves", f"raising the {word} hand and waving"),
        (f"waves hello with the {word} arm", f"waving hello with the {word} arm"),
    )


def _concepts() -> dict[str, Concept]:
    both_arms = frozenset({"left_arm", "right_arm"})
    specs = [
        Concept("walk_forward", _LOWER, 2.0, (
            ("walks forward", "walking forward"),
            ("walks straight ahead", "walking straight ahead"),
            ("takes several steps forward", "taking several steps forward"),
            ("strolls forward", "strolling forward")), _sample_walk("forward"), _locomotion),
        Concept("walk_backward", _LOWER, 2.0, (
            ("walks backward", "walking backward"),
            ("steps backwards", "stepping backwards"),
            ("walks backwards slowly", "walking backwards slowly"),
            ("takes a few steps back", "taking a few steps back")),
            _sample_walk("backward"), _locomotion),
        Concept("walk_left", _LOWER, 2.0, _sides("left"), _sample_walk("left"), _locomotion),
        Concept("walk_right", _LOWER, 2.0, _sides("right"), _sample_walk("right"), _locomotion),
        Concept("run", _LOWER, 1.5, (
            ("runs forward", "running forward"),
            ("jogs forward quickly", "jogging forward quickly"),
            ("runs straight ahead", "running straight ahead"),
            ("sprints forward", "sprinting forward")), _sample_run, _locomotion),
        Concept("turn_left", _LOWER, 1.8, _turns("left"), _sample_turn("left"), _locomotion),
        Concept("turn_right", _LOWER, 1.8, _turns("right"), _sample_turn("right"), _locomotion),
        Concept("walk_circle", _LOWER, 3.5, (
            ("walks in a circle", "walking in a circle"),
            ("walks around in a circle", "walking around in a circle"),
            ("walks in a small circle", "walking in a small circle"),
            ("circles around", "circling around")), _sample_circle, _locomotion),
        Concept("jump", _LOWER, 1.6, (
            ("jumps up and down", "jumping up and down"),
            ("jumps in place", "jumping in place"),
            ("jumps into the air", "jumping into the air"),
            ("hops up", "hopping up")), _sample_jump, _jump),
        Concept("squat", _LOWER, 2.0, (
            ("squats down", "squatting down"),
            ("squats down and stands back up", "squatting down and standing back up"),
            ("does a squat", "doing a squat"),
            ("bends the knees and squats", "bending the knees and squatting")),
            _sample_squat, _squat),
        Concept("kick_left", _LOWER, 1.4, _kicks("left"), _sample_kick(0), _kick),
        Concept("kick_right", _LOWER, 1.4, _kicks("right"), _sample_kick(1), _kick),
        Concept("wave_left", frozenset({"left_arm"}), 2.0, _waves("left"),
                _sample_wave((0,)), _wave),
        Concept("wave_right", frozenset({"right_arm"}), 2.0, _waves("right"),
                _sample_wave((1,)), _wave),
        Concept("wave_both", both_arms, 2.0, (
            ("waves both hands", "waving both hands"),
            ("waves with both arms", "waving with both arms"),
            ("waves both hands above the head", "waving both hands above the head"),
            ("waves both arms in the air", "waving both arms in the air")),
            _sample_wave((0, 1)), _wave),
        Concept("raise_arms", both_arms, 2.0, (
            ("raises both arms", "raising both arms"),
            ("lifts the arms above the head", "lifting the arms above the head"),
            ("raises the arms up high", "raising the arms up high"),
            ("puts both hands up", "putting both hands up")), _sample_raise, _raise_arms),
        Concept("clap", both_arms, 2.0, (
            ("claps", "clapping"),
            ("claps the hands", "clapping the hands"),
            ("claps several times", "clapping several times"),
            ("applauds", "applauding")), _sample_clap, _clap),
        Concept("punch", frozenset({"right_arm"}), 1.6, (
            ("punches forward with the right hand", "punching forward with the right hand"),
            ("throws punches with the right fist", "throwing punches with the right fist"),
            ("punches with the right arm", "punching with the right arm"),
            ("jabs forward with the right fist", "jabbing forward with the right fist")),
            _sample_punch, _punch),
    ]
    return {c.name: c for c in specs}


#: name → concept. Locomotion-like concepts own root, legs and torso; arm concepts own arms.
CONCEPTS: dict[str, Concept] = _concepts()


def _check_concept(name: str) -> Concept:
    if name not in CONCEPTS:
        raise ValueError(f"unknown concept {name!r}; known: {', '.join(CONCEPTS)}")
    return CONCEPTS[name]


#: simultaneous pairs that are another concept already.
_SAME_AS = {frozenset({"wave_left", "wave_right"}): "wave_both"}


def can_be_simultaneous(first: str, second: str) -> bool:
    """True when the two concepts own disjoint body parts and are not together another
    concept (waving the left and the right hand is ``wave_both``)."""
    a, b = _check_concept(first), _check_concept(second)
    return (first != second and not (a.parts & b.parts)
            and frozenset({first, second}) not in _SAME_AS)


# ---------------------------------------------------------------------------- clip specs

@dataclass(frozen=True)
class ClipSpec:
    """What to generate: concepts, how they combine, total duration (s) and overrides.

    ``params`` may hold ``initial_heading`` (rad), ``start_xz`` (m) and, per concept name, a
    dict overriding that concept's sampled parameters (unknown keys are an error).
    ``segment_durations`` (sequential only) defaults to a split proportional to the
    concepts' minimum durations.
    """

    concepts: tuple[str, ...]
    composition: str = "single"
    duration: float = 4.0
    params: Mapping[str, Any] = field(default_factory=dict)
    segment_durations: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if isinstance(self.concepts, str):
            raise ValueError(f"concepts must be a sequence of names, got the string "
                             f"{self.concepts!r}")
        object.__setattr__(self, "concepts", tuple(self.concepts))
        found = [_check_concept(name) for name in self.concepts]
        if self.composition not in COMPOSITIONS:
            raise ValueError(f"unknown composition {self.composition!r}; known: {COMPOSITIONS}")
        expected = 1 if self.composition == "single" else 2
        if len(self.concepts) != expected:
            raise ValueError(f"a {self.composition} clip has {expected} concept(s), got "
                             f"{len(self.concepts)}: {self.concepts}")
        if not MIN_DURATION <= self.duration <= MAX_DURATION:
            raise ValueError(f"duration must be in [{MIN_DURATION}, {MAX_DURATION}] s, got "
                             f"{self.duration}")
        if self.composition == "simultaneous" and not can_be_simultaneous(*self.concepts):
            raise ValueError(f"{self.concepts[0]!r} and {self.concepts[1]!r} cannot be "
                             "simultaneous: they share body parts or together are "
                             f"{_SAME_AS.get(frozenset(self.concepts), 'one concept')!r}")
        if self.composition != "sequential":
            if self.segment_durations is not None:
                raise ValueError("segment_durations is only for sequential clips")
            for concept in found:
                _check_long_enough(concept, self.duration)
            return
        if self.segment_durations is None:
            mins = np.array([c.min_duration for c in found])
            durations = tuple(float(d) for d in self.duration * mins / mins.sum())
            object.__setattr__(self, "segment_durations", durations)
        durations = tuple(float(d) for d in self.segment_durations)
        object.__setattr__(self, "segment_durations", durations)
        if len(durations) != len(found) or abs(sum(durations) - self.duration) > 1e-6:
            raise ValueError(f"segment_durations {durations} must have one entry per concept "
                             f"and sum to duration {self.duration}")
        for concept, duration in zip(found, durations, strict=True):
            _check_long_enough(concept, duration)

    @property
    def n_frames(self) -> int:
        """Raw joint frames: duration × 20 fps + 1 (features then have duration × 20)."""
        return int(round(self.duration * FPS)) + 1


def _check_long_enough(concept: Concept, duration: float) -> None:
    if duration < concept.min_duration - 1e-9:
        raise ValueError(f"concept {concept.name!r} needs at least {concept.min_duration} s, "
                         f"got {duration:.3f} s")


DEFAULT_COMPOSITION_WEIGHTS: dict[str, float] = {
    "single": 0.5, "simultaneous": 0.3, "sequential": 0.2}


def _frames(seconds: float) -> float:
    """Round a duration to whole frames."""
    return round(seconds * FPS) / FPS


def sample_clip_spec(rng: np.random.Generator, *, allow_compositions: bool = True,
                     concept_pool: Sequence[str] | None = None,
                     composition_weights: Mapping[str, float] | None = None) -> ClipSpec:
    """Draw a random clip specification: a composition kind (by ``composition_weights``,
    default 50 % single, 30 % simultaneous, 20 % sequential), concepts from ``concept_pool``
    (default all), a duration in [2, 6] s long enough for them, a random initial heading and
    start position."""
    pool = list(concept_pool) if concept_pool is not None else list(CONCEPTS)
    if not pool:
        raise ValueError("concept_pool is empty")
    for name in pool:
        _check_concept(name)
    weights = dict(composition_weights or DEFAULT_COMPOSITION_WEIGHTS)
    if not allow_compositions:
        weights = {"single": 1.0}
    for kind, weight in weights.items():
        if kind not in COMPOSITIONS:
            raise ValueError(f"unknown composition {kind!r}; known: {COMPOSITIONS}")
        if weight < 0:
            raise ValueError(f"composition weight for {kind!r} is negative: {weight}")
    kinds = [k for k in COMPOSITIONS if weights.get(k, 0.0) > 0]
    if not kinds:
        raise ValueError(f"composition weights select nothing: {weights}")
    probabilities = np.array([weights[k] for k in kinds]) / sum(weights[k] for k in kinds)
    kind = str(rng.choice(kinds, p=probabilities))
    params = {"initial_heading": float(rng.uniform(-np.pi, np.pi)),
              "start_xz": [float(v) for v in rng.uniform(-1.0, 1.0, 2)]}

    if kind == "single":
        name = str(rng.choice(pool))
        shortest = max(MIN_DURATION, CONCEPTS[name].min_duration)
        duration = _frames(rng.uniform(shortest, MAX_DURATION))
        return ClipSpec((name,), "single", duration, params)

    if kind == "simultaneous":
        pairs = [(a, b) for a in pool for b in pool if a < b and can_be_simultaneous(a, b)]
        if not pairs:
            raise ValueError(f"no two concepts in {pool} own disjoint body parts")
        a, b = pairs[int(rng.integers(len(pairs)))]
        first, second = sorted((a, b), key=lambda n: (not CONCEPTS[n].moves_root,
                                                      "left_arm" not in CONCEPTS[n].parts))
        shortest = max(MIN_DURATION, CONCEPTS[a].min_duration, CONCEPTS[b].min_duration)
        duration = _frames(rng.uniform(shortest, MAX_DURATION))
        return ClipSpec((first, second), "simultaneous", duration, params)

    pairs = [(a, b) for a in pool for b in pool
             if a != b and CONCEPTS[a].min_duration + CONCEPTS[b].min_duration <= MAX_DURATION]
    if not pairs:
        raise ValueError(f"no two different concepts in {pool} fit in {MAX_DURATION} s")
    a, b = pairs[int(rng.integers(len(pairs)))]
    mins = np.array([CONCEPTS[a].min_duration, CONCEPTS[b].min_duration])
    extra = rng.uniform(0.0, MAX_DURATION - mins.sum())
    share = rng.uniform(0.3, 0.7)
    first = _frames(mins[0] + extra * share)
    second = _frames(mins[1] + extra * (1 - share))
    duration = _frames(first + second)
    return ClipSpec((a, b), "sequential", duration, params, (first, duration - first))


# ----------------------------------------------------------------------------- composing

def _concept_track(name: str, t: np.ndarray, p: Mapping[str, Any], sway: float) -> _Track:
    """A single concept's track at the origin: its own motion for root-owning concepts,
    idle standing with the concept's arms otherwise."""
    concept = CONCEPTS[name]
    track = concept.motion(t, p)
    if concept.moves_root:
        return track
    base = _idle(t, sway)
    for part in concept.parts:
        _take_part(base, track, part)
    return base


def _simultaneous(names: Sequence[str], t: np.ndarray, params: Mapping[str, Mapping[str, Any]],
                  sway: float) -> tuple[_Track, dict[str, str]]:
    """Each body part from the concept that owns it; a root-owning concept's secondary
    parts (its arm swing) fill parts nobody owns; idle standing fills the rest."""
    owners = {part: "idle" for part in BODY_PARTS}
    base_name = next((n for n in names if CONCEPTS[n].moves_root), None)
    if base_name is None:
        track = _idle(t, sway)
    else:
        track = CONCEPTS[base_name].motion(t, params[base_name])
        owners = {part: base_name for part in BODY_PARTS}
    for name in names:
        if name == base_name:
            continue
        own = CONCEPTS[name].motion(t, params[name])
        for part in CONCEPTS[name].parts:
            _take_part(track, own, part)
            owners[part] = name
    return track, owners


def _blend(into: _Track, other: _Track, frames: np.ndarray, weight: np.ndarray) -> None:
    """Cross-fade ``into`` toward ``other`` on ``frames`` (arm directions along great
    circles, everything else linearly)."""
    for f in fields(into):
        if f.name == "arms":
            continue
        a = getattr(into, f.name)
        w = weight.reshape((-1,) + (1,) * (a.ndim - 1))
        a[frames] = (1 - w) * a[frames] + w * getattr(other, f.name)
    into.arms[frames] = _slerp_directions(into.arms[frames], other.arms,
                                          weight[:, None, None])


def _sequential(names: Sequence[str], durations: Sequence[float], n_frames: int,
                params: Mapping[str, Mapping[str, Any]], start_xz: np.ndarray,
                heading: float, sway: float) -> tuple[_Track, list[int]]:
    """Concepts one after another, each starting where the previous left the root; the
    cross-fade spans ``BLEND_FRAMES`` centred on each boundary."""
    bounds = [0] + [int(round(FPS * s)) for s in np.cumsum(durations)[:-1]] + [n_frames]
    half = BLEND_FRAMES // 2
    frames = np.arange(n_frames)
    out: _Track | None = None
    origin, facing = np.asarray(start_xz, float), heading
    for i, name in enumerate(names):
        lo = 0 if i == 0 else max(0, bounds[i] - half)
        hi = n_frames if i == len(names) - 1 else min(n_frames, bounds[i + 1] + half)
        local_t = (frames[lo:hi] - bounds[i]) / FPS
        track = _place(_concept_track(name, local_t, params[name], sway), origin, facing)
        if out is None:
            out = _idle(frames / FPS, sway)
            for f in fields(out):
                getattr(out, f.name)[lo:hi] = getattr(track, f.name)
        else:
            window = frames[lo:bounds[i] + half]
            weight = _smoothstep((window - lo + 0.5) / (bounds[i] + half - lo))
            _blend(out, _slice(track, 0, len(window)), window, weight)
            for f in fields(out):
                getattr(out, f.name)[bounds[i] + half:hi] = getattr(track, f.name)[len(window):]
        if i + 1 < len(names):
            k = bounds[i + 1] - lo
            origin, facing = track.root_xz[k].copy(), float(track.heading[k])
    assert out is not None
    return out, bounds


def _slice(track: _Track, start: int, stop: int) -> _Track:
    return _Track(**{f.name: getattr(track, f.name)[start:stop] for f in fields(track)})


# ------------------------------------------------------------------------------ the pose

def _tensor(array: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(array, dtype=np.float64))


def _about(axis: tuple[float, float, float], angle: torch.Tensor) -> torch.Tensor:
    return axis_angle_to_quat(angle.new_tensor(axis).expand(angle.shape + (3,)), angle)


def _euler(pitch: torch.Tensor, yaw: torch.Tensor, roll: torch.Tensor) -> torch.Tensor:
    """q = yaw about Y ⊗ pitch about X (positive leans +Y toward +Z) ⊗ roll about Z."""
    return qmul(qmul(_about((0, 1, 0), yaw), _about((1, 0, 0), pitch)),
                _about((0, 0, 1), roll))


_DOWN = torch.tensor([0.0, -1.0, 0.0], dtype=torch.float64)
_AHEAD = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
_COLLAR_REST = qbetween(_DOWN.expand(2, 3), _tensor(_COLLAR_DIRECTION))
_NECK_REST = qbetween(_AHEAD, _tensor(_NECK_DIRECTION))


def _solve_pose(track: _Track) -> tuple[torch.Tensor, torch.Tensor]:
    """Root positions (T, 3) and local rotations (T, 22, 4) realising a track.

    Legs: two-bone IK in the pelvis frame from hip to ankle target (knee forward), then the
    ankle turns the foot to its yaw, 20° toe-down. Arms: shortest-arc rotations putting the
    upper arm and forearm along their directions (torso frame, or heading frame where
    ``upright`` is 1; linear mix between — qbetween normalises). Spine: the track's pitch,
    yaw, roll split equally over spine1–3.
    """
    n = len(track.heading)
    down, ahead = _DOWN.expand(n, 3), _AHEAD.expand(n, 3)
    pelvis_tilt = _euler(*_tensor(track.pelvis_tilt).unbind(-1))
    pelvis = qmul(quat_about_y(_tensor(track.heading)), pelvis_tilt)
    root = _tensor(np.stack((track.root_xz[:, 0], track.pelvis_y, track.root_xz[:, 1]), -1))
    rotations = torch.zeros(n, NUM_JOINTS, 4, dtype=torch.float64)
    rotations[..., 0] = 1.0
    rotations[:, 0] = pelvis
    spine = _euler(*(_tensor(track.spine) / 3).unbind(-1))
    rotations[:, [3, 6, 9]] = spine[:, None]
    head = _tensor(track.head)
    rotations[:, 12] = qmul(_euler(head[:, 0], head[:, 1], torch.zeros_like(head[:, 0])),
                            _NECK_REST.expand(n, 4))
    for side, (hip, knee, ankle) in enumerate(((1, 4, 7), (2, 5, 8))):
        hip_position = root + qrot(pelvis, _tensor(_HIP_OFFSET[side]).expand(n, 3))
        target = qrot(qinv(pelvis), _tensor(track.ankles[:, side]) - hip_position)
        thigh, shin = _two_bone(target.numpy(), _THIGH[side], _SHIN[side], _KNEE_HINT)
        r_hip = qbetween(down, _tensor(thigh))
        r_knee = qbetween(down, qrot(qinv(r_hip), _tensor(shin)))
        yaw, tilt = track.foot_yaw[:, side], _FOOT_TILT + track.foot_pitch[:, side]
        foot = np.stack((np.sin(yaw) * np.cos(tilt), -np.sin(tilt), np.cos(yaw) * np.cos(tilt)),
                        -1)
        shin_frame = qmul(pelvis, qmul(r_hip, r_knee))
        rotations[:, hip], rotations[:, knee] = r_hip, r_knee
        rotations[:, ankle] = qbetween(ahead, qrot(qinv(shin_frame), _tensor(foot)))
    # spine3's rotation relative to the heading frame, for arms given upright
    torso = qmul(pelvis_tilt, qmul(spine, qmul(spine, spine)))
    for side, (collar, shoulder, elbow) in enumerate(((13, 16, 18), (14, 17, 19))):
        weight = _tensor(track.upright[:, side])[:, None]
        bones = []
        for bone in (0, 1):
            given = _tensor(track.arms[:, side, bone])
            bones.append(given + weight * (qrot(qinv(torso), given) - given))
        rest = _COLLAR_REST[side].expand(n, 4)
        r_shoulder = qbetween(down, qrot(qinv(rest), bones[0]))
        upper_frame = qmul(rest, r_shoulder)
        rotations[:, collar], rotations[:, shoulder] = rest, r_shoulder
        rotations[:, elbow] = qbetween(down, qrot(qinv(upper_frame), bones[1]))
    return root, rotations


# ------------------------------------------------------------------------------ captions

_SUBJECTS = ("a person", "someone", "a man", "a woman", "the person", "a human")
_TEMPLATES = {
    "single": ("{S} {A}.",),
    "simultaneous": ("{S} {A} while {b}.", "{S} {A} and {B} at the same time.",
                     "while {b}, {S} {A}.", "{S} {B} while {a}."),
    "sequential": ("{S} {A}, then {B}.", "{S} {A} and then {B}.", "first {S} {A}, then {B}.",
                   "{S} {A} before {b}.", "after {a}, {S} {B}."),
}

#: lemma → (third person singular, gerund)
_VERBS = {
    "walk": ("walks", "walking"), "take": ("takes", "taking"), "stroll": ("strolls", "strolling"),
    "step": ("steps", "stepping"), "sidestep": ("sidesteps", "sidestepping"),
    "shuffle": ("shuffles", "shuffling"), "run": ("runs", "running"), "jog": ("jogs", "jogging"),
    "sprint": ("sprints", "sprinting"), "turn": ("turns", "turning"),
    "pivot": ("pivots", "pivoting"), "circle": ("circles", "circling"),
    "jump": ("jumps", "jumping"), "hop": ("hops", "hopping"), "squat": ("squats", "squatting"),
    "stand": ("stands", "standing"), "do": ("does", "doing"), "bend": ("bends", "bending"),
    "kick": ("kicks", "kicking"), "wave": ("waves", "waving"), "raise": ("raises", "raising"),
    "lift": ("lifts", "lifting"), "put": ("puts", "putting"), "clap": ("claps", "clapping"),
    "applaud": ("applauds", "applauding"), "punch": ("punches", "punching"),
    "throw": ("throws", "throwing"), "jab": ("jabs", "jabbing"),
}
_NOUNS = {"person": "person", "man": "man", "woman": "woman", "human": "human",
          "step": "step", "steps": "step", "circle": "circle", "air": "air", "squat": "squat",
          "knees": "knee", "leg": "leg", "foot": "foot", "hand": "hand", "hands": "hand",
          "arm": "arm", "arms": "arm", "head": "head", "fist": "fist", "punches": "punch",
          "kick": "kick", "time": "time", "times": "time", "place": "place"}
_FIXED = {
    **{w: "DET" for w in ("a", "the", "both")},
    **{w: "ADJ" for w in ("several", "few", "small", "same")},
    **{w: "ADV" for w in ("forward", "backward", "backwards", "straight", "ahead", "quickly",
                          "slowly", "sideways", "around", "up", "down", "back", "high", "then",
                          "first", "afterwards")},
    **{w: "ADP" for w in ("to", "with", "in", "into", "above", "at", "after", "before")},
    "someone": "PRON", "while": "SCONJ", "and": "CCONJ", "hello": "INTJ",
}
_BODY_NOUNS = {"hand", "leg", "foot", "arm", "fist"}


def _verb_lemmas() -> dict[str, str]:
    lemmas = {}
    for lemma, forms in _VERBS.items():
        for form in (lemma, *forms):
            lemmas[form] = lemma
    return lemmas


_VERB_FORMS = _verb_lemmas()


def tag_caption(caption: str) -> list[tuple[str, str]]:
    """(lemma, universal POS) for each word of a caption, as HumanML3D's text files store
    them (spaCy there; here a rule-based tagger over the generator's closed lexicon).

    Rules: a word that is both noun and verb ("steps", "circle", "punches") is a NOUN after
    a determiner, adjective or verb and a VERB otherwise; "left"/"right" are ADJ before a
    body-part noun, NOUN after "the", ADV otherwise. Unknown words raise ``ValueError``.
    """
    words = re.findall(r"[a-z]+", caption.lower())
    tagged: list[tuple[str, str]] = []
    for i, word in enumerate(words):
        previous = tagged[-1][1] if tagged else None
        following = words[i + 1] if i + 1 < len(words) else None
        if word in ("left", "right"):
            if following is not None and _NOUNS.get(following) in _BODY_NOUNS:
                pos = "ADJ"
            elif tagged and tagged[-1][0] == "the":
                pos = "NOUN"
            else:
                pos = "ADV"
            tagged.append((word, pos))
        elif word in _NOUNS and word in _VERB_FORMS:
            noun = previous in ("DET", "ADJ", "NUM", "VERB")
            tagged.append((_NOUNS[word], "NOUN") if noun else (_VERB_FORMS[word], "VERB"))
        elif word in _VERB_FORMS:
            tagged.append((_VERB_FORMS[word], "VERB"))
        elif word in _NOUNS:
            tagged.append((_NOUNS[word], "NOUN"))
        elif word in _FIXED:
            tagged.append((word, _FIXED[word]))
        else:
            raise ValueError(f"word {word!r} of caption {caption!r} is not in the lexicon")
    return tagged


def humanml3d_text_line(caption: str, start: float = 0.0, end: float = 0.0) -> str:
    """``caption#lemma/POS lemma/POS ...#start#end`` (seconds; 0.0#0.0 = the whole clip)."""
    tokens = " ".join(f"{lemma}/{pos}" for lemma, pos in tag_caption(caption))
    return f"{caption}#{tokens}#{float(start)}#{float(end)}"


def _captions(spec: ClipSpec, rng: np.random.Generator, count: int = 3) -> list[str]:
    """``count`` different captions from the concepts' paraphrases and the templates."""
    phrases = [CONCEPTS[name].phrases for name in spec.concepts]
    templates = _TEMPLATES[spec.composition]
    found: list[str] = []
    for _ in range(50 * count):
        template = templates[int(rng.integers(len(templates)))]
        subject = _SUBJECTS[int(rng.integers(len(_SUBJECTS)))]
        chosen = [p[int(rng.integers(len(p)))] for p in phrases]
        fill = {"S": subject, "A": chosen[0][0], "a": chosen[0][1]}
        if len(chosen) > 1:
            fill.update(B=chosen[1][0], b=chosen[1][1])
        caption = template.format(**fill)
        if caption not in found:
            found.append(caption)
        if len(found) == count:
            break
    return found


# ------------------------------------------------------------------------------------ clips

@dataclass(frozen=True)
class Clip:
    """A generated clip: world joints (T, 22, 3) float32 at 20 fps, the root positions and
    local rotations (w, x, y, z) that made them, captions and machine-readable labels."""

    joints: np.ndarray
    root: np.ndarray
    rotations: np.ndarray
    captions: tuple[str, ...]
    labels: dict[str, Any]

    def text_lines(self) -> list[str]:
        """The captions as HumanML3D text lines (whole clip: ``#0.0#0.0``)."""
        return [humanml3d_text_line(c) for c in self.captions]


def _concept_params(spec: ClipSpec, rng: np.random.Generator) -> dict[str, dict[str, Any]]:
    durations = spec.segment_durations or (spec.duration,) * len(spec.concepts)
    params: dict[str, dict[str, Any]] = {}
    for i, (name, duration) in enumerate(zip(spec.concepts, durations, strict=True)):
        concept = CONCEPTS[name]
        stop = spec.composition == "sequential" and i + 1 < len(spec.concepts)
        drawn = concept.sample(rng, float(duration), stop)
        overrides = dict(spec.params.get(name, {}))
        unknown = sorted(set(overrides) - set(drawn))
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown} for concept {name!r}; known: "
                             f"{sorted(drawn)}")
        drawn.update(overrides)
        params[name] = drawn
    return params


def _plan(spec: ClipSpec, seed: int) -> tuple[_Track, tuple[str, ...], dict[str, Any]]:
    """The track, captions and labels of a clip (everything but the pose solve)."""
    if not isinstance(spec, ClipSpec):
        raise ValueError(f"spec must be a ClipSpec, got {type(spec).__name__}")
    rng = np.random.default_rng(seed)
    unknown = sorted(set(spec.params) - set(spec.concepts) - {"initial_heading", "start_xz"})
    if unknown:
        raise ValueError(f"unknown spec.params key(s) {unknown}; allowed: initial_heading, "
                         f"start_xz and the clip's concept names")
    heading = float(spec.params.get("initial_heading", 0.0))
    start_xz = np.asarray(spec.params.get("start_xz", (0.0, 0.0)), dtype=np.float64)
    if start_xz.shape != (2,):
        raise ValueError(f"start_xz must be two numbers, got {spec.params.get('start_xz')!r}")
    sway = float(rng.uniform(0, 2 * np.pi))
    params = _concept_params(spec, rng)
    n = spec.n_frames
    t = np.arange(n) / FPS
    last = n - 1                                   # features drop the last raw frame
    if spec.composition == "sequential":
        assert spec.segment_durations is not None
        track, bounds = _sequential(spec.concepts, spec.segment_durations, n, params,
                                    start_xz, heading, sway)
        half = BLEND_FRAMES // 2
        segments = [{"concept": name, "start": bounds[i], "end": min(bounds[i + 1], last),
                     "body_parts": {part: (name if part in CONCEPTS[name].parts
                                           or CONCEPTS[name].moves_root else "idle")
                                    for part in BODY_PARTS}}
                    for i, name in enumerate(spec.concepts)]
        transitions = bounds[1:-1]
        windows = [[b - half, b + half] for b in transitions]
        owners: dict[str, Any] = {}
    else:
        track, owners = _simultaneous(spec.concepts, t, params, sway)
        track = _place(track, start_xz, heading)
        segments = [{"concept": name, "start": 0, "end": last} for name in spec.concepts]
        transitions, windows = [], []
    captions = tuple(_captions(spec, rng))
    labels = {
        "concepts": list(spec.concepts), "composition": spec.composition, "fps": FPS,
        "n_frames": n, "segments": segments, "transitions": transitions,
        "transition_windows": windows, "body_parts": owners,
        "params": {"initial_heading": heading, "start_xz": start_xz.tolist(), "sway": sway,
                   **params},
        "seed": int(seed),
    }
    return track, captions, labels


def generate_clips(specs: Sequence[ClipSpec], seeds: Sequence[int]) -> list[Clip]:
    """:func:`generate_clip` for many clips at once: the pose solve and forward kinematics
    are per frame, so all clips' frames go through them in one batch (much faster)."""
    if len(specs) != len(seeds):
        raise ValueError(f"{len(specs)} specs but {len(seeds)} seeds")
    plans = [_plan(spec, seed) for spec, seed in zip(specs, seeds, strict=True)]
    if not plans:
        return []
    whole = _Track(**{f.name: np.concatenate([getattr(track, f.name) for track, _, _ in plans])
                      for f in fields(_Track)})
    root, rotations = _solve_pose(whole)
    joints = forward_kinematics(root, rotations)
    clips, start = [], 0
    for track, captions, labels in plans:
        stop = start + len(track.heading)
        clips.append(Clip(joints=joints[start:stop].numpy().astype(np.float32),
                          root=root[start:stop].numpy().astype(np.float32),
                          rotations=rotations[start:stop].numpy().astype(np.float32),
                          captions=captions, labels=labels))
        start = stop
    return clips


def generate_clip(spec: ClipSpec, seed: int) -> Clip:
    """Generate one clip, deterministically from ``(spec, seed)``.

    Labels: ``concepts``, ``composition``, ``segments`` (concept, start, end frames, end
    exclusive, raw-frame indices — the same indices address ``new_joints`` / features, whose
    last raw frame is dropped), ``transitions`` (boundary frames) and ``transition_windows``,
    ``body_parts`` (part → owning concept or "idle"; per segment for sequential clips),
    ``params`` (every drawn parameter) and ``fps``.
    """
    return generate_clips([spec], [seed])[0]


# ---------------------------------------------------------------------------------- datasets

SPLITS = ("train", "val", "test")
#: written last by :func:`write_dataset`: its presence means the folder is complete.
DATASET_MARKER = "dataset.json"


def _composition_weights(compositions: Mapping[str, float] | None) -> dict[str, float]:
    weights = dict(compositions if compositions is not None else DEFAULT_COMPOSITION_WEIGHTS)
    for kind, weight in weights.items():
        if kind not in COMPOSITIONS:
            raise ValueError(f"unknown composition {kind!r}; known: {COMPOSITIONS}")
        if not weight >= 0:
            raise ValueError(f"composition weight for {kind!r} must be ≥ 0, got {weight}")
    if sum(weights.values()) <= 0:
        raise ValueError(f"composition weights select nothing: {weights}")
    return weights


def _held_out(pairs: Sequence[Sequence[str]]) -> list[frozenset[str]]:
    found = []
    for pair in pairs:
        if len(pair) != 2 or pair[0] == pair[1]:
            raise ValueError(f"a held-out pair is two different concept names, got {pair!r}")
        for name in pair:
            _check_concept(name)
        found.append(frozenset(pair))
    return found


def _split_ids(ids: list[str], held: list[bool], fractions: Sequence[float],
               rng: np.random.Generator) -> dict[str, list[str]]:
    """Held-out clips go to test; the rest are shuffled and cut by ``fractions``."""
    if len(fractions) != 3 or min(fractions) < 0 or abs(sum(fractions) - 1) > 1e-6:
        raise ValueError(f"split_fractions must be 3 non-negative numbers summing to 1, got "
                         f"{tuple(fractions)}")
    free = [i for i, h in zip(ids, held, strict=True) if not h]
    free = [free[k] for k in rng.permutation(len(free))]
    n_train = int(round(fractions[0] * len(free)))
    n_val = int(round(fractions[1] * len(free)))
    if n_train == 0:
        raise ValueError(f"no training clips: {len(free)} clips not held out, train fraction "
                         f"{fractions[0]}")
    splits = {"train": free[:n_train], "val": free[n_train:n_train + n_val],
              "test": free[n_train + n_val:] + [i for i, h in zip(ids, held, strict=True) if h]}
    return {name: sorted(split) for name, split in splits.items()}


def block_averaged_std(std: np.ndarray) -> np.ndarray:
    """Replace each feature block's per-dimension std by the block's mean (HumanML3D
    ``mean_variance``). HumanML3D also divides the root and foot-contact blocks by
    ``feat_bias`` = 5; we do not (REFERENCE.md: "Std.npy is averaged within each block").
    A block whose std is 0 (a constant feature) gets 1 so normalising never divides by 0."""
    out = np.asarray(std, dtype=np.float64).copy()
    for block in FEATURE_BLOCKS.values():
        value = out[block].mean()
        out[block] = value if value > 0 else 1.0
    return out


_CHUNK = 256  # clips generated together: one pose solve / FK call, features by length


def _features_by_length(clips: Sequence[Clip]) -> list[tuple[np.ndarray, np.ndarray]]:
    """``joints_to_features`` of each clip, computed in batches of equal-length clips (the
    function is batched over leading dims; results are the same as one clip at a time)."""
    out: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(clips)
    lengths = sorted({len(c.joints) for c in clips})
    for length in lengths:
        members = [i for i, c in enumerate(clips) if len(c.joints) == length]
        features, canonical = joints_to_features(np.stack([clips[i].joints for i in members]))
        for k, i in enumerate(members):
            out[i] = (features[k], canonical[k])
    return out  # type: ignore[return-value]


def _write_clip(out: Path, clip_id: str, clip: Clip, arrays: tuple[np.ndarray, np.ndarray],
                held_out: bool, train: bool, stats: dict[str, Any]) -> None:
    features, canonical = arrays
    storage.write_npy(out / "new_joint_vecs" / f"{clip_id}.npy", features)
    storage.write_npy(out / "new_joints" / f"{clip_id}.npy", canonical)
    storage.write_text(out / "texts" / f"{clip_id}.txt", "\n".join(clip.text_lines()) + "\n")
    storage.write_json(out / "labels" / f"{clip_id}.json",
                       {"id": clip_id, **clip.labels, "held_out": held_out})
    if train:
        values = features.astype(np.float64)
        stats["sum"] += values.sum(0)
        stats["sum_sq"] += (values**2).sum(0)
        stats["count"] += len(values)


def write_dataset(out_dir: str | Path, *, n_clips: int, seed: int,
                  split_fractions: Sequence[float] = (0.8, 0.05, 0.15),
                  compositions: Mapping[str, float] | None = None,
                  held_out_pairs: Sequence[Sequence[str]] = (),
                  concept_pool: Sequence[str] | None = None) -> Path:
    """Generate ``n_clips`` clips into ``out_dir`` in HumanML3D's layout.

    Writes ``new_joint_vecs/ID.npy`` (T−1, 263) and ``new_joints/ID.npy`` (T−1, 22, 3)
    float32 (``features.joints_to_features``: floored, centred, facing +Z), ``texts/ID.txt``
    (3 lines ``caption#tokens#0.0#0.0``), ``labels/ID.json``, ``train.txt``/``val.txt``/
    ``test.txt``, ``Mean.npy``/``Std.npy`` (263,) from the *training* split (HumanML3D uses
    all clips), Std averaged within each feature block (:func:`block_averaged_std`), and
    last :data:`DATASET_MARKER`. IDs are zero-padded 6-digit indices. Clip i's motion, texts
    and labels depend only on ``(seed, i)`` and the options, not on ``n_clips`` (the splits
    and statistics do). Clips containing
    both concepts of a ``held_out_pairs`` entry (simultaneous or sequential) all go to the
    test split. All files are written atomically.
    """
    if not isinstance(n_clips, int | np.integer) or n_clips < 1:
        raise ValueError(f"n_clips must be a positive integer, got {n_clips!r}")
    weights = _composition_weights(compositions)
    held_pairs = _held_out(held_out_pairs)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / DATASET_MARKER).unlink(missing_ok=True)

    specs, clip_seeds = [], []
    for i in range(n_clips):
        rng = np.random.default_rng([seed, i])
        specs.append(sample_clip_spec(rng, concept_pool=concept_pool,
                                      composition_weights=weights))
        clip_seeds.append(int(rng.integers(2**31)))
    ids = [f"{i:06d}" for i in range(n_clips)]
    held = [any(pair <= set(s.concepts) for pair in held_pairs) for s in specs]
    splits = _split_ids(ids, held, split_fractions, np.random.default_rng([seed, n_clips, 7]))
    train = set(splits["train"])

    stats = {"count": 0, "sum": np.zeros(FEATURE_DIM), "sum_sq": np.zeros(FEATURE_DIM)}
    with torch.inference_mode():
        for first in range(0, n_clips, _CHUNK):
            chunk = range(first, min(first + _CHUNK, n_clips))
            clips = generate_clips([specs[i] for i in chunk], [clip_seeds[i] for i in chunk])
            arrays = _features_by_length(clips)
            for i, clip, pair in zip(chunk, clips, arrays, strict=True):
                _write_clip(out, ids[i], clip, pair, held[i], ids[i] in train, stats)
    count, total, total_sq = stats["count"], stats["sum"], stats["sum_sq"]
    mean = total / count
    std = np.sqrt(np.maximum(total_sq / count - mean**2, 0.0))
    storage.write_npy(out / "Mean.npy", mean.astype(np.float32))
    storage.write_npy(out / "Std.npy", block_averaged_std(std).astype(np.float32))
    for name in SPLITS:
        storage.write_text(out / f"{name}.txt", "".join(f"{i}\n" for i in splits[name]))
    storage.write_json(out / DATASET_MARKER, {
        "generator_version": GENERATOR_VERSION, "n_clips": n_clips, "seed": seed,
        "split_fractions": list(split_fractions), "compositions": weights,
        "held_out_pairs": [sorted(p) for p in held_pairs],
        "concept_pool": list(concept_pool) if concept_pool is not None else None,
        "split_sizes": {name: len(splits[name]) for name in SPLITS},
        "fps": FPS, "std": "per-dimension std over the training split, averaged within each "
                          "feature block; no feat_bias division",
    })
    return out


@dataclass(frozen=True)
class DatasetConfig:
    """Everything that determines a generated dataset (its cache key)."""

    n_clips: int = 2000
    seed: int = 0
    split_fractions: tuple[float, float, float] = (0.8, 0.05, 0.15)
    compositions: tuple[tuple[str, float], ...] = tuple(DEFAULT_COMPOSITION_WEIGHTS.items())
    held_out_pairs: tuple[tuple[str, str], ...] = ()
    concept_pool: tuple[str, ...] | None = None

    def as_dict(self) -> dict[str, Any]:
        return {"generator_version": GENERATOR_VERSION, "n_clips": self.n_clips,
                "seed": self.seed, "split_fractions": list(self.split_fractions),
                "compositions": [list(c) for c in self.compositions],
                "held_out_pairs": [list(p) for p in self.held_out_pairs],
                "concept_pool": list(self.concept_pool) if self.concept_pool else None}


def ensure_dataset(config: DatasetConfig | None = None) -> Path:
    """The dataset for ``config`` under ``cache_dir()/datasets/<config hash>``, generated on
    first use and reused once complete (its :data:`DATASET_MARKER` is written last)."""
    config = config or DatasetConfig()
    if not isinstance(config, DatasetConfig):
        raise ValueError(f"config must be a DatasetConfig, got {type(config).__name__}")
    out = paths.cache_dir() / "datasets" / config_hash(config.as_dict())
    marker = out / DATASET_MARKER
    if marker.exists() and storage.read_json(marker).get("generator_version") == \
            GENERATOR_VERSION:
        return out
    write_dataset(out, n_clips=config.n_clips, seed=config.seed,
                  split_fractions=config.split_fractions,
                  compositions=dict(config.compositions), held_out_pairs=config.held_out_pairs,
                  concept_pool=config.concept_pool)
    return out


#: the committed stand-in set: the first seed (counting from 0) whose 44 clips include every
#: concept at least once and stay under 5 MB.
STUB_CLIPS, STUB_SEED = 44, 20

_STUB_README = """# data_stubs — a small stand-in dataset in HumanML3D's layout

Synthetic motion, not motion capture: {n} clips from `repro.generator` (procedural,
concept-driven, forward kinematics on HumanML3D's 22-joint skeleton, 20 fps, 2–6 s), with the
real bone lengths and the exact HumanML3D 263-d features. Generated by

```python
from repro.generator import write_dataset
write_dataset("data_stubs", n_clips={n}, seed={seed})   # = repro.generator.regenerate_stubs()
```

(default options: 50 % single concepts, 30 % simultaneous and 20 % sequential pairs, splits
0.8/0.05/0.15; generator version {version}). The seed is the first one whose {n} clips contain
every concept at least once within 5 MB; it was chosen from the clip specifications alone.

Layout (HumanML3D's): `new_joint_vecs/ID.npy` (T−1, 263) float32, `new_joints/ID.npy`
(T−1, 22, 3) float32 (the joints recovered from the features: on the floor, facing +Z at frame
0), `texts/ID.txt` (3 lines `caption#word/POS ...#0.0#0.0`), `Mean.npy`, `Std.npy` (263,)
float32 (training split; Std averaged within each feature block, no feat_bias),
`train.txt`, `val.txt`, `test.txt`. Beside them, not in HumanML3D: `labels/ID.json` (concepts,
composition, segments in frames, transitions, body-part owners, all drawn parameters) and
`dataset.json` (the options; written last).
"""


def regenerate_stubs() -> Path:
    """Rewrite the committed ``data_stubs/`` set (and its README) exactly."""
    out = write_dataset(paths.data_stubs_dir(), n_clips=STUB_CLIPS, seed=STUB_SEED)
    storage.write_text(out / "README.md", _STUB_README.format(
        n=STUB_CLIPS, seed=STUB_SEED, version=GENERATOR_VERSION))
    return out


def _benchmark(n_clips: int = 200) -> dict[str, float]:
    """Seconds per clip for generation alone and generation + features (one thread)."""
    torch.set_num_threads(1)
    specs = [sample_clip_spec(np.random.default_rng([0, i])) for i in range(n_clips)]
    start = time.perf_counter()
    clips = [generate_clip(s, i) for i, s in enumerate(specs)]
    generate = time.perf_counter() - start
    start = time.perf_counter()
    for clip in clips:
        joints_to_features(clip.joints)
    features = time.perf_counter() - start
    return {"generate_s_per_clip": generate / n_clips, "features_s_per_clip": features / n_clips}
