"""B5 holding: the pose math that puts a held element where the grasp holds it, once per control period.

Takes a PyBullet pose (position, quaternion x, y, z, w) or a 4x4 transform; gives the transform
(:func:`matrix_of`) or the quaternion (:func:`quat_of`) with the numbers of
:func:`kbplanner.planning.carry.from_pos_quat` and :func:`kbplanner.planning.carry.quat_of`: the same
SciPy routines (its compiled rotation backend) on the same arrays, without the array-API dispatch of
:class:`scipy.spatial.transform.Rotation` around them, which costs most of the time for one rotation
(about 100 us of 110 per quaternion). Where that backend is not there (another SciPy), the public
class is used: the numbers are the same either way.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from kbplanner.planning.carry import from_pos_quat
from kbplanner.planning.carry import quat_of as _quat_of_public

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
    """PyBullet quaternion (x, y, z, w) of a transform (``carry.quat_of``'s numbers).

    SciPy first checks the rotation: a non-positive determinant is an error, a Gram matrix farther
    from the identity than ``isclose(atol=1e-12)`` (relative 1e-5) is orthogonalised by an SVD first.
    Here a rotation certainly inside those bounds (half of them: a few ulp of rounding can not cross
    them) takes Shepperd's method directly, operation by operation as SciPy does it; any other is
    left to SciPy."""
    (a, b, c), (d, e, f), (g, h, i) = np.asarray(m, dtype=np.float64)[:3, :3].tolist()
    rows = ((a, b, c), (d, e, f), (g, h, i))
    for r in range(3):
        for s in range(r, 3):
            dot = rows[r][0] * rows[s][0] + rows[r][1] * rows[s][1] + rows[r][2] * rows[s][2]
            if not abs(dot - (1.0 if r == s else 0.0)) < (5e-6 if r == s else 5e-13):
                return _quat_of_public(m)
    if not a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) > 0.5:
        return _quat_of_public(m)
    trace = a + e + i
    decision = (a, e, i, trace)
    choice = max(range(4), key=decision.__getitem__)  # the first of equal ones, as argmax
    mat = ((a, b, c), (d, e, f), (g, h, i))
    q = [0.0, 0.0, 0.0, 0.0]
    if choice != 3:
        ii = choice
        jj = (ii + 1) % 3
        kk = (jj + 1) % 3
        q[ii] = 1 - trace + 2 * mat[ii][ii]
        q[jj] = mat[jj][ii] + mat[ii][jj]
        q[kk] = mat[kk][ii] + mat[ii][kk]
        q[3] = mat[kk][jj] - mat[jj][kk]
    else:
        q[0] = h - f
        q[1] = c - g
        q[2] = d - b
        q[3] = 1 + trace
    return _unit(q)


#: the reference implementations (for tests)
REFERENCE: dict[str, Callable[..., Any]] = {"matrix_of": from_pos_quat, "quat_of": _quat_of_public}
