"""The HumanML3D 263-d motion representation and GMD's absolute-root variant.

Facts (REFERENCE.md "HumanML3D motion format"; EricGuo5513/HumanML3D ``process_file``,
``recover_root_rot_pos``, ``recover_from_ric``; korrawe/guided-motion-diffusion
``HumanML3D_abs/motion_representation.ipynb``). Torch throughout, batched over leading dims,
differentiable; numpy arrays are accepted (computed in float64).

Two quirks of HumanML3D's inverse kinematics are reproduced because the real data carry them
(checked against the real sample, tests/motion/test_features.py): the per-frame facing reads the
hips reversed, and the first frame's facing rotation is the identity.

The root heading is stored as HumanML3D stores it: ``features[..., 0]`` is the *half*-angle
arcsin(q_y) of the frame-to-frame facing quaternion, and the recovered facing quaternion is
(cos a, 0, sin a, 0) with a the accumulated half-angles, i.e. a rotation by 2a about +Y.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from repro.motion.quaternion import (
    numpy_compatible,
    qbetween,
    qinv,
    qmul,
    qrot,
    quat_about_y,
    quat_to_cont6d,
)
from repro.motion.skeleton import (
    FACE_JOINTS,
    FOOT_JOINTS,
    KINEMATIC_CHAINS,
    NUM_JOINTS,
    RAW_OFFSETS,
)

FEATURE_DIM = 263
FPS = 20
#: foot contact when a foot joint's squared per-frame displacement is below this (m²).
FOOT_CONTACT_THRESHOLD = 0.002
#: σ (frames) of the Gaussian that smooths the per-frame facing direction (HumanML3D's IK
#: ``smooth_forward=True``; scipy ``gaussian_filter1d``, mode "nearest", truncate 4).
FACING_SMOOTHING_SIGMA = 20.0

FEATURE_BLOCKS: OrderedDict[str, slice] = OrderedDict(
    root_rot_velocity=slice(0, 1),
    root_linear_velocity=slice(1, 3),
    root_y=slice(3, 4),
    ric_positions=slice(4, 67),
    rot_6d=slice(67, 193),
    local_velocity=slice(193, 259),
    foot_contact=slice(259, 263),
)
#: GMD's trajectory model sees (angle, x, z, y).
TRAJECTORY_FEATURES = slice(0, 4)
#: the features GMD's Emphasis projection scales by c (root angle and x/z).
EMPHASIS_FEATURES = slice(0, 3)
#: everything except the root block.
BODY_FEATURES = slice(4, FEATURE_DIM)

_UP = (0.0, 1.0, 0.0)
_FORWARD = (0.0, 0.0, 1.0)


def _check_features(features: torch.Tensor) -> None:
    if features.ndim < 2 or features.shape[-1] != FEATURE_DIM:
        raise ValueError(
            f"features must have shape (..., T, {FEATURE_DIM}), got {tuple(features.shape)}"
        )


def _check_joints(joints: torch.Tensor) -> None:
    if joints.ndim < 3 or joints.shape[-2:] != (NUM_JOINTS, 3):
        raise ValueError(
            f"joints must have shape (..., T, {NUM_JOINTS}, 3), got {tuple(joints.shape)}"
        )
    if joints.shape[-3] < 2:
        raise ValueError(
            f"joints need at least 2 frames to give velocities, got {joints.shape[-3]}"
        )


def _const(values: tuple[float, ...] | np.ndarray, like: torch.Tensor) -> torch.Tensor:
    return torch.as_tensor(np.asarray(values), dtype=like.dtype, device=like.device)


def _shift_and_accumulate(per_frame: torch.Tensor) -> torch.Tensor:
    """x_0 = 0, x_t = Σ_{s<t} v_s along the time axis -1 (HumanML3D's one-frame shift)."""
    shifted = torch.cat((torch.zeros_like(per_frame[..., :1]), per_frame[..., :-1]), dim=-1)
    return torch.cumsum(shifted, dim=-1)


# ---------------------------------------------------------------------------- features → joints

def _heading_quaternion(half_angle: torch.Tensor) -> torch.Tensor:
    """(cos a, 0, sin a, 0): the facing rotation for accumulated half-angle a."""
    return quat_about_y(2.0 * half_angle)


def _root_from_heading(half_angle: torch.Tensor, root_xz: torch.Tensor,
                       root_y: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    position = torch.stack((root_xz[..., 0], root_y, root_xz[..., 1]), dim=-1)
    return _heading_quaternion(half_angle), position


@numpy_compatible
def recover_root(features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Root facing quaternions (..., T, 4) and root positions (..., T, 3).

    HumanML3D ``recover_root_rot_pos``: a_0 = 0, a_t = Σ_{s<t} f_s[0]; q_t = (cos a_t, 0,
    sin a_t, 0); p_t^{xz} = Σ_{s<t} q_{s+1}⁻¹ · (f_s[1], 0, f_s[2]); p_t^y = f_t[3].
    The last frame's velocities are never used.
    """
    _check_features(features)
    half_angle = _shift_and_accumulate(features[..., 0])
    rotation = _heading_quaternion(half_angle)
    zero = torch.zeros_like(features[..., 1])
    local_velocity = torch.stack((features[..., 1], zero, features[..., 2]), dim=-1)
    # the velocity stored at frame s moves the root from s to s+1, in the facing frame of s+1.
    steps = torch.cat(
        (torch.zeros_like(local_velocity[..., :1, :]),
         qrot(qinv(rotation[..., 1:, :]), local_velocity[..., :-1, :])),
        dim=-2,
    )
    xz = torch.cumsum(steps, dim=-2)[..., [0, 2]]
    return _root_from_heading(half_angle, xz, features[..., 3])


def _ric_to_joints(features: torch.Tensor, rotation: torch.Tensor,
                   root_position: torch.Tensor,
                   joints: tuple[int, ...] | None = None) -> torch.Tensor:
    ric = features[..., FEATURE_BLOCKS["ric_positions"]].unflatten(-1, (NUM_JOINTS - 1, 3))
    if joints is not None:                     # non-root joints only: ric holds joints 1..21
        ric = ric[..., [j - 1 for j in joints], :]
    body = qrot(qinv(rotation)[..., None, :], ric)
    offset = torch.stack(
        (root_position[..., 0], torch.zeros_like(root_position[..., 0]), root_position[..., 2]),
        dim=-1,
    )
    if joints is not None:
        return body + offset[..., None, :]
    return torch.cat((root_position[..., None, :], body + offset[..., None, :]), dim=-2)


@numpy_compatible
def features_to_joints(features: torch.Tensor) -> torch.Tensor:
    """Joint positions (..., T, 22, 3) from relative-root features (HumanML3D ``recover_from_ric``).

    The 21 root-relative positions are rotated back by q_t⁻¹, shifted by the root's x/z and
    the root is prepended.
    """
    rotation, root_position = recover_root(features)
    return _ric_to_joints(features, rotation, root_position)


def features_to_some_joints(features: torch.Tensor, joints: Sequence[int]) -> torch.Tensor:
    """``features_to_joints(features)[..., joints, :]`` for non-root ``joints`` (indices
    1–21), rotating only those (torch; differentiable)."""
    if not joints or min(joints) < 1 or max(joints) >= NUM_JOINTS:
        raise ValueError(f"joints must be non-root joint indices 1..{NUM_JOINTS - 1}, got "
                         f"{list(joints)}")
    rotation, root_position = recover_root(features)
    return _ric_to_joints(features, rotation, root_position, tuple(joints))


# ------------------------------------------------------------------------- GMD's absolute root

@numpy_compatible
def relative_to_absolute_root(features: torch.Tensor) -> torch.Tensor:
    """GMD's absolute root: dim 0 → accumulated heading half-angle a_t (the value
    ``recover_root_rot_pos`` puts into cos/sin, a_0 = 0), dims 1–2 → world root x/z;
    dims 3–262 unchanged (HumanML3D_abs ``motion_representation.ipynb``)."""
    _check_features(features)
    half_angle = _shift_and_accumulate(features[..., 0])
    _, root_position = recover_root(features)
    return torch.cat(
        (half_angle[..., None], root_position[..., [0, 2]], features[..., 3:]), dim=-1
    )


@numpy_compatible
def absolute_to_relative_root(features: torch.Tensor) -> torch.Tensor:
    """Inverse of :func:`relative_to_absolute_root` by differencing.

    f_t[0] = a_{t+1} − a_t and f_t[1:3] = xz of q_{t+1} · (p_{t+1} − p_t). The relative
    representation's last-frame root velocities are not determined by the absolute one (nor
    used by :func:`recover_root`); like GMD (which duplicates the last step) they repeat the
    previous frame's values. So abs → rel → abs is exact on every frame and rel → abs → rel on
    every frame but the last of dims 0–2.
    """
    _check_features(features)
    if features.shape[-2] < 2:
        raise ValueError(f"need at least 2 frames to difference, got {features.shape[-2]}")
    half_angle = features[..., 0]
    rotation = _heading_quaternion(half_angle)
    zero = torch.zeros_like(half_angle)
    position = torch.stack((features[..., 1], zero, features[..., 2]), dim=-1)
    step = position[..., 1:, :] - position[..., :-1, :]
    local = qrot(rotation[..., 1:, :], step)[..., [0, 2]]
    angular = (half_angle[..., 1:] - half_angle[..., :-1])[..., None]
    root = torch.cat((angular, local), dim=-1)
    root = torch.cat((root, root[..., -1:, :]), dim=-2)
    return torch.cat((root, features[..., 3:]), dim=-1)


@numpy_compatible
def absolute_features_to_joints(features: torch.Tensor) -> torch.Tensor:
    """Joints (..., T, 22, 3) from absolute-root features (GMD ``recover_from_ric(abs_3d=True)``):
    heading and root x/z read directly instead of accumulated."""
    _check_features(features)
    rotation, root_position = _root_from_heading(features[..., 0], features[..., 1:3],
                                                 features[..., 3])
    return _ric_to_joints(features, rotation, root_position)


# ---------------------------------------------------------------------------- joints → features

def _facing_direction(joints: torch.Tensor, hips: tuple[int, int]) -> torch.Tensor:
    """Unnormalised forward direction up × across, across = unit((hips[0] − hips[1]) +
    (r_shoulder − l_shoulder)) (HumanML3D ``face_joint_indx``)."""
    _, _, r_shoulder, l_shoulder = FACE_JOINTS
    across = (joints[..., hips[0], :] - joints[..., hips[1], :]
              + joints[..., r_shoulder, :] - joints[..., l_shoulder, :])
    across = across / across.norm(dim=-1, keepdim=True)
    return torch.cross(_const(_UP, joints).expand_as(across), across, dim=-1)


#: hips as ``process_file`` reads them for the initial facing: right hip − left hip.
_HIPS = (FACE_JOINTS[0], FACE_JOINTS[1])
#: hips as HumanML3D's IK reads them: it unpacks ``face_joint_indx`` = (r_hip, l_hip, ...)
#: as (l_hip, r_hip, ...), so its per-frame facing uses left hip − right hip. The shoulder
#: span is wider than the hips', so the result still points forward, only noisier. The real
#: sample is reproduced only with this reversal (see tests/motion/test_features.py).
_IK_HIPS = (FACE_JOINTS[1], FACE_JOINTS[0])


def gaussian_smooth_time(values: torch.Tensor, sigma: float) -> torch.Tensor:
    """Gaussian filter along the time axis -2 of (..., T, C), edges extended with the nearest
    frame: scipy ``gaussian_filter1d(mode="nearest", truncate=4.0)``."""
    radius = int(4.0 * sigma + 0.5)
    taps = torch.arange(-radius, radius + 1, device=values.device)
    weights = torch.exp(-0.5 * (taps.to(values.dtype) / sigma) ** 2)
    weights = weights / weights.sum()
    frames = values.shape[-2]
    index = torch.arange(frames, device=values.device)[:, None] + taps[None, :]
    index = index.clamp(0, frames - 1)
    return (values[..., index, :] * weights[:, None]).sum(dim=-2)


def _bone_rotations_6d(joints: torch.Tensor, root_rotation: torch.Tensor) -> torch.Tensor:
    """HumanML3D's inverse kinematics, continuous 6D per joint 1..21 → (..., T, 126).

    For each kinematic chain, the shortest-arc rotation taking the rest direction of the bone
    parent → j onto its observed direction is expressed relative to the previous bone's and
    stored *at the child j* (a chain's first bone is relative to the root facing rotation —
    also for the arm chains, which start at spine3 but ignore the spine's rotation).
    """
    raw = _const(RAW_OFFSETS, joints)
    local: list[torch.Tensor | None] = [None] * NUM_JOINTS
    for chain in KINEMATIC_CHAINS:
        parent_global = root_rotation
        for parent, child in zip(chain[:-1], chain[1:], strict=True):
            bone = joints[..., child, :] - joints[..., parent, :]
            child_global = qbetween(raw[child].expand_as(bone), bone)
            local[child] = qmul(qinv(parent_global), child_global)
            parent_global = child_global
    return quat_to_cont6d(torch.stack(local[1:], dim=-2)).flatten(-2)


def _canonicalise(joints: torch.Tensor) -> torch.Tensor:
    """Floor at y = 0 (min over all joints and frames), frame-0 root x/z at the origin, and
    rotated about +Y so that frame 0 faces +Z (HumanML3D ``process_file``)."""
    floor = joints[..., 1].amin(dim=(-1, -2))
    root0 = joints[..., 0, 0, :]
    shift = torch.stack((root0[..., 0], floor, root0[..., 2]), dim=-1)
    joints = joints - shift[..., None, None, :]
    forward0 = _facing_direction(joints[..., 0, :, :], _HIPS)
    turn = qbetween(forward0, _const(_FORWARD, joints).expand_as(forward0))
    return qrot(turn[..., None, None, :], joints)


def _facing_rotations(positions: torch.Tensor, smoothing_sigma: float) -> torch.Tensor:
    """r_t (..., T, 4): the rotation taking the smoothed IK forward direction onto +Z, with
    r_0 = identity (HumanML3D's IK overwrites the first frame's root rotation)."""
    forward = _facing_direction(positions, _IK_HIPS)
    if smoothing_sigma > 0:
        forward = gaussian_smooth_time(forward, smoothing_sigma)
    facing = qbetween(forward, _const(_FORWARD, positions).expand_as(forward))
    identity = _const((1.0, 0.0, 0.0, 0.0), facing).expand_as(facing[..., :1, :])
    return torch.cat((identity, facing[..., 1:, :]), dim=-2)


def _foot_contacts(joints: torch.Tensor, threshold: float) -> torch.Tensor:
    feet = list(FOOT_JOINTS["left"] + FOOT_JOINTS["right"])
    step = joints[..., 1:, feet, :] - joints[..., :-1, feet, :]
    return (step.pow(2).sum(dim=-1) < threshold).to(joints.dtype)


def _joints_to_features(joints: torch.Tensor, foot_threshold: float,
                        smoothing_sigma: float) -> tuple[torch.Tensor, torch.Tensor]:
    _check_joints(joints)
    positions = _canonicalise(joints)
    facing = _facing_rotations(positions, smoothing_sigma)

    root = positions[..., 0, :]
    root_velocity = qrot(facing[..., 1:, :], root[..., 1:, :] - root[..., :-1, :])[..., [0, 2]]
    turn = qmul(facing[..., 1:, :], qinv(facing[..., :-1, :]))
    # q and −q are the same rotation; HumanML3D's arcsin(q_y) assumes w ≥ 0 (REFERENCE pitfall).
    turn = torch.where(turn[..., :1] < 0, -turn, turn)
    angular = torch.asin(turn[..., 2:3].clamp(-1.0, 1.0))

    centred = positions - (root * _const((1.0, 0.0, 1.0), root))[..., None, :]
    ric = qrot(facing[..., None, :], centred)[..., 1:, :].flatten(-2)
    rot6d = _bone_rotations_6d(positions, facing)
    velocity = positions[..., 1:, :, :] - positions[..., :-1, :, :]
    local_velocity = qrot(facing[..., :-1, None, :], velocity).flatten(-2)
    contacts = _foot_contacts(positions, foot_threshold)

    features = torch.cat(
        (angular, root_velocity, root[..., :-1, 1:2], ric[..., :-1, :], rot6d[..., :-1, :],
         local_velocity, contacts),
        dim=-1,
    )
    return features, features_to_joints(features)


def joints_to_features(
    joints: np.ndarray | torch.Tensor,
    *,
    foot_threshold: float = FOOT_CONTACT_THRESHOLD,
    smoothing_sigma: float = FACING_SMOOTHING_SIGMA,
) -> tuple[np.ndarray | torch.Tensor, np.ndarray | torch.Tensor]:
    """HumanML3D features (..., T−1, 263) and canonical joints (..., T−1, 22, 3) from raw
    joint positions (..., T, 22, 3) at 20 fps (HumanML3D ``process_file`` + its IK).

    The motion is put on the floor, frame 0's root moved to x = z = 0 and turned to face +Z
    (facing from right − left hip plus right − left shoulder). Per frame, the facing rotation
    r_t takes the Gaussian-smoothed (σ = 20 frames) IK forward direction onto +Z, r_0 = identity
    (both quirks of HumanML3D's IK: see ``_IK_HIPS``, ``_facing_rotations``). Then:
    [0] arcsin of the y part of r_{t+1} r_t⁻¹ (the half-angle); [1:3] root x/z velocity
    rotated by r_{t+1}; [3] root height; [4:67] joints 1–21 relative to the root's x/z, rotated
    by r_t; [67:193] continuous 6D (first two columns of R) of the IK rotations;
    [193:259] all joint velocities rotated by r_t; [259:263] contacts of joints 7, 10, 8, 11
    (squared displacement per frame < ``foot_threshold``). The last frame only feeds the
    velocities, so T frames give T − 1 feature frames.

    Canonical joints are ``features_to_joints(features)``, i.e. the canonicalised input
    without its last frame (because r_0 = identity, recovery returns the motion unrotated) —
    what HumanML3D stores as ``new_joints``. The skeleton is *not* retargeted (HumanML3D's
    ``uniform_skeleton`` step); bone lengths are kept as given.

    Numpy input is computed in float64 and returned as float32 (the on-disk dtype); torch
    input keeps its dtype and stays differentiable (except the thresholded contacts).
    """
    if isinstance(joints, np.ndarray):
        features, canonical = _joints_to_features(
            torch.from_numpy(np.asarray(joints, dtype=np.float64)), foot_threshold,
            smoothing_sigma)
        return features.numpy().astype(np.float32), canonical.numpy().astype(np.float32)
    return _joints_to_features(joints, foot_threshold, smoothing_sigma)


def split_blocks(features: np.ndarray | torch.Tensor) -> dict[str, np.ndarray | torch.Tensor]:
    """The named blocks of :data:`FEATURE_BLOCKS` as views of ``features`` (..., 263)."""
    if features.shape[-1] != FEATURE_DIM:
        raise ValueError(f"features must end in {FEATURE_DIM} values, got {tuple(features.shape)}")
    return {name: features[..., block] for name, block in FEATURE_BLOCKS.items()}


@dataclass(frozen=True)
class Conformance:
    """Our feature code against one real HumanML3D clip (:func:`conformance`)."""

    #: max |features_to_joints(features) − new_joints| (m)
    joint_error: float
    #: frames 0 … exact_frames − 1 have their whole facing-smoothing window inside new_joints
    exact_frames: int
    #: block → (max |joints_to_features(new_joints) − features| on all frames, on the exact ones)
    block_errors: dict[str, tuple[float, float]]


def conformance(features: np.ndarray, joints: np.ndarray) -> Conformance:
    """Compare our feature code with a real clip's ``new_joint_vecs`` (T, 263) and
    ``new_joints`` (T, 22, 3): joints recovered from the features against ``new_joints``, and
    features recomputed from ``new_joints`` against the features, block by block.

    HumanML3D smooths the facing over ±radius frames (``gaussian_filter1d``, σ =
    :data:`FACING_SMOOTHING_SIGMA`, radius int(4σ + 0.5) = 80) of the raw clip, one frame
    longer than ``new_joints``; a frame t whose window and next frame stay inside
    ``new_joints`` (t + radius + 1 < T) is reproducible exactly, later ones are not.
    """
    features, joints = np.asarray(features), np.asarray(joints)
    joint_error = float(np.abs(features_to_joints(features) - joints).max())
    recomputed, _ = joints_to_features(joints)
    radius = int(4.0 * FACING_SMOOTHING_SIGMA + 0.5)
    exact = max(0, len(joints) - 1 - radius)
    n = len(recomputed)
    errors = {}
    for name, block in FEATURE_BLOCKS.items():
        diff = np.abs(recomputed[:, block] - features[:n, block])
        errors[name] = (float(diff.max()), float(diff[:exact].max()) if exact else float("nan"))
    return Conformance(joint_error=joint_error, exact_frames=exact, block_errors=errors)
