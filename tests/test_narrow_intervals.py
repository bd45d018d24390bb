"""B5 navigation (NV-2): where a carry leg passes two narrow places close together, the load is not
turned back between them for a normal stretch shorter than the margin kept round each (reverse13: a
turn on the spot only the narrow load can make, next to a door, made the test project's panel turn
narrow and back twice)."""

from __future__ import annotations

import pytest

from kbplanner.simulation.carry_paths import narrow_intervals
from kbplanner.world.footprint import ConfigurationSpace
from kbplanner.world.occupancy import Box, occupancy_from_meshes
from test_navigation import WIDE, box

PATH = ((0.8, 2.0, 0.0), (8.0, 2.0, 0.0))  # straight east through both doors, the load across the way


def _two_doors() -> ConfigurationSpace:
    """A 9 x 4 m hall crossed by two walls (x 3.0-3.2 and 5.0-5.2), each with a 0.9 m door at y 2."""
    walls = [box(-0.2, -0.2, 9.2, 0.0), box(-0.2, 4.0, 9.2, 4.2), box(-0.2, 0.0, 0.0, 4.0),
             box(9.0, 0.0, 9.2, 4.0)]
    for x in (3.0, 5.0):
        walls += [box(x, 0.0, x + 0.2, 1.55), box(x, 2.45, x + 0.2, 4.0)]
    grid = occupancy_from_meshes(walls, (0.05, 1.5), Box(-0.5, -0.5, 9.7, 4.5), 0.05)
    return ConfigurationSpace.build(grid, WIDE)


def test_narrow_stretches_less_than_the_margin_apart_are_one() -> None:
    cs = _two_doors()
    step = cs.grid.resolution / 4
    blocked = narrow_intervals(PATH, cs, 0.0, step)  # where the wide load does not pass, not grown
    assert len(blocked) == 2
    gap = blocked[1][0] - blocked[0][1]
    assert gap > 0.2
    # grown by a margin, the normal stretch left between them is gap - 2 x margin
    wide_apart = gap / 4  # leaves gap / 2, over the margin: turned back and narrow again
    assert [(round(a, 3), round(b, 3)) for a, b in narrow_intervals(PATH, cs, wide_apart, step)] == [
        (round(blocked[0][0] - wide_apart, 3), round(blocked[0][1] + wide_apart, 3)),
        (round(blocked[1][0] - wide_apart, 3), round(blocked[1][1] + wide_apart, 3))]
    close = gap / 2.5  # leaves gap / 5, under the margin: carried narrow from before one to after the other
    merged = narrow_intervals(PATH, cs, close, step)
    assert len(merged) == 1
    assert merged[0] == pytest.approx((blocked[0][0] - close, blocked[1][1] + close))
