"""B5 speed-ups that claim identical results: the plain-float paths against the numpy ones."""

from __future__ import annotations

import numpy as np

from kbplanner.simulation import separation
from kbplanner.simulation.separation import rects_distance
from kbplanner.world.footprint import Rect


def _vectorised(px: np.ndarray, py: np.ndarray, pose: tuple[float, float, float], rects: list[Rect]):
    old = separation.SCALAR_POINTS
    separation.SCALAR_POINTS = -1
    try:
        return rects_distance(px, py, pose, rects)
    finally:
        separation.SCALAR_POINTS = old


def test_point_distance_is_bit_identical_to_the_numpy_path() -> None:
    rng = np.random.default_rng(3)
    rects = [Rect(0.0, 0.0, 0.99, 0.67), Rect(0.4, 0.1, 1.2, 0.3, 0.3), Rect(-0.2, 0.0, 0.5, 2.0, 1.2)]
    for trial in range(300):
        pose = (float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3)), float(rng.uniform(-4, 4)))
        n = int(rng.integers(1, separation.SCALAR_POINTS + 1))
        px, py = rng.uniform(-5, 5, n), rng.uniform(-5, 5, n)
        if trial % 10 == 0:  # points inside and on the axes of a rectangle
            px[0], py[0] = pose[0], pose[1]
        got = rects_distance(px, py, pose, rects[: 1 + trial % 3])
        want = _vectorised(px, py, pose, rects[: 1 + trial % 3])
        for g, w in zip(got, want, strict=True):
            assert g.shape == w.shape
            assert g.tobytes() == w.tobytes()
    d, ux, uy = rects_distance(np.array([2.0]), np.array([0.0]), (0.0, 0.0, 0.0), [Rect(0.0, 0.0, 1.0, 0.6)])
    assert (float(d[0]), float(ux[0]), float(uy[0])) == (1.5, 1.0, 0.0)
