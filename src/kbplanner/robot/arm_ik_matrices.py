"""The 4 x 4 matrices of the closed-form arm IK (B4 arm poses per skill,
:mod:`kbplanner.robot.arm_analytic_ik`): DH link transforms and rigid inverses, alone and as stacks.

The stacked forms give the very floats of the lone ones (session 14, b4first14): each entry is the same
Python float expression, and numpy's matmul of a stack multiplies each pair of inner 4 x 4 (or 3 x 3
by 3) matrices with the same BLAS call and strides as it does two lone ones
(tests/test_ik_same_floats.py compares with the pre-session code bit for bit).

Example:
    >>> import math
    >>> m = dh_matrix(math.pi / 2, 0.1, 0.2, 0.0)
    >>> bool(abs(rigid_inverse(m) @ m - np.eye(4)).max() < 1e-12)
    True
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

Matrix = npt.NDArray[np.float64]

_LAST_ROW = np.array((0.0, 0.0, 0.0, 1.0))


def dh_entries(theta: float, d: float, a: float, alpha: float) -> tuple[float, ...]:
    """The 16 entries of :func:`dh_matrix`, row by row."""
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    return (ct, -st * ca, st * sa, a * ct,
            st, ct * ca, -ct * sa, a * st,
            0.0, sa, ca, d,
            0.0, 0.0, 0.0, 1.0)


def dh_matrix(theta: float, d: float, a: float, alpha: float) -> Matrix:
    """``Rz(theta) Tz(d) Tx(a) Rx(alpha)`` as a 4x4 matrix."""
    return np.array(dh_entries(theta, d, a, alpha)).reshape(4, 4)


def dh_stack(thetas: Sequence[float], d: float, a: float, alpha: float) -> Matrix:
    """:func:`dh_matrix` of each of ``thetas`` (n x 4 x 4)."""
    return np.array([dh_entries(theta, d, a, alpha) for theta in thetas]).reshape(len(thetas), 4, 4)


def dh_chain_many(d: Sequence[float], a: Sequence[float], alpha: Sequence[float],
                  qs: Sequence[Sequence[float]]) -> Matrix:
    """``eye(4) @ dh(q[0], ...) @ ... @ dh(q[5], ...)`` (left to right) of each of ``qs`` (n x 4 x 4)."""
    n = len(qs)
    t = np.tile(np.eye(4), (n, 1, 1))
    for i in range(len(d)):
        t = t @ dh_stack([float(q[i]) for q in qs], d[i], a[i], alpha[i])
    return t


def rigid_inverse(t: Matrix) -> Matrix:
    """The inverse of a rigid transform: ``R^T`` and ``-R^T p``."""
    out = np.empty((4, 4))
    r = t[:3, :3].T
    out[:3, :3] = r
    out[:3, 3] = -r @ t[:3, 3]
    out[3] = _LAST_ROW
    return out


def rigid_inverse_many(t: Matrix) -> Matrix:
    """:func:`rigid_inverse` of each of a stack (n x 4 x 4)."""
    out = np.empty(t.shape)
    r = t[:, :3, :3].transpose(0, 2, 1)
    out[:, :3, :3] = r
    out[:, :3, 3] = (-r @ t[:, :3, 3:4])[:, :, 0]
    out[:, 3] = _LAST_ROW
    return out


def cross3(a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """``np.cross`` of two 3-vectors, the same floats (its ``a1 * b2 - a2 * b1``, ... one float at a time)
    without its axis handling: a tenth of the time."""
    a0, a1, a2 = (float(v) for v in np.asarray(a, dtype=float).tolist())
    b0, b1, b2 = (float(v) for v in np.asarray(b, dtype=float).tolist())
    return np.array((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0))
