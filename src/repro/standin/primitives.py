"""Motion primitives of the stand-in generator: concept motions as tracks, and the pose solver.

How a pose is made. A concept (walk forward, wave the right hand, ...) is a small parametric
function of time that fills a :class:`Track`: the root trajectory (x/z, heading, pelvis
height), world targets for the two ankles, spine and head angles, and unit directions of
the upper arms and forearms (in the torso frame, or in the heading frame where "up" means
against gravity: raising and waving). :func:`solve_pose` turns a track into local
rotations: two-bone inverse kinematics for the legs (hip–knee–ankle, knee bending forward) and
shortest-arc rotations for the arm bones. Walking is a gait planner: each foot is planted at
the root's position at mid-stance (so stride length = speed × cycle time and stance feet do
not slide) and swings along an arc to its next plant; the pelvis is lowered where a stance
leg could not otherwise reach its plant.

Each concept has a sampler, ``sample_*(rng, duration, stop_at_end) → params`` (the random
parameters of one occurrence; ``stop_at_end``: another concept follows, so come to rest),
and a motion, ``motion(t, params) → Track`` at local times ``t`` (s), made at the origin
facing +Z (:func:`place` moves it). ``repro.generator`` names the concepts and composes them.

Conventions: Y up, a heading of 0 faces +Z, a positive heading change turns left (toward +X,
the body's left). Rest pose: feet point forward and 20° down so the toes (joints 10, 11)
touch the floor while the ankles stand 5 cm above it; the collar bones point up and out;
the head points up; arms hang slightly away from the body.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d, minimum_filter1d

from repro.motion.quaternion import axis_angle_to_quat, qbetween, qinv, qmul, qrot, quat_about_y
from repro.motion.skeleton import BONE_LENGTHS, NUM_JOINTS, OFFSETS

__all__ = [
    "ANKLE_HEIGHT", "GRAVITY", "STAND_HEIGHT", "Track", "clap", "idle", "jump", "kick",
    "locomotion", "place", "punch", "raise_arms", "sample_circle", "sample_clap", "sample_jump",
    "sample_kick", "sample_punch", "sample_raise", "sample_run", "sample_squat", "sample_turn",
    "sample_walk", "sample_wave", "slerp_directions", "smoothstep", "solve_pose", "squat",
    "take_part", "wave",
]

#: m/s², for the ballistic flight of a jump.
GRAVITY = 9.81

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

def smoothstep(x: np.ndarray | float) -> np.ndarray:
    """3x² − 2x³ of x clipped to [0, 1]: 0 below 0, 1 above 1, zero slope at both ends."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _ease(t: np.ndarray, start: float, end: float) -> np.ndarray:
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
class Track:
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

    def copy(self) -> Track:
        """A copy with every array copied."""
        return Track(**{f.name: getattr(self, f.name).copy() for f in fields(self)})


_PART_FIELDS = {
    "root": ("root_xz", "heading", "pelvis_y", "pelvis_tilt"),
    "legs": ("ankles", "foot_yaw", "foot_pitch"),
    "torso": ("spine", "head"),
}


def take_part(dst: Track, src: Track, part: str) -> None:
    """Copy body part ``part`` (``root``, ``legs``, ``torso``, ``left_arm`` or ``right_arm``)
    of ``src`` into ``dst``, in place: an arm's two bone directions and ``upright``; the
    root's position, heading, pelvis height and tilt; the legs' ankle targets and foot angles;
    the torso's spine and head angles."""
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


def idle(t: np.ndarray, sway_phase: float = 0.0) -> Track:
    """Standing: feet planted under the hips, a slight breathing sway."""
    n = len(t)
    sway = np.sin(2 * np.pi * 0.3 * t + sway_phase)
    ankles = np.zeros((n, 2, 3))
    ankles[:, :, 0] = _SIGN * _STANCE_X
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
    yaw = plant_yaw[i] + smoothstep(u) * (plant_yaw[i + 1] - plant_yaw[i])
    step = np.linalg.norm(there - here, axis=-1) + 0.15 * np.abs(plant_yaw[i + 1] - plant_yaw[i])
    short = np.clip(step / 0.25, 0.0, 1.0)
    ankle = np.empty((len(t), 3))
    ankle[:, [0, 2]] = here + smoothstep(u)[:, None] * (there - here)
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


