"""The per-process configuration-space cache (B4/B5): the same free maps and labels as a build."""

from __future__ import annotations

import numpy as np
import pytest

from kbplanner.world import cspace_cache
from kbplanner.world.cspace_cache import configuration_space
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

RES = 0.05


def _map(seed: int, shape: tuple[int, int] = (90, 120)) -> OccupancyGrid:
    rng = np.random.default_rng(seed)
    occ = np.zeros(shape, dtype=bool)
    for _ in range(12):  # walls and blocks
        y, x = rng.integers(0, shape[0]), rng.integers(0, shape[1])
        h, w = rng.integers(1, 25), rng.integers(1, 25)
        occ[y:y + h, x:x + w] = True
    occ |= rng.random(shape) < 0.01
    return OccupancyGrid(occ, origin=(1.3, -2.1), resolution=RES)


def _window(g: OccupancyGrid, iy: int, ix: int, ny: int, nx: int) -> OccupancyGrid:
    return OccupancyGrid(g.occupied[iy:iy + ny, ix:ix + nx].copy(),
                         origin=(g.origin[0] + ix * RES, g.origin[1] + iy * RES), resolution=RES)


FOOTPRINTS = [Footprint((Rect(0, 0, 0.5, 0.3),), "base"),
              Footprint((Rect(0, 0, 0.5, 0.3), Rect(0.4, 0.1, 0.2, 0.9, 0.3)), "carry")]


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("fp", FOOTPRINTS, ids=lambda f: f.name)
def test_windows_of_a_kept_grid_are_cropped_exactly(seed: int, fp: Footprint) -> None:
    cspace_cache.clear()
    g = _map(seed)
    whole = configuration_space(g, fp, 24)
    assert np.array_equal(whole.free, ConfigurationSpace.build(g, fp, 24).free)
    rng = np.random.default_rng(seed + 10)
    for _ in range(6):
        ny, nx = int(rng.integers(10, 80)), int(rng.integers(10, 110))
        iy, ix = int(rng.integers(0, 90 - ny + 1)), int(rng.integers(0, 120 - nx + 1))
        sub = _window(g, iy, ix, ny, nx)
        got = configuration_space(sub, fp, 24)
        assert got.grid is sub and got.footprint is fp
        assert np.array_equal(got.free, ConfigurationSpace.build(sub, fp, 24).free), (iy, ix, ny, nx)
    assert cspace_cache.stats()["cropped"] >= 1
    assert cspace_cache.stats()["built"] == 1 + 6 - cspace_cache.stats()["cropped"]


def test_a_window_with_another_cell_is_patched() -> None:
    cspace_cache.clear()
    g = _map(3)
    configuration_space(g, FOOTPRINTS[0], 24)
    sub = _window(g, 10, 10, 50, 60)
    occ = sub.occupied.copy()
    occ[25, 30] = not occ[25, 30]
    changed = OccupancyGrid(occ, origin=sub.origin, resolution=RES)
    got = configuration_space(changed, FOOTPRINTS[0], 24)
    assert np.array_equal(got.free, ConfigurationSpace.build(changed, FOOTPRINTS[0], 24).free)
    assert cspace_cache.stats()["built"] == 1 and cspace_cache.stats()["patched"] == 1


def test_same_grid_shares_free_maps_and_labels() -> None:
    cspace_cache.clear()
    g = _map(4)
    a = configuration_space(g, FOOTPRINTS[1], 24)
    labels, roots = a.labels_and_roots(True)
    again = OccupancyGrid(g.occupied.copy(), origin=g.origin, resolution=RES)
    b = configuration_space(again, FOOTPRINTS[1], 24)
    assert b.grid is again and b.free is a.free
    assert b.labels_and_roots(True)[0] is labels
    assert not b.free.flags.writeable and not labels.flags.writeable
    fresh = ConfigurationSpace.build(g, FOOTPRINTS[1], 24)
    assert np.array_equal(fresh.components(diagonal=True), roots[labels])
    assert cspace_cache.stats()["hits"] == 1
    # another margin or yaw binning is another space
    configuration_space(g, FOOTPRINTS[1], 24, 0.05)
    configuration_space(g, FOOTPRINTS[1], 36)
    assert cspace_cache.stats()["built"] == 3


