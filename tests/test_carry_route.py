"""NV-2, cell route first (issue 14): a carry leg whose normal carry must pass a narrow passage takes the
cell route without RRTConnect's try; a leg without one is planned as before."""

from __future__ import annotations

import itertools
import math

import pytest

from kbplanner.simulation.carry_paths import cells_first, plan_with_carry_modes
from kbplanner.simulation.grid_yardstick import grid_shortest_path_length
from kbplanner.simulation.motion_check import path_is_free
from kbplanner.simulation.narrow_passage import heading_counts, narrow_passage
from kbplanner.simulation.nav_path import NavSettings
from kbplanner.world.footprint import ConfigurationSpace
from kbplanner.world.occupancy import Box, OccupancyGrid, occupancy_from_meshes
from test_navigation import GOAL, NARROW, START, WIDE, box


def rooms(door_width: float, wall_thickness: float) -> OccupancyGrid:
    """Two 4 x 4 m rooms joined by a door of the given width through a wall of the given thickness
    (centred on x = 4.1): a thick wall makes the door a passage rather than a slot."""
    lo, hi = 2.0 - door_width / 2, 2.0 + door_width / 2
    x0, x1 = 4.1 - wall_thickness / 2, 4.1 + wall_thickness / 2
    walls = [box(-0.2, -0.2, 8.4, 0.0), box(-0.2, 4.0, 8.4, 4.2), box(-0.2, 0.0, 0.0, 4.0),
             box(8.2, 0.0, 8.4, 4.0), box(x0, 0.0, x1, lo), box(x0, hi, x1, 4.0)]
    return occupancy_from_meshes(walls, (0.05, 1.5), Box(-0.5, -0.5, 8.7, 4.5), 0.05)


@pytest.fixture(scope="module")
def passage() -> OccupancyGrid:
    """The wide load (1.2 m across the 0.99 m robot) fits through the 1.2 m, 0.6 m deep door only within
    about 30 degrees of heading across it."""
    return rooms(1.2, 0.6)


@pytest.fixture(scope="module")
def wide_door() -> OccupancyGrid:
    return rooms(1.8, 0.2)


def test_the_narrow_passage_test_reads_the_headings_that_fit_on_the_way(passage: OccupancyGrid,
                                                                        wide_door: OccupancyGrid) -> None:
    cs = ConfigurationSpace.build(passage, WIDE)
    ix, iy = passage.cell_of(4.1, 2.0)
    assert 0 < heading_counts(cs)[iy, ix] * 360 / cs.n_bins < 45  # in the door: under 45 deg fit
    assert narrow_passage(cs, START, GOAL)
    assert not narrow_passage(cs, START, GOAL, max_deg=heading_counts(cs)[iy, ix] * 360 / cs.n_bins)
    # both ends in one room: no passage on the way
    assert not narrow_passage(cs, START, (2.5, 3.0, 0.0))
    # a wide door: the load turns freely in it
    assert not narrow_passage(ConfigurationSpace.build(wide_door, WIDE), START, GOAL)
    # the door closed to the wide load (the narrow carry's question then): not joined, not narrow
    assert not narrow_passage(ConfigurationSpace.build(rooms(1.0, 0.6), WIDE), START, GOAL)


def test_a_leg_through_a_narrow_passage_takes_the_cell_route_without_rrtconnect(
    passage: OccupancyGrid,
) -> None:
    settings = NavSettings(seed=3, carry_cells_first=True)
    plan = plan_with_carry_modes(passage, START, GOAL, WIDE, NARROW, settings)
    assert plan.ok and plan.mode == "normal" and not plan.events
    assert plan.path.planner == "RRTConnect+cells"
    assert "not tried: a narrow passage" in plan.reason
    assert plan.normal_attempt is plan.path and plan.space is plan.normal_space
    cs = ConfigurationSpace.build(passage, WIDE)
    assert path_is_free(cs, plan.path.poses)
    assert plan.path.poses[0][:2] == pytest.approx(START[:2]) and plan.path.poses[-1] == pytest.approx(GOAL)
    assert plan.path.length_m < 1.3 * grid_shortest_path_length(cs, START, GOAL)
    # no seed in it: another seed gives the same route
    again = plan_with_carry_modes(passage, START, GOAL, WIDE, NARROW,
                                  NavSettings(seed=99, carry_cells_first=True))
    assert again.path.poses == plan.path.poses
    # the setting off: RRTConnect is tried (and here finds a path itself)
    old = plan_with_carry_modes(passage, START, GOAL, WIDE, NARROW, NavSettings(seed=3))
    assert old.ok and old.path.planner == "RRTConnect" and "not tried" not in old.reason


