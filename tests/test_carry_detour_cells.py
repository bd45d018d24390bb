"""B5 navigation (pathq11): a leg still round the long way after the seed retries is timed against the
cell routes on its own configuration space (``carry_paths.cell_alternatives``)."""

from __future__ import annotations

import pytest

from kbplanner.simulation.carry_paths import DETOUR_CORRIDORS_M, cell_alternatives
from kbplanner.simulation.grid_yardstick import grid_shortest_path_length
from kbplanner.simulation.motion_check import path_is_free
from kbplanner.simulation.nav_path import NavSettings
from kbplanner.world.footprint import ConfigurationSpace
from test_carry_route import rooms
from test_navigation import GOAL, START, WIDE


def test_the_cell_routes_are_free_distinct_seedless_and_near_the_yardstick() -> None:
    grid = rooms(1.8, 0.2)  # a wide door: the load turns in it
    cs = ConfigurationSpace.build(grid, WIDE)
    routes = cell_alternatives(cs, START, GOAL, NavSettings(seed=3))
    assert 1 <= len(routes) <= len(DETOUR_CORRIDORS_M) + 1
    assert len({r.poses for r in routes}) == len(routes)  # no route twice
    best = grid_shortest_path_length(cs, START, GOAL)
    for r in routes:
        assert r.ok and r.planner.endswith("+cells")
        assert path_is_free(cs, r.poses)
        assert r.poses[0][:2] == pytest.approx(START[:2]) and r.poses[-1] == pytest.approx(GOAL)
        assert best - 1e-9 <= r.length_m < 1.3 * best
    # no random numbers: another seed gives the same routes
    again = cell_alternatives(cs, START, GOAL, NavSettings(seed=99))
    assert [r.poses for r in again] == [r.poses for r in routes]


def test_no_cell_routes_from_a_blocked_end_or_where_cells_do_not_join() -> None:
    cs = ConfigurationSpace.build(rooms(1.8, 0.2), WIDE)
    assert cell_alternatives(cs, START, (4.1, 0.1, 0.0), NavSettings()) == []  # the goal in the wall
    shut = ConfigurationSpace.build(rooms(0.6, 0.6), WIDE)  # the wide load passes at no heading
    assert cell_alternatives(shut, START, GOAL, NavSettings()) == []
