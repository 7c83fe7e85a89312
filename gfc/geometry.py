"""Poses, frames and rotation representations, in NumPy (plans, simulation) and torch (energies).

Conventions
-----------
- A pose is ``[x, y, z, qx, qy, qz, qw]`` (PyBullet's quaternion order, scalar last).
- Inside the factor graph a pose is a 9-vector ``[x, y, z, r11, r21, r31, r12, r22, r32]``:
  the position and the first two *columns* of the rotation matrix (the "6D" representation of
  Zhou et al. 2019). It is continuous, has no sign ambiguity, and, importantly for composition,
  a change of frame acts on it *linearly*: for ``world_from_base = (R_b, t_b)`` the base-frame
  vector is ``[R_b^T (p - t_b), R_b^T c1, R_b^T c2]``. Scores therefore map between frames with
  an orthogonal matrix (see ``gfc.planner.frames``).
- Variable names carry frames: ``world_from_object`` maps object coordinates to world ones.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import torch

FloatArray = npt.NDArray[np.float64]

POSE7_DIM = 7
POSE9_DIM = 9


# ----------------------------------------------------------------------------- NumPy


def quat_to_matrix(quat: npt.ArrayLike) -> FloatArray:
    """``[qx, qy, qz, qw]`` (normalised here) -> 3x3 rotation matrix."""
    qx, qy, qz, qw = np.asarray(quat, dtype=np.float64) / np.linalg.norm(quat)
    return np.array(
        [
            [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
            [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
            [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
        ]
    )


def matrix_to_quat(rot: npt.ArrayLike) -> FloatArray:
    """3x3 rotation matrix -> ``[qx, qy, qz, qw]`` with ``qw >= 0`` (canonical sign)."""
    m = np.asarray(rot, dtype=np.float64)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [s / 4, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, s / 4, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, s / 4, (m[1, 0] - m[0, 1]) / s]
    quat = np.asarray(q)
    quat /= np.linalg.norm(quat)
    return -quat if quat[3] < 0 else quat


def yaw_quat(yaw: float) -> FloatArray:
    """Rotation about world z by ``yaw`` radians as ``[qx, qy, qz, qw]``."""
    return np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])


def pose7_to_matrix(pose: npt.ArrayLike) -> FloatArray:
    """``[x, y, z, qx, qy, qz, qw]`` -> 4x4 homogeneous transform."""
    p = np.asarray(pose, dtype=np.float64)
    out = np.eye(4)
    out[:3, :3] = quat_to_matrix(p[3:7])
    out[:3, 3] = p[:3]
    return out


def matrix_to_pose7(mat: npt.ArrayLike) -> FloatArray:
    m = np.asarray(mat, dtype=np.float64)
    return np.concatenate([m[:3, 3], matrix_to_quat(m[:3, :3])])


def matrix_to_pose9(mat: npt.ArrayLike) -> FloatArray:
    m = np.asarray(mat, dtype=np.float64)
    return np.concatenate([m[:3, 3], m[:3, 0], m[:3, 1]])


def pose9_to_matrix(vec: npt.ArrayLike) -> FloatArray:
    """9-vector -> 4x4 transform; the rotation is re-orthonormalised (Gram-Schmidt)."""
    v = np.asarray(vec, dtype=np.float64)
    out = np.eye(4)
    out[:3, :3] = rot6d_to_matrix_np(v[3:9])
    out[:3, 3] = v[:3]
    return out


def pose7_to_pose9(pose: npt.ArrayLike) -> FloatArray:
    return matrix_to_pose9(pose7_to_matrix(pose))


def pose9_to_pose7(vec: npt.ArrayLike) -> FloatArray:
    return matrix_to_pose7(pose9_to_matrix(vec))


def rot6d_to_matrix_np(six: npt.ArrayLike) -> FloatArray:
    s = np.asarray(six, dtype=np.float64)
    a1, a2 = s[0:3], s[3:6]
    b1 = a1 / max(float(np.linalg.norm(a1)), 1e-9)
    a2 = a2 - np.dot(b1, a2) * b1
    b2 = a2 / max(float(np.linalg.norm(a2)), 1e-9)
    b3 = np.cross(b1, b2)
    return np.stack([b1, b2, b3], axis=1)


def invert(mat: npt.ArrayLike) -> FloatArray:
    """Inverse of a rigid 4x4 transform."""
    m = np.asarray(mat, dtype=np.float64)
    out = np.eye(4)
    out[:3, :3] = m[:3, :3].T
    out[:3, 3] = -m[:3, :3].T @ m[:3, 3]
    return out


def yaw_of_matrix(rot: npt.ArrayLike) -> float:
    """Heading of the rotated x axis in the world xy plane, in radians."""
    r = np.asarray(rot, dtype=np.float64)
    return math.atan2(r[1, 0], r[0, 0])


def approach_frame(origin: npt.ArrayLike, target: npt.ArrayLike) -> FloatArray:
    """The 4x4 frame at ``target`` (its z kept) whose x axis points horizontally from ``origin`` to
    ``target`` (z up): "away from the robot" at the target, whatever the target's own yaw."""
    o = np.asarray(origin, dtype=np.float64)
    t = np.asarray(target, dtype=np.float64)
    yaw = math.atan2(t[1] - o[1], t[0] - o[0])
    c, s = math.cos(yaw), math.sin(yaw)
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    out[:3, 3] = t[:3]
    return out