def test_memory_is_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    cspace_cache.clear()
    one = 24 * 90 * 120  # bytes of one free map set
    monkeypatch.setattr(cspace_cache, "BUDGET_BYTES", 3 * one)
    for seed in range(6):
        cs = configuration_space(_map(seed), FOOTPRINTS[0], 24)
        cs.labels_and_roots(False)
    st = cspace_cache.stats()
    assert st["evicted"] >= 2 and st["kept"] <= 3
    assert st["bytes"] <= 3 * one + cs.nbytes()


@pytest.mark.parametrize("fp", FOOTPRINTS, ids=lambda f: f.name)
def test_a_few_other_cells_are_built_again_exactly(fp: Footprint) -> None:
    cspace_cache.clear()
    g = _map(5, (160, 200))
    configuration_space(g, fp, 24)
    rng = np.random.default_rng(7)
    for n_changed in (1, 3, 8):
        sub = _window(g, 10, 12, 140, 180)
        occ = sub.occupied.copy()
        y, x = int(rng.integers(20, 120)), int(rng.integers(20, 160))
        for _ in range(n_changed):  # a few cells near one another, as an element drawn a little differently
            dy, dx = rng.integers(-3, 4, size=2)
            occ[y + dy, x + dx] = not occ[y + dy, x + dx]
        changed = OccupancyGrid(occ, origin=sub.origin, resolution=RES)
        got = configuration_space(changed, fp, 24)
        assert np.array_equal(got.free, ConfigurationSpace.build(changed, fp, 24).free), n_changed
    assert cspace_cache.stats()["patched"] == 3


@pytest.mark.parametrize("diagonal", [True, False])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_joined_is_the_labels_answer(seed: int, diagonal: bool) -> None:
    """ConfigurationSpace.joined (a box around each pose, then the whole labelling) against comparing
    the components of the whole labelling, on poses all over random maps."""
    g = _map(seed, (100, 140))
    fp = FOOTPRINTS[seed % 2]
    fresh = ConfigurationSpace.build(g, fp, 24)
    labelled = ConfigurationSpace.build(g, fp, 24)
    rng = np.random.default_rng(seed)
    free_cells = np.argwhere(fresh.free)
    picks = free_cells[rng.integers(0, len(free_cells), 40)]
    poses = [(g.origin[0] + (ix + 0.5) * RES, g.origin[1] + (iy + 0.5) * RES, k * fresh.bin_width)
             for k, iy, ix in picks]
    poses += [(g.origin[0] - 1.0, 0.0, 0.0), (g.origin[0] + 0.02, g.origin[1] + 0.02, 0.0)]  # off, blocked
    shortcut = 0
    for i in range(0, len(poses) - 1):
        a, b = poses[i], poses[i + 1]
        want = labelled.components_of([a, b], diagonal=diagonal)
        cs = ConfigurationSpace(grid=g, footprint=fp, free=fresh.free)
        got = cs.joined(a, b, diagonal=diagonal)
        assert got == (want[0] > 0 and want[0] == want[1]), (a, b)
        shortcut += got and diagonal not in cs.memo  # answered without labelling the whole space
    if fp is FOOTPRINTS[0]:  # the small footprint turns in place on much of the map
        assert shortcut > 0


def test_a_grid_changed_in_place_after_a_build_is_not_taken_for_the_old_one() -> None:
    """A window is a view of the caller's array; the caller may change the array afterwards."""
    cspace_cache.clear()
    occ = _map(6).occupied.copy()
    fp = FOOTPRINTS[0]
    first = OccupancyGrid(occ[5:80, 5:110], origin=(0.25, 0.25), resolution=RES)  # a view
    configuration_space(first, fp, 24)
    occ[30:40, 30:60] = ~occ[30:40, 30:60]
    again = OccupancyGrid(occ[5:80, 5:110], origin=(0.25, 0.25), resolution=RES)
    got = configuration_space(again, fp, 24)
    assert np.array_equal(got.free, ConfigurationSpace.build(again, fp, 24).free)
