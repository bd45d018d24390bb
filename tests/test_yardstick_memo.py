"""The yardstick's searches kept on a configuration space (B5, simulation/grid_yardstick.py): the same
cells and lengths as a search from scratch, shared by the spaces of one free map."""

from __future__ import annotations

import numpy as np

from kbplanner.simulation import grid_yardstick
from kbplanner.simulation.grid_yardstick import grid_shortest_path_length, shortest_cells
from kbplanner.world import cspace_cache
from kbplanner.world.cspace_cache import configuration_space
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

FP = Footprint((Rect(0, 0, 0.5, 0.3),), "base")


def _grid(origin: tuple[float, float] = (0.0, 0.0)) -> OccupancyGrid:
    occ = np.zeros((80, 100), dtype=bool)
    occ[:, 0] = occ[:, -1] = occ[0] = occ[-1] = True
    occ[10:70, 40] = True  # a wall with gaps at both ends
    occ[30:50, 70:75] = True
    return OccupancyGrid(occ, origin=origin, resolution=0.05)


def _scratch(cs: ConfigurationSpace, start: tuple[float, float],
             goal: tuple[float, float]) -> list[tuple[int, int]] | None:
    free = cs.free_any_yaw()
    (sx, sy), (gx, gy) = cs.grid.cell_of(*start), cs.grid.cell_of(*goal)
    return grid_yardstick._dijkstra_cells(free, (sy, sx), (gy, gx))


def test_kept_cells_and_lengths_are_those_of_a_search_from_scratch() -> None:
    cspace_cache.clear()
    g = _grid()
    cs = configuration_space(g, FP)
    ends = [((1.0, 1.0), (3.0, 1.2)), ((1.0, 3.5), (4.5, 1.0)), ((1.0, 1.0), (3.0, 1.2))]
    for start, goal in ends:
        cells = shortest_cells(cs, start, goal)
        assert cells is not None and cells == _scratch(cs, start, goal)
        assert shortest_cells(cs, start, goal) == cells  # asked again: from the memo
    assert ("cells", *(tuple(reversed(g.cell_of(*p))) for p in ends[0])) in cs.path_memo
    # a space of the same free map (another grid object, origin) shares the memo; lengths match a
    # fresh space's, and a grid given with its footprint gives the same length
    other = configuration_space(_grid(), FP)
    assert other.path_memo is cs.path_memo
    fresh = ConfigurationSpace.build(g, FP)
    for start, goal in ends:
        got = grid_shortest_path_length(other, start, goal)
        assert got == grid_yardstick._shortest_length(fresh, start, goal)
        assert got == grid_shortest_path_length(g, start, goal, FP)
    assert cs.nbytes() > int(cs.free.nbytes) + sum(int(a.nbytes + b.nbytes) for a, b in cs.memo.values())


def test_the_yardstick_is_never_shorter_than_the_straight_line() -> None:
    """The navigation skill keeps a leg within 1.25 x the straight distance without searching its
    yardstick (skills/navigation.py ``_shorter``): exact only while the yardstick, a line from start to
    goal, is never shorter than the straight distance."""
    cspace_cache.clear()
    cs = configuration_space(_grid(), FP)
    rng = np.random.default_rng(3)
    found = 0
    for _ in range(60):
        start = (float(rng.uniform(0.4, 4.6)), float(rng.uniform(0.4, 3.6)))
        goal = (float(rng.uniform(0.4, 4.6)), float(rng.uniform(0.4, 3.6)))
        length = grid_shortest_path_length(cs, start, goal)
        if np.isfinite(length):
            found += 1
            assert length >= np.hypot(goal[0] - start[0], goal[1] - start[1]) * (1.0 - 1e-9)
    assert found > 20
