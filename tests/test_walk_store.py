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
