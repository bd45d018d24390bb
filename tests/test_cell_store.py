"""The grid shortest cell paths kept on disk (B5, simulation/cell_store.py): read back, the very cells a
search gives, with no search; the yardstick's lengths the very numbers, not worked out again; the carry
legs' corridor routes the very poses; a damaged file is ignored; nothing is kept without a folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kbplanner.simulation import cell_store, grid_yardstick
from kbplanner.world import cspace_store
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

FP = Footprint((Rect(0, 0, 0.5, 0.3),), "base")
ENDS = [((0.6, 0.6), (4.2, 2.6)), ((4.2, 2.6), (0.4, 3.1)), ((0.6, 0.6), (2.5, 1.0))]


def _space() -> ConfigurationSpace:
    occ = np.zeros((70, 90), dtype=bool)
    occ[10:60, 30:34] = True  # a wall to go round
    occ[30:34, 50:90] = True
    occ[0:20, 60:62] = True
    return ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05), FP, 36)


def _search(cs: ConfigurationSpace) -> list[tuple[list[tuple[int, int]] | None, float]]:
    return [(grid_yardstick.shortest_cells(cs, a, b), grid_yardstick._shortest_length(cs, a, b))
            for a, b in ENDS]


def test_a_second_run_reads_the_same_cells_without_searching(tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    searched = _search(_space())  # no folder: nothing kept
    assert all(c is not None and len(c) > 10 for c, _ in searched)
    folder = tmp_path / "cspace"
    with cspace_store.kept_in(folder):
        first = _search(_space())
        cell_store.flush()
    assert len(list((tmp_path / cell_store.SUBDIR).glob("*.npz"))) == 1
    cell_store._known.clear()  # a new process

    def no_search(*_a: object) -> None:
        raise AssertionError("a kept path was searched again")

    monkeypatch.setattr(grid_yardstick, "_dijkstra_cells", no_search)
    monkeypatch.setattr(grid_yardstick, "_farthest_visible", no_search)  # the lengths read too
    with cspace_store.kept_in(folder):
        again = _search(_space())
    assert cell_store.counts["read"] >= 1
    assert first == searched and again == searched  # the same cells (ints) and the same lengths
    monkeypatch.undo()
    with cspace_store.kept_in(folder):  # another pair of ends: searched, then kept with the others
        cs = _space()
        assert grid_yardstick.shortest_cells(cs, (0.4, 3.1), (4.0, 0.3)) is not None
        cell_store.flush()
    cell_store._known.clear()
    with cspace_store.kept_in(folder):
        paths = cell_store._paths(_space().free_any_yaw(), None)
    assert paths is not None and len(paths[0]) == len(ENDS) + 1


def test_no_path_and_a_damaged_file(tmp_path: Path) -> None:
    occ = np.zeros((40, 40), dtype=bool)
    occ[:, 18:22] = True  # two halves: no path between them
    cs = ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05), FP, 36)
    folder = tmp_path / "cspace"
    with cspace_store.kept_in(folder):
        assert grid_yardstick.shortest_cells(cs, (0.2, 1.0), (1.6, 1.0)) is None
        cell_store.flush()
    cell_store._known.clear()
    free = cs.free_any_yaw()
    s, t = (20, 4), (20, 32)
    with cspace_store.kept_in(folder):
        assert cell_store.lookup(free, s, t) == (True, None)  # kept: no path
        (kept,) = (tmp_path / cell_store.SUBDIR).glob("*.npz")
        kept.write_bytes(b"not a zip file")
        cell_store._known.clear()
        assert cell_store.lookup(free, s, t) == (False, None)
    assert not cell_store.active() and cell_store.lookup(free, s, t) == (False, None)


def test_corridor_routes_read_back_without_searching(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from kbplanner.simulation import corridor_cells as cc

    queries = [((0.6, 0.6, 0.0), (4.2, 2.6, 1.5)), ((4.2, 2.6, 0.3), (0.4, 3.1, -2.0)),
               ((0.6, 0.6, 0.0), (4.2, 2.6, 1.5), 0.2)]

    def routes() -> list[object]:
        cs = _space()
        return [cc.corridor_cells(cs, q[0], q[1], *q[2:]) for q in queries]  # type: ignore[arg-type]

    searched = routes()  # no folder
    assert searched[0] is not None and len(searched[0]) > 10
    folder = tmp_path / "cspace"
    with cspace_store.kept_in(folder):
        first = routes()
        cell_store.flush()
    assert len(list((tmp_path / cell_store.SUBDIR).glob("corridor-*.npz"))) == 1
    cell_store._corridors.clear()  # a new process

    def no_search(*_a: object) -> None:
        raise AssertionError("a kept route was searched again")

    monkeypatch.setattr(cc, "bfs_cells", no_search)
    with cspace_store.kept_in(folder):
        again = routes()
    assert first == searched and again == searched  # the same poses, float for float
