"""world/cspace_labels.py: the labels of runs are ndimage.label's, cell for cell (B4 carry-leg parts)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from kbplanner.world.cspace_labels import label_runs
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid


def _structure(diagonal: bool) -> np.ndarray:
    return np.ones((3, 3, 3), dtype=bool) if diagonal else ndimage.generate_binary_structure(3, 1)


@pytest.mark.parametrize("diagonal", [True, False])
def test_random_arrays_match_ndimage(diagonal: bool) -> None:
    rng = np.random.default_rng(14)
    for _ in range(200):
        shape = tuple(int(v) for v in rng.integers(1, 14, 3))
        free = rng.random(shape) < rng.random()
        want, n_want = ndimage.label(free, structure=_structure(diagonal))
        got, n_got = label_runs(free, diagonal)
        assert n_got == n_want
        assert got.dtype == np.int32 and got.shape == free.shape
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("diagonal", [True, False])
def test_empty_and_full(diagonal: bool) -> None:
    for free in (np.zeros((3, 4, 5), dtype=bool), np.ones((3, 4, 5), dtype=bool),
                 np.zeros((0, 4, 5), dtype=bool), np.ones((2, 3, 0), dtype=bool)):
        want, n_want = ndimage.label(free, structure=_structure(diagonal))
        got, n_got = label_runs(free, diagonal)
        assert n_got == n_want
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("diagonal", [True, False])
def test_configuration_space_labels_match_ndimage(diagonal: bool) -> None:
    """A real space (walls, a door, a pillar; 72 yaw bins): labels and the wrap roots as before."""
    occ = np.zeros((70, 110), dtype=bool)
    occ[:, 55] = True
    occ[30:42, 55] = False
    occ[10:14, 20:24] = True
    occ[50:53, 80:100] = True
    grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
    cs = ConfigurationSpace.build(grid, Footprint((Rect(0, 0, 0.6, 0.3), Rect(0.1, 0, 0.2, 1.2))))
    want, n_want = ndimage.label(cs.free, structure=_structure(diagonal))
    labels, roots = cs.labels_and_roots(diagonal)
    np.testing.assert_array_equal(labels, want)
    assert len(roots) == n_want + 1
    assert roots[0] == 0 and n_want > 1
