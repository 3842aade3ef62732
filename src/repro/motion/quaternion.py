"""Unit quaternions (w, x, y, z) and continuous 6D rotations, in torch.

Every function takes torch tensors with any leading batch shape; ``numpy_compatible``
lets the public motion functions accept numpy arrays too (computed in float64, returned
as numpy). Rotations act on column vectors: ``qrot(q, v) = q ⊗ (0, v) ⊗ q⁻¹``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np
import torch


def numpy_compatible(function: Callable[..., Any]) -> Callable[..., Any]:
    """Run a torch function on numpy inputs: arrays become float64 tensors and results
    go back to numpy in the dtype of the first array argument."""

    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        arrays = [a for a in args if isinstance(a, np.ndarray)]
        if not arrays:
            return function(*args, **kwargs)
        dtype = arrays[0].dtype if arrays[0].dtype.kind == "f" else np.float64
        converted = [torch.from_numpy(np.asarray(a, dtype=np.float64)) if isinstance(a, np.ndarray)
                     else a for a in args]
        result = function(*converted, **kwargs)

        def back(value: Any) -> Any:
            if isinstance(value, torch.Tensor):
                return value.detach().cpu().numpy().astype(dtype)
            if isinstance(value, tuple):
                return tuple(back(v) for v in value)
            return value

        return back(result)

    return wrapper


def qmul(q: torch.Tensor, r: torch.Tensor) -> torch.Tensor:
    """Hamilton product q ⊗ r."""
    w1, x1, y1, z1 = q.unbind(-1)
    w2, x2, y2, z2 = r.unbind(-1)
    return torch.stack(
        (
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ),
        dim=-1,
    )


def qinv(q: torch.Tensor) -> torch.Tensor:
    """Inverse of a unit quaternion (its conjugate)."""
    return q * q.new_tensor([1.0, -1.0, -1.0, -1.0])


def qnormalize(q: torch.Tensor, eps: float = 1e-12) -> torch.Tensor:
    return q / q.norm(dim=-1, keepdim=True).clamp_min(eps)


def qrot(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate 3-vectors v by unit quaternions q: v' = v + 2w(u×v) + 2u×(u×v), u = (x, y, z)."""
    q, v = torch.broadcast_tensors(q, torch.cat((torch.zeros_like(v[..., :1]), v), dim=-1))
    u, w, vec = q[..., 1:], q[..., :1], v[..., 1:]
    uv = torch.cross(u, vec, dim=-1)
    uuv = torch.cross(u, uv, dim=-1)
    return vec + 2.0 * (w * uv + uuv)


def axis_angle_to_quat(axis: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    """q = (cos θ/2, sin θ/2 · n) for a unit axis n (broadcast against angle[..., None])."""
    axis = axis / axis.norm(dim=-1, keepdim=True).clamp_min(1e-12)
    half = angle[..., None] / 2.0
    return torch.cat((torch.cos(half), torch.sin(half) * axis), dim=-1)


def quat_about_y(angle: torch.Tensor) -> torch.Tensor:
    """Rotation by ``angle`` radians about +Y (the up axis): (cos θ/2, 0, sin θ/2, 0)."""
    half = angle / 2.0
    zero = torch.zeros_like(half)
    return torch.stack((torch.cos(half), zero, torch.sin(half), zero), dim=-1)


def qbetween(u: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """The shortest-arc unit quaternion taking direction u onto direction v."""
    u = u / u.norm(dim=-1, keepdim=True).clamp_min(1e-12)
    v = v / v.norm(dim=-1, keepdim=True).clamp_min(1e-12)
    w = 1.0 + (u * v).sum(-1, keepdim=True)
    xyz = torch.cross(u, v, dim=-1)
    opposite = w[..., 0] < 1e-9
    if bool(opposite.any()):
        # 180°: any axis orthogonal to u works; pick u × e_x, or u × e_y when u ∥ e_x.
        ex = torch.zeros_like(u)
        ex[..., 0] = 1.0
        ey = torch.zeros_like(u)
        ey[..., 1] = 1.0
        axis = torch.cross(u, ex, dim=-1)
        axis = torch.where(axis.norm(dim=-1, keepdim=True) < 1e-6, torch.cross(u, ey, dim=-1), axis)
        xyz = torch.where(opposite[..., None], axis, xyz)
    return qnormalize(torch.cat((w, xyz), dim=-1))


def quat_to_matrix(q: torch.Tensor) -> torch.Tensor:
    """3×3 rotation matrix of a unit quaternion (acts on column vectors)."""
    w, x, y, z = qnormalize(q).unbind(-1)
    return torch.stack(
        (
            1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
            2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
            2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
        ),
        dim=-1,
    ).reshape(q.shape[:-1] + (3, 3))


def matrix_to_cont6d(matrix: torch.Tensor) -> torch.Tensor:
    """Continuous 6D representation (Zhou et al. 2019): the first two columns of R."""
    return torch.cat((matrix[..., :, 0], matrix[..., :, 1]), dim=-1)


def quat_to_cont6d(q: torch.Tensor) -> torch.Tensor:
    return matrix_to_cont6d(quat_to_matrix(q))


def cont6d_to_matrix(cont6d: torch.Tensor) -> torch.Tensor:
    """Gram–Schmidt on the two stored columns; the third is their cross product."""
    a, b = cont6d[..., :3], cont6d[..., 3:]
    x = a / a.norm(dim=-1, keepdim=True).clamp_min(1e-12)
    z = torch.cross(x, b, dim=-1)
    z = z / z.norm(dim=-1, keepdim=True).clamp_min(1e-12)
    y = torch.cross(z, x, dim=-1)
    return torch.stack((x, y, z), dim=-1)