def pose9_frame_map(world_from_frame: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The affine map ``v_frame = A @ v_world + b`` for 9-vector poses.

    ``A = blockdiag(R^T, R^T, R^T)`` is orthogonal, ``b = [-R^T t, 0, 0]``.
    """
    m = np.asarray(world_from_frame, dtype=np.float64)
    rot_t = m[:3, :3].T
    a = np.zeros((9, 9))
    for block in range(3):
        a[3 * block : 3 * block + 3, 3 * block : 3 * block + 3] = rot_t
    b = np.zeros(9)
    b[:3] = -rot_t @ m[:3, 3]
    return a, b


# ----------------------------------------------------------------------------- torch


def rot6d_to_matrix(six: torch.Tensor) -> torch.Tensor:
    """Differentiable Gram-Schmidt. ``six``: (..., 6) -> (..., 3, 3) with columns b1, b2, b3."""
    a1, a2 = six[..., 0:3], six[..., 3:6]
    b1 = a1 / a1.norm(dim=-1, keepdim=True).clamp_min(1e-6)
    a2 = a2 - (b1 * a2).sum(-1, keepdim=True) * b1
    b2 = a2 / a2.norm(dim=-1, keepdim=True).clamp_min(1e-6)
    b3 = torch.cross(b1, b2, dim=-1)
    return torch.stack([b1, b2, b3], dim=-1)


def pose9_to_transform(vec: torch.Tensor) -> torch.Tensor:
    """(..., 9) -> (..., 4, 4) homogeneous transforms."""
    rot = rot6d_to_matrix(vec[..., 3:9])  # (..., 3, 3)
    top = torch.cat([rot, vec[..., 0:3].unsqueeze(-1)], dim=-1)  # (..., 3, 4)
    bottom = torch.zeros(*vec.shape[:-1], 1, 4, dtype=vec.dtype, device=vec.device)
    bottom[..., 0, 3] = 1.0
    return torch.cat([top, bottom], dim=-2)


def transform_points(world_from_frame: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
    """Apply (..., 4, 4) transforms to (..., 3) points."""
    rot = world_from_frame[..., :3, :3]
    return (rot @ points.unsqueeze(-1)).squeeze(-1) + world_from_frame[..., :3, 3]


def relative_transform(world_from_a: torch.Tensor, world_from_b: torch.Tensor) -> torch.Tensor:
    """``a_from_b = inv(world_from_a) @ world_from_b`` for rigid (..., 4, 4) transforms."""
    rot_a_t = world_from_a[..., :3, :3].transpose(-1, -2)
    rot = rot_a_t @ world_from_b[..., :3, :3]
    trans = (rot_a_t @ (world_from_b[..., :3, 3] - world_from_a[..., :3, 3]).unsqueeze(-1)).squeeze(-1)
    top = torch.cat([rot, trans.unsqueeze(-1)], dim=-1)
    bottom = torch.zeros_like(top[..., :1, :])
    bottom[..., 0, 3] = 1.0
    return torch.cat([top, bottom], dim=-2)


def yaw_of_transform(world_from_frame: torch.Tensor) -> torch.Tensor:
    """Heading of the frame's x axis in the world xy plane. (..., 4, 4) -> (...)."""
    return torch.atan2(world_from_frame[..., 1, 0], world_from_frame[..., 0, 0])


def wrap_angle(angle: torch.Tensor) -> torch.Tensor:
    """Wrap to (-pi, pi]."""
    return torch.atan2(torch.sin(angle), torch.cos(angle))
