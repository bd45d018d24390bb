"""B5 configuration space build (world layer): the free maps computed with the row-restricted transforms
(``cspace_fft.hits_many``) are the former full ``rfft2``/``irfft2`` correlation's, cell for cell, and the
exact "no occupied cell under the kernel" (a brute-force dilation) on random maps, footprints and margins."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import fft as sp_fft
from scipy import ndimage

from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid


def _former_free(grid: OccupancyGrid, fp: Footprint, n_bins: int, margin_m: float) -> np.ndarray:
    """The build's free maps as the code before the row-restricted transforms computed them."""
    width = 2 * math.pi / n_bins
    kernels = [fp.kernel(grid.resolution, k * width - width / 2, k * width + width / 2, margin_m)
               for k in range(n_bins)]
    h = max(k.shape[0] for k in kernels) // 2
    padded = np.pad(grid.occupied, h, constant_values=True).astype(np.float32)
    size = 2 * h + 1
    shape = tuple(sp_fft.next_fast_len(n, real=True) for n in padded.shape)
    grid_f = sp_fft.rfft2(padded, shape)
    ny, nx = grid.shape
    free = np.empty((n_bins, ny, nx), dtype=bool)
    for k, kern in enumerate(kernels):
        hk = kern.shape[0] // 2
        full = np.zeros((size, size), dtype=np.float32)
        full[h - hk : h + hk + 1, h - hk : h + hk + 1] = kern
        conv = sp_fft.irfft2(grid_f * sp_fft.rfft2(full[::-1, ::-1], shape), shape)
        free[k] = conv[size - 1 : size - 1 + ny, size - 1 : size - 1 + nx] < 0.5
    return free


def _exact_free(grid: OccupancyGrid, fp: Footprint, k: int, n_bins: int, margin_m: float) -> np.ndarray:
    """Free cells of bin ``k`` by a binary dilation of the occupied cells (off the grid occupied)."""
    width = 2 * math.pi / n_bins
    kern = fp.kernel(grid.resolution, k * width - width / 2, k * width + width / 2, margin_m)
    hk = kern.shape[0] // 2
    padded = np.pad(grid.occupied, hk, constant_values=True)
    hit = ndimage.binary_dilation(padded, structure=kern[::-1, ::-1])[hk:-hk, hk:-hk]
    return ~hit


def _grid(seed: int, ny: int, nx: int, res: float) -> OccupancyGrid:
    rng = np.random.default_rng(seed)
    occ = rng.random((ny, nx)) < 0.002
    for _ in range(6):
        x, y = rng.integers(0, nx), rng.integers(0, ny)
        occ[y : y + rng.integers(1, 15), x : x + rng.integers(1, 15)] = True
    return OccupancyGrid(occ, origin=(-2.0, 1.5), resolution=res)


FOOTPRINTS = [
    Footprint((Rect(0.0, 0.0, 0.99, 0.67),), name="base"),
    Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(0.5, 0.1, 0.3, 1.6, yaw=0.3)), name="base+load"),
    Footprint((Rect(0.2, -0.1, 0.4, 0.3),), name="small off-centre"),
]


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("fp", FOOTPRINTS, ids=lambda f: f.name)
def test_free_maps_are_the_former_correlations_and_exact(seed: int, fp: Footprint) -> None:
    rng = np.random.default_rng(100 + seed)
    grid = _grid(seed, int(rng.integers(40, 130)), int(rng.integers(40, 170)), 0.1)
    margin = [0.0, 0.05, 0.12][seed - 1]
    n_bins = 24
    cs = ConfigurationSpace.build(grid, fp, n_bins, margin)
    assert cs.free.any() and not cs.free.all()
    assert np.array_equal(cs.free, _former_free(grid, fp, n_bins, margin))
    for k in (0, 5, 13):
        assert np.array_equal(cs.free[k], _exact_free(grid, fp, k, n_bins, margin))
