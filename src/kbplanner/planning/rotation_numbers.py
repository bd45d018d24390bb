"""B4 pose math: a rotation's quaternion and roll, pitch, yaw with SciPy's numbers, without its dispatch.

B4 asks the roll, pitch and yaw of every tool frame it solves the IK for (:func:`kbplanner.planning.carry.
rpy_of`, some 1 400 a case-study scenario) and the quaternion of every probe it places
(:func:`kbplanner.planning.carry.quat_of`). ``Rotation.from_matrix`` checks and converts one matrix in
about 40 us of the 65 each takes; here:

- :func:`quat_of_matrix`: a rotation certainly within SciPy's bounds (its Gram matrix within half of
  ``isclose(atol=1e-12)`` of the identity, the determinant positive) by Shepperd's method, operation by
  operation as SciPy's ``from_matrix`` does it (what :mod:`kbplanner.simulation.held_pose` does for B5);
  any other matrix is left to SciPy (its SVD or its error);
- :func:`rpy_of_matrix`: that quaternion's extrinsic ``xyz`` angles by SciPy's own compiled
  ``as_euler`` (the routine ``Rotation.as_euler`` calls for one rotation), its gimbal-lock warning
  not raised (``carry.rpy_of`` silences it).

The same floats as ``Rotation.from_matrix(m).as_quat()`` and ``.as_euler("xyz")``
(tests/test_rotation_numbers.py compares them bit for bit on random, gimbal-locked and slightly
non-orthogonal matrices). Where SciPy's compiled backend is not there (another SciPy), the public
class is used.

Example:
    >>> import numpy as np
    >>> m = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    >>> [round(v, 6) for v in quat_of_matrix(m)], [round(v, 6) for v in rpy_of_matrix(m)]
    ([0.0, 0.0, 0.707107, 0.707107], [0.0, 0.0, 1.570796])
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

try:  # SciPy's compiled rotation backend (what Rotation calls for one NumPy rotation)
    from scipy.spatial.transform import _rotation_cy

    _AS_EULER: Callable[..., Any] | None = _rotation_cy.as_euler
except (ImportError, AttributeError):  # pragma: no cover - another SciPy
    _AS_EULER = None

Quat = tuple[float, float, float, float]


def _public_quat(m: npt.ArrayLike) -> Quat:
    x, y, z, w = (float(v) for v in Rotation.from_matrix(np.asarray(m)[:3, :3]).as_quat())
    return (x, y, z, w)


def _public_rpy(m: npt.ArrayLike) -> tuple[float, float, float]:
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock detected")
        r, p, y = (float(v) for v in Rotation.from_matrix(np.asarray(m)[:3, :3]).as_euler("xyz"))
    return (r, p, y)


def _shepperd(m: npt.ArrayLike) -> Quat | None:
    """SciPy's quaternion of a rotation certainly within its checks, else None."""
    (a, b, c), (d, e, f), (g, h, i) = np.asarray(m, dtype=np.float64)[:3, :3].tolist()
    rows = ((a, b, c), (d, e, f), (g, h, i))
    for r in range(3):
        for s in range(r, 3):
            dot = rows[r][0] * rows[s][0] + rows[r][1] * rows[s][1] + rows[r][2] * rows[s][2]
            if not abs(dot - (1.0 if r == s else 0.0)) < (5e-6 if r == s else 5e-13):
                return None
    if not a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) > 0.5:
        return None
    trace = a + e + i
    decision = (a, e, i, trace)
    choice = max(range(4), key=decision.__getitem__)  # the first of equal ones, as argmax
    q = [0.0, 0.0, 0.0, 0.0]
    if choice != 3:
        ii = choice
        jj = (ii + 1) % 3
        kk = (jj + 1) % 3
        q[ii] = 1 - trace + 2 * rows[ii][ii]
        q[jj] = rows[jj][ii] + rows[ii][jj]
        q[kk] = rows[kk][ii] + rows[ii][kk]
        q[3] = rows[kk][jj] - rows[jj][kk]
    else:
        q[0] = h - f
        q[1] = c - g
        q[2] = d - b
        q[3] = 1 + trace
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def quat_of_matrix(m: npt.ArrayLike) -> Quat:
    """``Rotation.from_matrix(m[:3, :3]).as_quat()`` (x, y, z, w) as floats."""
    q = _shepperd(m)
    return q if q is not None else _public_quat(m)


def rpy_of_matrix(m: npt.ArrayLike) -> tuple[float, float, float]:
    """``Rotation.from_matrix(m[:3, :3]).as_euler("xyz")`` as floats, without the gimbal-lock warning."""
    q = _shepperd(m) if _AS_EULER is not None else None
    if q is None or _AS_EULER is None:
        return _public_rpy(m)
    r, p, y = (float(v) for v in _AS_EULER(np.array([q], dtype=np.float64), "xyz", degrees=False,
                                           suppress_warnings=True)[0])
    return (r, p, y)
