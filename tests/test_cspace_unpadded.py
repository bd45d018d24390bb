"""Configuration space build (world layer, B4/B5): ``cspace_fft.free_maps`` - the unpadded grid's
transform, the kernels' extents blocking the cells whose footprint leaves the grid, several bins
transformed at once - gives, cell for cell, the free maps of the build before session 11 (the grid padded
with occupied cells, one bin at a time) and of a binary dilation, on random maps (sparse, dense, empty,
full, smaller than a kernel), footprints, margins and yaw bins."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import fft as sp_fft
from scipy import ndimage

from kbplanner.world import cspace_fft
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid


def _padded_build(occ: np.ndarray, fp: Footprint, res: float, n_bins: int, margin_m: float) -> np.ndarray:
    """The free maps as ``ConfigurationSpace.build`` computed them before session 11."""
    width = 2 * math.pi / n_bins
    kernels = [fp.kernel(res, k * width - width / 2, k * width + width / 2, margin_m) for k in range(n_bins)]
    h = max(k.shape[0] for k in kernels) // 2
    padded = np.pad(occ, h, constant_values=True).astype(np.float32)
    shape = tuple(sp_fft.next_fast_len(n, real=True) for n in padded.shape)
    grid_f = sp_fft.rfft2(padded, shape)
    ny, nx = occ.shape
    size = 2 * h + 1
    free = np.empty((n_bins, ny, nx), dtype=bool)
    for k, kern in enumerate(kernels):
        hk = kern.shape[0] // 2
        full = np.zeros((size, size), dtype=np.float32)
        full[h - hk : h + hk + 1, h - hk : h + hk + 1] = kern
        kern_f = sp_fft.fft(sp_fft.rfft(full[::-1, ::-1], n=shape[1], axis=1), n=shape[0], axis=0)
        rows = sp_fft.ifft(grid_f * kern_f, axis=0)[size - 1 : size - 1 + ny]
        hits = sp_fft.irfft(rows, n=shape[1], axis=1)[:, size - 1 : size - 1 + nx]
        free[k] = hits < 0.5
    return free


def _dilated(occ: np.ndarray, fp: Footprint, res: float, k: int, n_bins: int, margin_m: float) -> np.ndarray:
    width = 2 * math.pi / n_bins
    kern = fp.kernel(res, k * width - width / 2, k * width + width / 2, margin_m)
    hk = kern.shape[0] // 2
    padded = np.pad(occ, hk, constant_values=True)
    return ~ndimage.binary_dilation(padded, structure=kern[::-1, ::-1])[hk:-hk, hk:-hk]


def _occupancy(rng: np.random.Generator, ny: int, nx: int, density: float) -> np.ndarray:
    occ = rng.random((ny, nx)) < density
    for _ in range(int(rng.integers(0, 8))):
        x, y = rng.integers(0, max(1, nx)), rng.integers(0, max(1, ny))
        occ[y : y + rng.integers(1, 30), x : x + rng.integers(1, 4)] = True  # walls
    return occ


FOOTPRINTS = [
    Footprint((Rect(0.0, 0.0, 0.99, 0.67),), name="base"),
    Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(0.45, 0.0, 0.6, 2.4, yaw=math.pi / 2)), name="base+load"),
    Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(0.5, 0.1, 0.3, 1.6, yaw=0.3)), name="base+skew load"),
    Footprint((Rect(0.3, -0.2, 0.2, 0.1),), name="small off-centre"),
]


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("fp", FOOTPRINTS, ids=lambda f: f.name)
def test_free_maps_equal_the_padded_build_and_a_dilation(seed: int, fp: Footprint) -> None:
    rng = np.random.default_rng(seed)
    res = [0.05, 0.1, 0.05, 0.04, 0.1, 0.05][seed]
    ny, nx = int(rng.integers(3, 140)), int(rng.integers(3, 160))
    occ = _occupancy(rng, ny, nx, [0.001, 0.01, 0.05, 0.2, 0.0, 0.003][seed])
    margin, n_bins = [0.0, 0.05, 0.0, 0.12, 0.0, 0.0][seed], [72, 24, 36, 8, 72, 72][seed]
    free = cspace_fft.free_maps(occ, fp.rects, res, n_bins, margin)
    assert free.dtype == np.bool_ and free.shape == (n_bins, ny, nx)
    assert np.array_equal(free, _padded_build(occ, fp, res, n_bins, margin))
    for k in (0, n_bins // 3, n_bins - 1):
        assert np.array_equal(free[k], _dilated(occ, fp, res, k, n_bins, margin))


@pytest.mark.parametrize("shape", [(1, 1), (4, 90), (90, 3), (20, 20), (0, 7), (10, 10), (8, 40), (40, 8)])
@pytest.mark.parametrize("fill", [False, True])
def test_grids_smaller_than_a_kernel_empty_or_full(shape: tuple[int, int], fill: bool) -> None:
    occ = np.full(shape, fill, dtype=bool)
    for fp in FOOTPRINTS:
        for res in (0.05, 0.02):
            got = cspace_fft.free_maps(occ, fp.rects, res, 12, 0.0)
            assert np.array_equal(got, _padded_build(occ, fp, res, 12, 0.0))
    assert not cspace_fft.free_maps(occ, FOOTPRINTS[0].rects, 0.05, 12, 0.0).any()  # nothing fits


def test_a_small_kernel_off_the_robot_on_a_grid_shorter_than_the_kernel_square() -> None:
    """The transform (as long as the grid) is shorter than the kernel's square (2h + 1), yet the load
    fits: the kernel's rows past the transform's length are folded onto it (here ahead of a robot whose
    base is tiny)."""
    fp = Footprint((Rect(0.0, 0.0, 0.04, 0.04), Rect(0.6, 0.0, 0.1, 0.1)), name="tiny base, load ahead")
    occ = np.zeros((9, 30), dtype=bool)
    occ[4, 20] = True
    got = cspace_fft.free_maps(occ, fp.rects, 0.05, 72, 0.0)
    assert cspace_fft.kernel_set(fp.rects, 0.05, 72, 0.0).h >= 9  # the transform along y: 9 < 2h + 1
    assert np.array_equal(got, _padded_build(occ, fp, 0.05, 72, 0.0))
    assert got[0].any() and not got[0].all()


def test_a_space_with_room_is_free_somewhere_and_blocked_near_the_edge() -> None:
    occ = np.zeros((80, 90), dtype=bool)
    free = cspace_fft.free_maps(occ, FOOTPRINTS[1].rects, 0.05, 72, 0.0)
    assert free[:, 40, 45].all() and not free[:, 0, :].any() and not free[:, :, -1].any()


def test_bins_transformed_a_few_at_a_time_or_one_by_one_agree(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(7)
    grid = OccupancyGrid(_occupancy(rng, 120, 130, 0.01), origin=(1.0, -2.0), resolution=0.05)
    whole = ConfigurationSpace.build(grid, FOOTPRINTS[2]).free
    monkeypatch.setattr(cspace_fft, "BATCH_CELLS", 1)
    one = ConfigurationSpace.build(grid, FOOTPRINTS[2]).free
    assert np.array_equal(whole, one) and whole.any()


#: footprints as the case study's carry modes give them (the base and a frame held off the robot's axis)
CARRIED = [
    Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(-0.005, -0.1741, 0.608, 2.4)), name="frame across"),
    Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(-0.005, -0.1741, 2.4, 0.089)), name="frame along"),
]


@pytest.mark.parametrize("fp", FOOTPRINTS + CARRIED, ids=lambda f: f.name)
def test_kernels_turned_over_are_found_cell_for_cell(fp: Footprint) -> None:
    """``KernelSet.mirror``: a kernel read off another's transform is that kernel with its rows, columns
    or both reversed, and that one is transformed for itself."""
    kset = cspace_fft.kernel_set(fp.rects, 0.05, 72, 0.0)
    assert len(kset.mirror) == len(kset.flipped)
    turn = {cspace_fft.ROWS: (slice(None, None, -1), slice(None)),
            cspace_fft.COLUMNS: (slice(None), slice(None, None, -1)),
            cspace_fft.BOTH: (slice(None, None, -1), slice(None, None, -1))}
    for j, (i, how) in enumerate(kset.mirror):
        if i >= 0:
            assert i < j and kset.mirror[i] == (-1, 0)
            assert np.array_equal(kset.flipped[j], kset.flipped[i][turn[how]])
    hows = {how for _, how in kset.mirror}
    if fp.name in ("base", "base+load"):  # mirrored across the robot's x axis
        assert cspace_fft.ROWS in hows
    if fp.name in ("frame across", "frame along"):  # half a turn
        assert cspace_fft.BOTH in hows


@pytest.mark.parametrize("seed", range(8))
def test_grids_about_as_large_as_a_kernel(seed: int) -> None:
    """Transforms as long as the grid, shorter or a little longer than the kernel's square (folded,
    wrapped around): the cells whose kernel stays on the grid are counted exactly, the others blocked."""
    rng = np.random.default_rng(100 + seed)
    fp = (FOOTPRINTS + CARRIED)[seed % 6]
    res = 0.05
    h = cspace_fft.kernel_set(fp.rects, res, 24, 0.0).h
    ny, nx = (int(v) for v in rng.integers(max(1, h - 6), 2 * h + 12, size=2))
    occ = _occupancy(rng, ny, nx, [0.0, 0.002, 0.01, 0.03][seed % 4])
    free = cspace_fft.free_maps(occ, fp.rects, res, 24, 0.0)
    assert np.array_equal(free, _padded_build(occ, fp, res, 24, 0.0)), (ny, nx)


@pytest.mark.parametrize("fp", CARRIED, ids=lambda f: f.name)
def test_carried_frames_on_walled_rooms(fp: Footprint) -> None:
    """A room with walls and a door, larger than the kernels: the padded build's free maps, some free."""
    occ = np.zeros((150, 210), dtype=bool)
    occ[[0, -1], :] = occ[:, [0, -1]] = True
    occ[:, 100] = True
    occ[60:85, 100] = False  # a door
    occ[30:40, 150:160] = True
    free = cspace_fft.free_maps(occ, fp.rects, 0.05, 72, 0.0)
    assert np.array_equal(free, _padded_build(occ, fp, 0.05, 72, 0.0))
    assert free.any() and not free.all()
