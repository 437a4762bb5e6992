"""Rigid poses (position, unit quaternion w-x-y-z) and the 4x4 matrix helpers the importer composes them with."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

Vec = NDArray[np.float64]


def quat(values: ArrayLike) -> Vec:
    """A normalized w-x-y-z quaternion."""
    q = np.asarray(values, dtype=np.float64)
    return q / np.linalg.norm(q)


def axis_angle(axis: ArrayLike, angle: float) -> Vec:
    """The quaternion rotating by `angle` radians about the unit vector `axis`."""
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * np.asarray(axis, dtype=np.float64)])


def rotate(q: Vec, vector: ArrayLike) -> Vec:
    """`vector` rotated by the quaternion `q`."""
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, np.asarray(vector, dtype=np.float64), q)
    return out


def quat_angle(q: Vec) -> float:
    """The rotation angle of `q` in [0, pi] radians."""
    return 2 * math.atan2(float(np.linalg.norm(q[1:])), abs(float(q[0])))


def matrix_quat(rotation: NDArray[np.float64]) -> Vec:
    """The quaternion of a 3x3 rotation matrix (column vectors)."""
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rotation, dtype=np.float64).reshape(9))
    return q


@dataclass(frozen=True)
class Pose:
    """A rigid transform: x -> rotate(quat, x) + pos."""

    pos: Vec
    quat: Vec

    def __mul__(self, other: Pose) -> Pose:
        """`self` after `other` (other expressed in self's frame)."""
        q = np.zeros(4)
        mujoco.mju_mulQuat(q, self.quat, other.quat)
        return Pose(self.pos + rotate(self.quat, other.pos), q / np.linalg.norm(q))

    def inverse(self) -> Pose:
        """The transform undoing this one."""
        conjugate = self.quat * np.array([1.0, -1.0, -1.0, -1.0])
        return Pose(-rotate(conjugate, self.pos), conjugate)

    def matrix(self) -> NDArray[np.float64]:
        """The 4x4 homogeneous matrix (column vectors)."""
        out = np.eye(4)
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, self.quat)
        out[:3, :3] = rotation.reshape(3, 3)
        out[:3, 3] = self.pos
        return out


IDENTITY = Pose(np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))


def decompose(matrix: NDArray[np.float64]) -> tuple[Pose, Vec]:
    """Split a 4x4 affine matrix into its rigid pose and per-axis scale (column norms; shear is dropped)."""
    linear = matrix[:3, :3]
    scale = np.linalg.norm(linear, axis=0)
    rotation = linear / scale
    if np.linalg.det(rotation) < 0:  # a mirror: fold it into the scale of the last axis
        scale[2], rotation[:, 2] = -scale[2], -rotation[:, 2]
    u, _, vt = np.linalg.svd(rotation)  # nearest rotation, in case of shear
    return Pose(matrix[:3, 3].copy(), matrix_quat(u @ vt)), scale