def test_a_leg_without_a_narrow_passage_is_planned_as_before(wide_door: OccupancyGrid) -> None:
    on = plan_with_carry_modes(wide_door, START, GOAL, WIDE, NARROW,
                               NavSettings(seed=3, carry_cells_first=True))
    off = plan_with_carry_modes(wide_door, START, GOAL, WIDE, NARROW, NavSettings(seed=3))
    assert on.ok and on.path.planner == "RRTConnect"
    assert (on.mode, on.path.poses, on.path.reason) == (off.mode, off.path.poses, off.path.reason)


def test_where_the_wide_load_cannot_pass_the_narrow_carry_is_planned_as_before() -> None:
    grid = rooms(1.0, 0.6)  # the wide load fits through at no heading
    on = plan_with_carry_modes(grid, START, GOAL, WIDE, NARROW, NavSettings(seed=3, carry_cells_first=True))
    off = plan_with_carry_modes(grid, START, GOAL, WIDE, NARROW, NavSettings(seed=3))
    assert on.ok and on.mode == "narrow"
    assert [e.kind for e in on.events] == ["rotate_to_narrow", "rotate_back"]
    assert on.path.poses == off.path.poses
    assert cells_first(ConfigurationSpace.build(grid, WIDE), START, GOAL,
                       NavSettings(carry_cells_first=True)) is None


def test_cells_first_answers_only_when_asked(passage: OccupancyGrid) -> None:
    cs = ConfigurationSpace.build(passage, WIDE)
    assert cells_first(cs, START, GOAL, NavSettings()) is None
    routed = cells_first(cs, START, GOAL, NavSettings(carry_cells_first=True))
    assert routed is not None and routed.ok and math.isfinite(routed.length_m)
    blocked = (4.1, 0.2, 0.0)  # in the wall
    assert cells_first(cs, START, blocked, NavSettings(carry_cells_first=True)) is None


def test_the_corridor_search_returns_free_face_adjacent_cells_near_the_shortest_path(
    passage: OccupancyGrid,
) -> None:
    from kbplanner.simulation.corridor_cells import corridor_cells
    from kbplanner.simulation.grid_yardstick import shortest_cells

    cs = ConfigurationSpace.build(passage, WIDE)
    cells = corridor_cells(cs, START, GOAL, radius_m=0.5)
    assert cells is not None
    g = cs.grid
    idx = [(cs.yaw_bin(t), *reversed(g.cell_of(x, y))) for x, y, t in cells]
    assert idx[0] == (cs.yaw_bin(START[2]), *reversed(g.cell_of(*START[:2])))
    assert idx[-1] == (cs.yaw_bin(GOAL[2]), *reversed(g.cell_of(*GOAL[:2])))
    assert all(cs.free[c] for c in idx)
    for (b0, y0, x0), (b1, y1, x1) in itertools.pairwise(idx):
        db = min((b1 - b0) % cs.n_bins, (b0 - b1) % cs.n_bins)
        assert abs(y1 - y0) + abs(x1 - x0) + db == 1  # one face-adjacent step
    line = shortest_cells(cs, START, GOAL)
    assert line is not None
    for _, y, x in idx:
        assert min(math.hypot(y - ly, x - lx) for ly, lx in line) * g.resolution <= 0.5 + 1e-9
    # a corridor of the path's own cells leaves no room to turn the load: none there (cells_first then
    # searches the whole window)
    assert corridor_cells(cs, START, GOAL, radius_m=0.0) is None
