"""Rigid transforms with MuJoCo's (w, x, y, z) quaternions, and their USD (Gf) forms."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray
from pxr import Gf

AXES = ("X", "Y", "Z")


def quat_mul(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, np.asarray(a, float), np.asarray(b, float))
    return out


def quat_conj(q: ArrayLike) -> NDArray[np.float64]:
    out = np.zeros(4)
    mujoco.mju_negQuat(out, np.asarray(q, float))
    return out


def rotate(q: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, np.asarray(v, float), np.asarray(q, float))
    return out


def _turn(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """The shortest rotation taking unit vector `a` to unit vector `b` (they must not be opposite)."""
    half = a + b
    half /= np.linalg.norm(half)
    quat = np.concatenate(([a @ half], np.cross(a, half)))
    return quat / np.linalg.norm(quat)


@dataclass(frozen=True)
class Pose:
    """A frame: position and orientation (w, x, y, z) in its parent's frame."""

    pos: NDArray[np.float64]
    quat: NDArray[np.float64]

    def apply(self, point: ArrayLike) -> NDArray[np.float64]:
        return self.pos + rotate(self.quat, point)

    def inverse_apply(self, point: ArrayLike) -> NDArray[np.float64]:
        return rotate(quat_conj(self.quat), np.asarray(point, float) - self.pos)

    def relative_quat(self, quat: ArrayLike) -> NDArray[np.float64]:
        """A world orientation expressed in this frame."""
        return quat_mul(quat_conj(self.quat), quat)


WORLD = Pose(np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))


def axis_frame(axis: ArrayLike) -> tuple[str, NDArray[np.float64]]:
    """The USD joint axis token (X, Y or Z: the one nearest `axis`) and the rotation taking it onto
    `axis`, so any MuJoCo axis becomes a standard USD axis in a rotated joint frame."""
    direction = np.asarray(axis, float) / np.linalg.norm(axis)
    index = int(np.argmax(np.abs(direction)))
    unit = np.eye(3)[index]
    if direction[index] > 0:
        return AXES[index], _turn(unit, direction)
    flip = np.concatenate(([0.0], np.eye(3)[(index + 1) % 3]))  # half turn: unit -> -unit
    return AXES[index], quat_mul(_turn(-unit, direction), flip)


def gf_quatf(quat: ArrayLike) -> Gf.Quatf:
    w, x, y, z = (float(v) for v in np.asarray(quat, float))
    return Gf.Quatf(w, x, y, z)


def _steady(value: float) -> float:
    """A double rounded to 1e-12 (and -0 made 0), so the written file does not depend on the last bits
    of the platform's arithmetic; far below every tolerance."""
    return round(float(value), 12) + 0.0


def gf_quatd(quat: ArrayLike) -> Gf.Quatd:
    w, x, y, z = (_steady(v) for v in np.asarray(quat, float))
    return Gf.Quatd(w, x, y, z)


def gf_vec3f(vec: ArrayLike) -> Gf.Vec3f:
    return Gf.Vec3f(*(float(v) for v in np.asarray(vec, float)))


def gf_vec3d(vec: ArrayLike) -> Gf.Vec3d:
    return Gf.Vec3d(*(_steady(v) for v in np.asarray(vec, float)))
