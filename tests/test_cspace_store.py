"""Configuration spaces kept on disk (B4/B5, world/cspace_store.py): read back, the very free maps a build
gives; a damaged or foreign file is ignored; nothing is kept without a folder or with the cache off."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kbplanner.world import cspace_cache, cspace_store
from kbplanner.world.cspace_cache import configuration_space
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

RES = 0.05
BASE = Footprint((Rect(0, 0, 0.5, 0.3),), "base")
CARRY = Footprint((Rect(0, 0, 0.5, 0.3), Rect(0.4, 0.1, 0.2, 0.9, 0.3)), "carry")


def _map(seed: int, shape: tuple[int, int] = (70, 90),
         origin: tuple[float, float] = (1.3, -2.1)) -> OccupancyGrid:
    rng = np.random.default_rng(seed)
    occ = np.zeros(shape, dtype=bool)
    for _ in range(10):
        y, x = rng.integers(0, shape[0]), rng.integers(0, shape[1])
        occ[y:y + rng.integers(1, 20), x:x + rng.integers(1, 20)] = True
    occ |= rng.random(shape) < 0.01
    return OccupancyGrid(occ, origin=origin, resolution=RES)


@pytest.mark.parametrize("fp", [BASE, CARRY], ids=lambda f: f.name)
@pytest.mark.parametrize("seed", [0, 1])
def test_a_second_command_reads_the_same_free_maps(tmp_path: Path, fp: Footprint, seed: int) -> None:
    g = _map(seed)
    built = ConfigurationSpace.build(g, fp, 72)
    cspace_cache.clear()
    with cspace_store.kept_in(tmp_path):
        first = configuration_space(g, fp, 72)
    assert cspace_cache.stats()["built"] == 1 and cspace_cache.stats()["read"] == 0
    assert len(list(tmp_path.glob("*.npy"))) == 1
    cspace_cache.clear()  # a new process: nothing kept in memory
    with cspace_store.kept_in(tmp_path):
        again = configuration_space(g, fp, 72)
    assert cspace_cache.stats()["read"] == 1 and cspace_cache.stats()["built"] == 0
    assert again.free.dtype == built.free.dtype and again.free.shape == built.free.shape
    assert np.array_equal(first.free, built.free) and np.array_equal(again.free, built.free)
    # labels computed on the read maps are the build's
    for diagonal in (False, True):
        assert np.array_equal(again.components(diagonal=diagonal), built.components(diagonal=diagonal))


def test_the_key_is_the_cells_not_the_origin(tmp_path: Path) -> None:
    a, b = _map(3), _map(3, origin=(7.0, 4.0))
    other = _map(4)
    fp = BASE
    assert cspace_store.key(a, fp, 72, 0.0) == cspace_store.key(b, fp, 72, 0.0)
    assert cspace_store.key(a, fp, 72, 0.0) != cspace_store.key(other, fp, 72, 0.0)
    assert cspace_store.key(a, fp, 72, 0.0) != cspace_store.key(a, CARRY, 72, 0.0)
    assert cspace_store.key(a, fp, 72, 0.0) != cspace_store.key(a, fp, 36, 0.0)
    assert cspace_store.key(a, fp, 72, 0.0) != cspace_store.key(a, fp, 72, 0.05)
    with cspace_store.kept_in(tmp_path):
        cspace_store.write(a, fp, 72, 0.0, ConfigurationSpace.build(a, fp).free)
        read = cspace_store.read(b, fp, 72, 0.0)
    assert read is not None and np.array_equal(read, ConfigurationSpace.build(b, fp).free)


def test_damaged_or_foreign_files_are_ignored(tmp_path: Path) -> None:
    g = _map(5)
    built = ConfigurationSpace.build(g, BASE).free
    with cspace_store.kept_in(tmp_path):
        path = tmp_path / f"{cspace_store.key(g, BASE, 72, 0.0)}.npy"
        for damaged in (b"not an array", b""):  # ValueError, EOFError from numpy
            path.write_bytes(damaged)
            assert cspace_store.read(g, BASE, 72, 0.0) is None
        np.save(path, np.zeros(10, dtype=np.uint8))  # another shape
        assert cspace_store.read(g, BASE, 72, 0.0) is None
        cspace_cache.clear()
        cs = configuration_space(g, BASE)  # built again and the file replaced
        assert np.array_equal(cs.free, built)
        read = cspace_store.read(g, BASE, 72, 0.0)
    assert read is not None and np.array_equal(read, built)


def test_nothing_kept_without_a_folder_or_with_the_cache_off(tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    g = _map(6)
    cspace_cache.clear()
    with cspace_store.kept_in(None):
        configuration_space(g, BASE)
    monkeypatch.setenv("KBPLANNER_NO_CACHE", "1")
    cspace_cache.clear()
    with cspace_store.kept_in(tmp_path):
        assert cspace_store.folder() is None
        configuration_space(g, BASE)
    assert not list(tmp_path.iterdir())
    assert cspace_store.folder() is None


def test_the_oldest_files_go_past_the_budget(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cspace_store, "BUDGET_BYTES", 1)  # only the newest file stays
    monkeypatch.setattr(cspace_store, "TRIM_EVERY", 1)
    with cspace_store.kept_in(tmp_path):
        for seed in (7, 8, 9):
            g = _map(seed)
            cspace_store.write(g, BASE, 72, 0.0, ConfigurationSpace.build(g, BASE).free)
        names = [p.name for p in tmp_path.glob("*.npy")]
    assert names == [f"{cspace_store.key(_map(9), BASE, 72, 0.0)}.npy"]


@pytest.mark.parametrize("res", [0.05, 0.1])
@pytest.mark.parametrize("margin", [0.0, 0.07])
@pytest.mark.parametrize("n_bins", [8, 72])
def test_kernel_reach_is_the_largest_kernel_without_rasterising(res: float, margin: float,
                                                                n_bins: int) -> None:
    import math

    from kbplanner.world.cspace_cache import kernel_reach

    for fp in (BASE, CARRY, Footprint((Rect(0.3, -0.2, 2.4, 0.1, 0.7), Rect(0, 0, 0.99, 0.67)))):
        w = 2 * math.pi / n_bins
        largest = max(fp.kernel(res, k * w - w / 2, k * w + w / 2, margin).shape[0] // 2
                      for k in range(n_bins))
        assert kernel_reach(fp, res, n_bins, margin) == largest
