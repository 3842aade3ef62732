"""The 22-joint HumanML3D skeleton (SMPL joint order) and forward kinematics.

Facts from HumanML3D's ``paramUtil.py`` (see ``../shared/REFERENCE.md``): kinematic chains,
raw offset directions, and the bone lengths of its target skeleton. Y is up, the body faces +Z.
"""

from __future__ import annotations

import numpy as np
import torch

from repro.motion.quaternion import numpy_compatible, qmul, qrot

JOINT_NAMES: tuple[str, ...] = (
    "pelvis", "L_hip", "R_hip", "spine1", "L_knee", "R_knee", "spine2", "L_ankle", "R_ankle",
    "spine3", "L_foot", "R_foot", "neck", "L_collar", "R_collar", "head", "L_shoulder",
    "R_shoulder", "L_elbow", "R_elbow", "L_wrist", "R_wrist",
)
NUM_JOINTS = len(JOINT_NAMES)
JOINT_INDEX = {name: i for i, name in enumerate(JOINT_NAMES)}

#: HumanML3D's t2m_kinematic_chain: right leg, left leg, spine+head, right arm, left arm.
KINEMATIC_CHAINS: tuple[tuple[int, ...], ...] = (
    (0, 2, 5, 8, 11),
    (0, 1, 4, 7, 10),
    (0, 3, 6, 9, 12, 15),
    (9, 14, 17, 19, 21),
    (9, 13, 16, 18, 20),
)


def _parents() -> tuple[int, ...]:
    parents = [-1] * NUM_JOINTS
    for chain in KINEMATIC_CHAINS:
        for parent, child in zip(chain[:-1], chain[1:], strict=True):
            parents[child] = parent
    return tuple(parents)


#: parent of each joint (-1 for the pelvis).
PARENTS: tuple[int, ...] = _parents()

#: t2m_raw_offsets: unit direction of each bone (parent → joint) in the rest pose.
RAW_OFFSETS = np.array(
    [[0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, -1, 0], [0, 1, 0],
     [0, -1, 0], [0, -1, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1], [0, 1, 0], [1, 0, 0],
     [-1, 0, 0], [0, 0, 1], [0, -1, 0], [0, -1, 0], [0, -1, 0], [0, -1, 0], [0, -1, 0],
     [0, -1, 0]],
    dtype=np.float64,
)

#: bone lengths (m) of joints 1–21 to their parents, HumanML3D's target skeleton; 0 for the root.
BONE_LENGTHS = np.array(
    [0.0, 0.1031, 0.1099, 0.1316, 0.3936, 0.3902, 0.1432, 0.4324, 0.4256, 0.0574, 0.1434,
     0.1494, 0.2194, 0.1375, 0.1434, 0.1030, 0.1316, 0.1230, 0.2568, 0.2631, 0.2660, 0.2699],
    dtype=np.float64,
)

#: rest-pose bone vectors (22, 3): direction × length.
OFFSETS = RAW_OFFSETS * BONE_LENGTHS[:, None]

FOOT_JOINTS = {"left": (7, 10), "right": (8, 11)}  # ankle, foot (the foot-contact joints)
#: face_joint_indx in HumanML3D: right hip, left hip, right shoulder (collar), left shoulder.
FACE_JOINTS = (2, 1, 17, 16)


@numpy_compatible
def forward_kinematics(root_positions: torch.Tensor, local_rotations: torch.Tensor,
                       offsets: torch.Tensor | None = None) -> torch.Tensor:
    """Global joint positions from the root position and per-joint local rotations.

    Standard FK: G_0 = R_0, G_j = G_parent(j) ⊗ R_j, and
    p_j = p_parent(j) + G_parent(j) · offset_j (the rotation *at* a joint turns the bones
    leaving it). This is the generator's convention; feature extraction never needs it,
    because features are computed from joint positions, as HumanML3D does.

    Args:
        root_positions: (..., 3) pelvis positions.
        local_rotations: (..., 22, 4) unit quaternions (w, x, y, z).
        offsets: (22, 3) rest-pose bone vectors; defaults to :data:`OFFSETS`.
    Returns:
        (..., 22, 3) joint positions.
    """
    if local_rotations.shape[-2:] != (NUM_JOINTS, 4):
        raise ValueError(f"local_rotations must end in (22, 4), got {tuple(local_rotations.shape)}")
    if offsets is None:
        offsets = torch.as_tensor(OFFSETS, dtype=local_rotations.dtype,
                                  device=local_rotations.device)
    global_rotations: list[torch.Tensor | None] = [None] * NUM_JOINTS
    positions: list[torch.Tensor | None] = [None] * NUM_JOINTS
    global_rotations[0] = local_rotations[..., 0, :]
    positions[0] = root_positions
    for joint in range(1, NUM_JOINTS):  # SMPL order lists every parent before its children
        parent = PARENTS[joint]
        parent_rotation = global_rotations[parent]
        bone = offsets[joint].expand_as(root_positions)
        positions[joint] = positions[parent] + qrot(parent_rotation, bone)
        global_rotations[joint] = qmul(parent_rotation, local_rotations[..., joint, :])
    return torch.stack(positions, dim=-2)


def bone_lengths(joints: np.ndarray | torch.Tensor) -> np.ndarray | torch.Tensor:
    """Length of every bone (..., 22) of a joint array (..., 22, 3); 0 at the root."""
    parents = list(PARENTS)
    parents[0] = 0
    diff = joints - joints[..., parents, :]
    if isinstance(diff, torch.Tensor):
        return diff.norm(dim=-1)
    return np.linalg.norm(diff, axis=-1)