def locomotion(t: np.ndarray, p: Mapping[str, Any]) -> Track:
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
    return Track(root_xz=root_xz, heading=heading, pelvis_y=pelvis_y, pelvis_tilt=tilt,
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


def sample_walk(direction: str) -> Callable[..., dict[str, Any]]:
    """The parameter sampler of walking ``direction`` ("forward", "backward", "left" or
    "right") for :func:`locomotion`: 0.9–1.5 m/s forward, 0.55–0.9 m/s backward or 0.45–0.7
    m/s sideways (feet set wider, so they never cross); stops by the end if ``stop_at_end``."""

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


def sample_run(rng: np.random.Generator, duration: float, stop_at_end: bool) -> dict[str, Any]:
    """Parameters of running forward for :func:`locomotion`: 2.4–3.4 m/s, a short stance
    (duty 0.35, so both feet leave the ground), high swings lifting the heel early, bent
    elbows, a forward lean."""
    p = _gait(rng, cycle=(0.65, 0.78), duty=0.35, lift=(0.17, 0.23), reach=0.95,
              arm_swing=(0.3, 0.45), elbow=(1.6, 1.8), lean=0.15, lift_shape=0.5)
    p.update(v_forward=rng.uniform(2.4, 3.4), v_left=0.0, omega=0.0,
             stop_at=_stop(duration, stop_at_end), ramp_in=rng.uniform(0.3, 0.5))
    return p


def sample_turn(direction: str) -> Callable[..., dict[str, Any]]:
    """The parameter sampler of turning in place to ``direction`` ("left" or "right") for
    :func:`locomotion`: 90–180° at 100–160°/s, starting at a random time, with small steps."""

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


def sample_circle(rng: np.random.Generator, duration: float,
                  stop_at_end: bool) -> dict[str, Any]:
    """Parameters of walking a circle for :func:`locomotion`: 0.9–1.3 m/s, turning 330–390°
    (either way) at a constant rate over the clip."""
    p = _gait(rng, cycle=(0.95, 1.1), arm_swing=(0.2, 0.35))
    total = math.radians(rng.uniform(330, 390)) * rng.choice([-1.0, 1.0])
    moving = duration - p["ramp_in"] / 2 - (0.25 if stop_at_end else 0.0)
    p.update(v_forward=rng.uniform(0.9, 1.3), v_left=0.0, omega=total / moving,
             stop_at=_stop(duration, stop_at_end))
    return p


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
    track.root_xz[:, 0] = -_SIGN[side] * 0.06 * weight
    track.pelvis_y = track.pelvis_y - 0.03 * weight
    track.spine[:, 0] -= 0.25 * lean
    for arm_side in (0, 1):
        upper = _arm_direction(arm_side, 0.1, 0.14 + 0.35 * weight)
        track.arms[:, arm_side, 0] = upper
        track.arms[:, arm_side, 1] = _bend(upper, 0.3, _FORWARD)
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
    return _normalize(out)


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
    ready = _ease(t, p["start"], p["start"] + 0.4)
    local = np.maximum(t - p["start"] - 0.4, 0.0)
    half_gap = 0.03 + (p["open"] - 0.03) * 0.5 * (1 + np.cos(2 * np.pi * p["frequency"] * local))
    half_gap = np.where(t < p["start"] + 0.4, p["open"], half_gap)
    for side in (0, 1):
        wrist = np.stack((_SIGN[side] * half_gap, np.full_like(t, p["height"]),
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


def solve_pose(track: Track) -> tuple[torch.Tensor, torch.Tensor]:
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

