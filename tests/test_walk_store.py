"""The workers' walking routes kept on disk (B5, simulation/walk_store.py): read back, the very polylines a
search gives, with no search; a new leg is searched and kept; a damaged file is ignored; nothing is kept
without a folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kbplanner.simulation import walk_store
from kbplanner.simulation.separation import WORKER_RADIUS_M
from kbplanner.simulation.workers import _Router
from kbplanner.world import cspace_store
from kbplanner.world.occupancy import OccupancyGrid

LEGS = [((0.5, 0.5), (8.0, 5.5)), ((8.0, 5.5), (1.0, 6.0)), ((1.0, 6.0), (0.5, 0.5))]


def _map() -> OccupancyGrid:
    occ = np.zeros((140, 180), dtype=bool)
    occ[20:120, 60:70] = True  # a wall to walk round
    occ[0:90, 120:125] = True
    return OccupancyGrid(occ, origin=(-0.3, 0.2), resolution=0.05)


def _walk(router: _Router, legs: list[tuple[tuple[float, float], tuple[float, float]]]) -> list[np.ndarray]:
    return [router.path(a, b) for a, b in legs]


def test_a_second_run_reads_the_same_legs_without_searching(tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    grid = _map()
    searched = _walk(_Router(grid, WORKER_RADIUS_M), LEGS)  # no folder: nothing kept
    assert not tmp_path.joinpath(walk_store.SUBDIR).exists()
    folder = tmp_path / "cspace"
    with cspace_store.kept_in(folder):
        first = _Router(grid, WORKER_RADIUS_M)
        assert walk_store.read_into(first) == 0
        got = _walk(first, LEGS)
        walk_store.write_from(first)
    assert len(list((tmp_path / walk_store.SUBDIR).glob("*.npz"))) == 1
    again = _Router(grid, WORKER_RADIUS_M)

    def no_search(*_a: object) -> list[tuple[int, int]]:
        raise AssertionError("a kept leg was searched again")

    monkeypatch.setattr(again, "_dijkstra", no_search)
    with cspace_store.kept_in(folder):
        assert walk_store.read_into(again) == len(LEGS)
        read = _walk(again, LEGS)
    for a, b, c in zip(searched, got, read, strict=True):
        assert a.dtype == c.dtype and a.shape == c.shape and len(a) > 2
        assert a.tobytes() == b.tobytes() == c.tobytes()
    monkeypatch.undo()
    # a new leg: searched, and the file then holds all four
    with cspace_store.kept_in(folder):
        new = ((1.0, 6.0), (8.5, 0.6))
        assert again.path(*new).tobytes() == _Router(grid, WORKER_RADIUS_M).path(*new).tobytes()
        walk_store.write_from(again)
        third = _Router(grid, WORKER_RADIUS_M)
        assert walk_store.read_into(third) == len(LEGS) + 1


def test_another_map_or_a_damaged_file_is_not_read(tmp_path: Path) -> None:
    grid = _map()
    folder = tmp_path / "cspace"
    with cspace_store.kept_in(folder):
        r = _Router(grid, WORKER_RADIUS_M)
        _walk(r, LEGS[:1])
        walk_store.write_from(r)
        moved = OccupancyGrid(grid.occupied, origin=(0.0, 0.0), resolution=0.05)
        assert walk_store.key(_Router(moved, WORKER_RADIUS_M)) != walk_store.key(r)
        assert walk_store.read_into(_Router(moved, WORKER_RADIUS_M)) == 0
        (kept,) = (tmp_path / walk_store.SUBDIR).glob("*.npz")
        kept.write_bytes(b"not a zip file")
        fresh = _Router(grid, WORKER_RADIUS_M)
        assert walk_store.read_into(fresh) == 0 and not fresh._memo
        assert walk_store.key(_Router(None, WORKER_RADIUS_M)) is None


def test_the_walking_map_is_kept_and_read_back_the_same(tmp_path: Path) -> None:
    from kbplanner.simulation import workers

    grid = _map()
    made, k = workers.walk_cells(grid, WORKER_RADIUS_M)
    assert k == 1 and made.dtype == np.bool_ and 0 < made.sum() < made.size
    assert walk_store.walk_cells_kept(grid, WORKER_RADIUS_M)[0].tobytes() == made.tobytes()  # no folder
    assert not list(tmp_path.iterdir())
    folder = tmp_path / "cspace"
    with cspace_store.kept_in(folder):
        first = walk_store.walk_cells_kept(grid, WORKER_RADIUS_M)
        (kept,) = (tmp_path / walk_store.SUBDIR / walk_store.MAPS).glob("*.npz")
        read = walk_store.walk_cells_kept(grid, WORKER_RADIUS_M)
        fresh = OccupancyGrid(grid.occupied.copy(), origin=grid.origin, resolution=grid.resolution)
        router = _Router(fresh, WORKER_RADIUS_M, walk_store.walk_cells_kept(fresh, WORKER_RADIUS_M))
        assert "edt" not in fresh._cache  # the map read, no distance transform made
        assert walk_store.walk_cells_kept(grid, 0.5)[0].sum() < made.sum()  # another clearance: another map
        for got in (first, read, (router.free, 1)):
            assert got[1] == 1 and got[0].dtype == np.bool_ and got[0].tobytes() == made.tobytes()
        assert walk_store.key(router) == walk_store.key(_Router(grid, WORKER_RADIUS_M))
        kept.write_bytes(b"damaged")
        again = walk_store.walk_cells_kept(grid, WORKER_RADIUS_M)
        assert again[0].tobytes() == made.tobytes()
        assert walk_store.walk_cells_kept(grid, WORKER_RADIUS_M)[0].tobytes() == made.tobytes()


def test_a_big_site_walking_map_is_coarser_and_kept_so(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    from kbplanner.simulation import workers

    monkeypatch.setattr(workers, "MAX_ROUTING_CELLS", 5000)
    grid = _map()
    made, k = workers.walk_cells(grid, WORKER_RADIUS_M)
    assert k == 3 and made.shape == (140 // 3, 180 // 3)
    with cspace_store.kept_in(tmp_path / "cspace"):
        walk_store.walk_cells_kept(grid, WORKER_RADIUS_M)
        read, k_read = walk_store.walk_cells_kept(grid, WORKER_RADIUS_M)
        router = _Router(grid, WORKER_RADIUS_M, (read, k_read))
    assert k_read == 3 and read.tobytes() == made.tobytes()
    assert router.grid is not None and router.grid.resolution == grid.resolution * 3
    assert router.free is not None and router.free.tobytes() == made.tobytes()
