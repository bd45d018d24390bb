"""planning/rotation_numbers.py: SciPy's quaternion and roll, pitch, yaw of a matrix, bit for bit (B4)."""

from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from kbplanner.planning import carry
from kbplanner.planning.rotation_numbers import quat_of_matrix, rpy_of_matrix


def _public(m: np.ndarray) -> tuple[tuple[float, ...], tuple[float, ...]]:
    r = Rotation.from_matrix(np.asarray(m)[:3, :3])
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock detected")
        rpy = tuple(float(v) for v in r.as_euler("xyz"))
    return tuple(float(v) for v in r.as_quat()), rpy


def _matrices() -> list[np.ndarray]:
    rng = np.random.default_rng(13)
    ms = list(Rotation.random(3000, random_state=4).as_matrix())
    ms += [Rotation.from_euler("xyz", [a, s * np.pi / 2, b]).as_matrix()  # gimbal lock
           for a in np.linspace(-3, 3, 5) for b in np.linspace(-3, 3, 5) for s in (1.0, -1.0)]
    ms += [np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0])]
    ms += [m + rng.normal(0.0, 1e-9, (3, 3)) for m in ms[:300]]  # orthogonalised by SciPy's SVD
    ms += [m + rng.normal(0.0, 1e-15, (3, 3)) for m in ms[:300]]  # a few ulp off
    for m in ms[:200]:  # 4 x 4 transforms
        t = np.eye(4)
        t[:3, :3] = m
        t[:3, 3] = rng.normal(size=3)
        ms.append(t)
    return ms


def test_same_floats_as_scipy() -> None:
    for m in _matrices():
        quat, rpy = _public(m)
        assert quat_of_matrix(m) == quat
        assert rpy_of_matrix(m) == rpy
        assert carry.quat_of(m if m.shape == (4, 4) else np.pad(m, ((0, 1), (0, 1)))) == quat
        assert carry.rpy_of(m) == rpy


def test_not_a_rotation_is_scipys_error() -> None:
    mirror = np.diag([1.0, 1.0, -1.0])
    for f in (quat_of_matrix, rpy_of_matrix):
        try:
            f(mirror)
        except ValueError as exc:
            assert "determinant" in str(exc)
        else:
            raise AssertionError("a mirror is not a rotation")
