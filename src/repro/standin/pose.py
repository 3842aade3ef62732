"""The stand-in body and the pose solver: what a pose needs (:class:`Track`) and how it
becomes local rotations (:func:`solve_pose`).

A :class:`Track` holds, per frame, the root trajectory (x/z, heading, pelvis height), world
targets for the two ankles, spine and head angles, and unit directions of the upper arms and
forearms (in the torso frame, or in the heading frame where "up" means against gravity:
raising and waving). :func:`solve_pose` turns a track into local rotations: two-bone inverse
kinematics for the legs (hip–knee–ankle, knee bending forward) and shortest-arc rotations for
the arm bones. The concept motions that fill tracks are in ``repro.standin.primitives`` and
``repro.standin.locomotion``.

Conventions: Y up, a heading of 0 faces +Z, a positive heading change turns left (toward +X,
the body's left). Rest pose: feet point forward and 20° down so the toes (joints 10, 11)
touch the floor while the ankles stand 5 cm above it; the collar bones point up and out;
the head points up; arms hang slightly away from the body.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
import torch

from repro.motion.quaternion import axis_angle_to_quat, qbetween, qinv, qmul, qrot, quat_about_y
from repro.motion.skeleton import BONE_LENGTHS, NUM_JOINTS, OFFSETS

__all__ = [
    "ANKLE_HEIGHT", "FOOT_TILT", "FOREARM", "FORWARD", "HIP_OFFSET", "SHIN",
    "SHOULDER", "SIDE_SIGN", "STANCE_X", "STAND_HEIGHT", "THIGH", "UP", "UPPER_ARM", "Track",
    "arm_direction", "bend", "normalize", "rotate_xz", "solve_pose", "take_part", "two_bone",
]

# ------------------------------------------------------------------------ skeleton geometry

#: x sign of each side: +X is the body's left (left = 0, right = 1).
SIDE_SIGN = np.array([1.0, -1.0])
#: hip joints (1, 2) relative to the pelvis; thigh, shin, upper-arm and forearm lengths (m),
#: left and right.
HIP_OFFSET = OFFSETS[[1, 2]]
THIGH = BONE_LENGTHS[[4, 5]]
SHIN = BONE_LENGTHS[[7, 8]]
UPPER_ARM = BONE_LENGTHS[[18, 19]]
FOREARM = BONE_LENGTHS[[20, 21]]
#: rest pitch of the feet: toe down by 20°.
FOOT_TILT = math.radians(20.0)
#: ankle height when the foot (ankle → toe joint) points 20° down with the toe on the floor.
ANKLE_HEIGHT = BONE_LENGTHS[[10, 11]] * math.sin(FOOT_TILT)
#: standing pelvis height: both legs 98.5 % extended (left and right legs differ by 1 cm).
STAND_HEIGHT = float(np.min(ANKLE_HEIGHT + 0.985 * (THIGH + SHIN)))
#: half the distance between standing ankles (m).
STANCE_X = 0.11
_COLLAR_DIRECTION = np.array([[0.3, 0.95, 0.0], [-0.3, 0.95, 0.0]])
_COLLAR_DIRECTION /= np.linalg.norm(_COLLAR_DIRECTION, axis=1, keepdims=True)
#: shoulder joints (16, 17) relative to spine3 in the torso frame (x left, y up, z forward).
SHOULDER = OFFSETS[[13, 14]] + BONE_LENGTHS[[16, 17], None] * _COLLAR_DIRECTION
_NECK_DIRECTION = np.array([0.0, math.cos(math.radians(15)), math.sin(math.radians(15))])

UP = np.array([0.0, 1.0, 0.0])
FORWARD = np.array([0.0, 0.0, 1.0])
_KNEE_HINT = np.array([0.0, 0.5, 1.0])        # knees bend forward (and up when the leg is raised)

# ------------------------------------------------------------------------ vector geometry

def normalize(v: np.ndarray) -> np.ndarray:
    """``v`` divided by its length along the last axis (lengths below 1e-12 count as 1e-12)."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def arm_direction(side: int, flex: np.ndarray | float, abduct: np.ndarray | float) -> np.ndarray:
    """Upper-arm direction in the torso frame: hanging (−Y) turned forward by ``flex`` then
    out to the side by ``abduct`` (radians): (±cos f sin a, −cos f cos a, sin f)."""
    flex, abduct = np.broadcast_arrays(np.asarray(flex, float), np.asarray(abduct, float))
    return np.stack((SIDE_SIGN[side] * np.cos(flex) * np.sin(abduct),
                     -np.cos(flex) * np.cos(abduct), np.sin(flex)), axis=-1)


def bend(upper: np.ndarray, angle: np.ndarray | float, toward: np.ndarray) -> np.ndarray:
    """The direction ``upper`` turned by ``angle`` toward ``toward`` (elbow flexion)."""
    toward = np.broadcast_to(toward, upper.shape)
    perpendicular = normalize(toward - (toward * upper).sum(-1, keepdims=True) * upper)
    angle = np.asarray(angle, float)[..., None]
    return np.cos(angle) * upper + np.sin(angle) * perpendicular


def two_bone(target: np.ndarray, first: float, second: float,
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
    normal = normalize(hint - (hint * along).sum(-1, keepdims=True) * along)
    upper = cos_alpha * along + np.sqrt(1 - cos_alpha**2) * normal
    lower = normalize(along * d - first * upper)
    return upper, lower


def rotate_xz(xz: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
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
        hip_position = root + qrot(pelvis, _tensor(HIP_OFFSET[side]).expand(n, 3))
        target = qrot(qinv(pelvis), _tensor(track.ankles[:, side]) - hip_position)
        thigh, shin = two_bone(target.numpy(), THIGH[side], SHIN[side], _KNEE_HINT)
        r_hip = qbetween(down, _tensor(thigh))
        r_knee = qbetween(down, qrot(qinv(r_hip), _tensor(shin)))
        yaw, tilt = track.foot_yaw[:, side], FOOT_TILT + track.foot_pitch[:, side]
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
