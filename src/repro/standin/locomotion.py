"""Locomotion concepts of the stand-in generator: walking (four directions), running,
turning in place and walking a circle, all one gait planner.

Walking is a gait planner: each foot is planted at the root's position at mid-stance (so
stride length = speed × cycle time and stance feet do not slide) and swings along an arc to
its next plant; the pelvis is lowered where a stance leg could not otherwise reach its plant.
Samplers and the motion follow the conventions of ``repro.standin.primitives``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from scipy.ndimage import gaussian_filter1d, minimum_filter1d

from repro.motion.skeleton import BONE_LENGTHS
from repro.standin.pose import (
    ANKLE_HEIGHT,
    FOOT_TILT,
    FORWARD,
    HIP_OFFSET,
    SHIN,
    SIDE_SIGN,
    STANCE_X,
    STAND_HEIGHT,
    THIGH,
    Track,
    arm_direction,
    bend,
    rotate_xz,
)
from repro.standin.primitives import ease, smoothstep

__all__ = ["locomotion", "sample_circle", "sample_run", "sample_turn", "sample_walk"]


# -------------------------------------------------------------------------------- the gait

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
        ramp = ease(tau, 0.0, p["ramp_in"]) * (tau >= 0)
        if p.get("stop_at") is not None:
            ramp = ramp * ease(p["stop_at"] - tau, 0.0, 0.5)
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
    plant_xz = plant_xz + rotate_xz(np.array([SIDE_SIGN[side] * p["width"], 0.0]), plant_yaw)
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
    roll = np.where(planted, ease(stance_part, 0.55, 1.0), 1 - ease(u, 0.0, 0.5))
    pitch = p["heel_off"] * roll * short * effort
    length = BONE_LENGTHS[10 + side]
    ahead = length * (math.cos(FOOT_TILT) - np.cos(FOOT_TILT + pitch))
    ankle[:, [0, 2]] += ahead[:, None] * np.stack((np.sin(yaw), np.cos(yaw)), -1)
    ankle[:, 1] += length * (np.sin(FOOT_TILT + pitch) - math.sin(FOOT_TILT))
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
    world_v = rotate_xz(np.stack((rates[:, 1], rates[:, 0]), -1), heading_g)
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

    hips = root_xz[:, None, :] + rotate_xz(
        np.broadcast_to(HIP_OFFSET[:, [0, 2]], (n, 2, 2)), heading[:, None])
    reach = np.hypot(*(ankles[:, :, [0, 2]] - hips).transpose(2, 0, 1))
    legs = p["reach"] * (THIGH + SHIN)
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
        upper = arm_direction(side, flex, 0.14)
        arms[:, side, 0] = upper
        arms[:, side, 1] = bend(upper, p["elbow"], FORWARD)
    return Track(root_xz=root_xz, heading=heading, pelvis_y=pelvis_y, pelvis_tilt=tilt,
                 ankles=ankles, foot_yaw=foot_yaw, foot_pitch=foot_pitch, spine=spine,
                 head=np.zeros((n, 2)), arms=arms, upright=np.zeros((n, 2)))


def _gait(rng: np.random.Generator, *, cycle: tuple[float, float], duty: float = 0.6,
          lift: tuple[float, float] = (0.09, 0.13), width: float = STANCE_X,
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
