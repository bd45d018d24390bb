"""B5 per-tick speed-ups of session 8 (tickfast) that claim identical results, each against the
former code (kept here, or in the library, as the reference)."""

from __future__ import annotations

import math

import numpy as np

from kbplanner.planning import carry
from kbplanner.simulation import held_pose


def _random_quat(rng: np.random.Generator, k: int) -> list[float]:
    q = rng.normal(size=4)
    if k % 3 == 0:
        q /= np.linalg.norm(q)
    if k % 7 == 0:
        q[int(rng.integers(4))] = 0.0
    return [float(v) for v in q]


def test_held_element_matrix_is_bit_identical_to_scipys() -> None:
    rng = np.random.default_rng(11)
    for k in range(4000):
        q = _random_quat(rng, k)
        pos = rng.normal(size=3).tolist()
        assert held_pose.matrix_of(pos, q).tobytes() == carry.from_pos_quat(pos, q).tobytes(), (pos, q)


def test_held_element_quaternion_is_bit_identical_to_scipys() -> None:
    rng = np.random.default_rng(12)
    kinds = {"off orthogonal": 0, "orthogonal": 0}
    for k in range(4000):
        a = carry.from_pos_quat(rng.normal(size=3).tolist(), _random_quat(rng, k))
        m = a @ carry.transform(*rng.normal(size=6).tolist())  # a product: rounding off orthogonality
        if k % 5 == 0:  # farther off: past the direct path's bounds, or SciPy's own (its SVD)
            m[:3, :3] += rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-16, -4)
        if k % 11 == 0:  # quarter turns: ties in Shepperd's choice, zeros
            m = carry.transform(0, 0, 0, *(rng.integers(-2, 3, size=3) * math.pi / 2).tolist())
        gram = m[:3, :3] @ m[:3, :3].T
        kinds["off orthogonal" if np.abs(gram - np.eye(3)).max() > 1e-13 else "orthogonal"] += 1
        assert held_pose.quat_of(m) == carry.quat_of(m), m
    assert min(kinds.values()) > 100, kinds
