"""B5 holding: the pose math that puts a held element where the grasp holds it, once per control period.

Takes a PyBullet pose (position, quaternion x, y, z, w) or a 4x4 transform; gives the transform
(:func:`matrix_of`) or the quaternion (:func:`quat_of`) with the numbers of
:func:`kbplanner.planning.carry.from_pos_quat` and :func:`kbplanner.planning.carry.quat_of`: SciPy's
formulas, operation by operation, without the array-API dispatch of
:class:`scipy.spatial.transform.Rotation` around them, which costs most of the time for one rotation
(about 100 us of 110 per quaternion). The quaternion is B4's
(:mod:`kbplanner.planning.rotation_numbers`); rotations outside its exact path are left to SciPy.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from kbplanner.planning.carry import from_pos_quat
from kbplanner.planning.rotation_numbers import quat_of_matrix

Matrix = npt.NDArray[np.float64]


def _rotation(x: float, y: float, z: float, w: float) -> list[list[float]]:
    """The rotation matrix of a unit quaternion: SciPy's ``as_matrix`` formula, operation by operation."""
    x2, y2, z2, w2 = x * x, y * y, z * z, w * w
    xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
    return [[x2 - y2 - z2 + w2, 2 * (xy - zw), 2 * (xz + yw)],
            [2 * (xy + zw), -x2 + y2 - z2 + w2, 2 * (yz - xw)],
            [2 * (xz - yw), 2 * (yz + xw), -x2 - y2 + z2 + w2]]


def _unit(q: Sequence[float]) -> tuple[float, float, float, float]:
    """A quaternion divided by its norm (SciPy's normalisation)."""
    x, y, z, w = (float(v) for v in q)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    return (x / n, y / n, z / n, w / n)


def matrix_of(pos: Sequence[float], quat: Sequence[float]) -> Matrix:
    """4x4 transform of a position and a PyBullet quaternion (``carry.from_pos_quat``'s numbers)."""
    x, y, z, w = (float(v) for v in quat)
    if not math.isfinite(x + y + z + w) or x * x + y * y + z * z + w * w == 0.0:
        return from_pos_quat(pos, quat)  # SciPy's errors
    m = np.eye(4)
    m[:3, :3] = _rotation(*_unit((x, y, z, w)))
    m[:3, 3] = list(pos)
    return m


def quat_of(m: Matrix) -> tuple[float, float, float, float]:
    """PyBullet quaternion (x, y, z, w) of a transform (``carry.quat_of``'s numbers: SciPy's
    ``Rotation.from_matrix``, by :func:`kbplanner.planning.rotation_numbers.quat_of_matrix`)."""
    return quat_of_matrix(m)


def _scipy_quat(m: Matrix) -> tuple[float, float, float, float]:
    x, y, z, w = (float(v) for v in Rotation.from_matrix(np.asarray(m)[:3, :3]).as_quat())
    return (x, y, z, w)


#: the reference implementations (for tests)
REFERENCE: dict[str, Callable[..., Any]] = {"matrix_of": from_pos_quat, "quat_of": _scipy_quat}
