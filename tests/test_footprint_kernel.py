"""B5 configuration space build (world layer): the footprint kernels rasterised for every (sub-angle,
rectangle) at once (``cspace_fft.rasterised_kernel``) are, cell for cell, the kernels of the former loop over
sub-angles and rectangles on a meshgrid, on random footprints, resolutions, yaw intervals and margins."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kbplanner.world import footprint as fpm
from kbplanner.world.footprint import Footprint, Rect


def _former_kernel(rects: tuple[Rect, ...], resolution: float, yaw_lo: float, yaw_hi: float,
                   margin_m: float) -> np.ndarray:
    """The kernel as the code before session 11 rasterised it (one sub-angle and rectangle at a time)."""
    grow = resolution + margin_m
    n_sub = max(2, math.ceil((yaw_hi - yaw_lo) / math.radians(0.5)) + 1)
    h = fpm.kernel_half_size(rects, resolution, margin_m)
    offs = np.arange(-h, h + 1) * resolution
    xx, yy = np.meshgrid(offs, offs)
    out = np.zeros(xx.shape, dtype=bool)
    eps = 1e-9
    for yaw in np.linspace(yaw_lo, yaw_hi, n_sub):
        c, s = math.cos(float(yaw)), math.sin(float(yaw))
        for r in rects:
            cx, cy = c * r.cx - s * r.cy, s * r.cx + c * r.cy
            a = float(yaw) + r.yaw
            ux, uy = math.cos(a), math.sin(a)
            hl, hw = r.length / 2, r.width / 2
            dx, dy = xx - cx, yy - cy
            inside = np.abs(dx * ux + dy * uy) <= hl + grow * (abs(ux) + abs(uy)) + eps
            inside &= np.abs(-dx * uy + dy * ux) <= hw + grow * (abs(uy) + abs(ux)) + eps
            inside &= np.abs(dx) <= hl * abs(ux) + hw * abs(uy) + grow + eps
            inside &= np.abs(dy) <= hl * abs(uy) + hw * abs(ux) + grow + eps
            out |= inside
    return out


def _random_rects(rng: np.random.Generator) -> tuple[Rect, ...]:
    rects = [Rect(0.0, 0.0, float(rng.uniform(0.3, 1.2)), float(rng.uniform(0.3, 0.9)))]
    for _ in range(int(rng.integers(0, 3))):
        rects.append(Rect(float(rng.uniform(-0.8, 0.8)), float(rng.uniform(-0.5, 0.5)),
                          float(rng.uniform(0.05, 1.8)), float(rng.uniform(0.02, 1.0)),
                          yaw=float(rng.uniform(-math.pi, math.pi))))
    return tuple(rects)


@pytest.mark.parametrize("seed", range(12))
def test_kernel_equals_former_rasterisation(seed: int) -> None:
    rng = np.random.default_rng(seed)
    rects = _random_rects(rng)
    res = float(rng.choice([0.05, 0.1, 0.025, 0.04]))
    margin = float(rng.choice([0.0, 0.05, 0.13]))
    n_bins = int(rng.choice([72, 36, 8]))
    width = 2 * math.pi / n_bins
    for k in range(n_bins):
        lo, hi = k * width - width / 2, k * width + width / 2
        new = Footprint(rects).kernel(res, lo, hi, margin)
        old = _former_kernel(rects, res, lo, hi, margin)
        assert new.dtype == old.dtype and new.shape == old.shape
        assert np.array_equal(new, old), (seed, k)


def test_kernel_of_a_robot_and_load_equals_former() -> None:
    """The case study's shapes: the base and a load carried ahead (on and between bin edges)."""
    rects = (Rect(0.0, 0.0, 0.99, 0.67), Rect(0.45, 0.0, 0.6, 2.4, yaw=math.pi / 2))
    for lo, hi in [(-math.pi / 72, math.pi / 72), (0.3, 0.31), (1.0, 1.0 + 2 * math.pi / 72), (-3.2, -3.1)]:
        assert np.array_equal(Footprint(rects).kernel(0.05, lo, hi, 0.0),
                              _former_kernel(rects, 0.05, lo, hi, 0.0))
        assert Footprint(rects).kernel(0.05, lo, hi, 0.0).any()
