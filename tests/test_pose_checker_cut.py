"""planning/base_poses.PoseChecker: the kernel cut to its cells gives the configuration space's answer."""

from __future__ import annotations

import math

import numpy as np

from kbplanner.planning.base_poses import PoseChecker
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid


def test_free_is_the_configuration_space_look_up() -> None:
    rng = np.random.default_rng(21)
    occ = rng.random((60, 90)) < 0.02
    occ[:, 45] = True
    occ[20:32, 45] = False
    grid = OccupancyGrid(occ, origin=(-1.0, 2.0), resolution=0.05)
    footprints = [Footprint((Rect(0, 0, 0.5, 0.3),)),
                  Footprint((Rect(0, 0, 0.5, 0.3), Rect(0.1, 0.3, 0.1, 1.2))),
                  Footprint((Rect(0.4, 0.0, 0.1, 0.1),))]  # off-centre: its kernel on one side only
    checker = PoseChecker(grid, 24)
    for fp in footprints:
        cs = ConfigurationSpace.build(grid, fp, 24)
        answers = set()
        for _ in range(1500):
            # poses over the grid and a little beyond it (kernels reaching off the map)
            x = grid.origin[0] + rng.uniform(-0.2, 90 * 0.05 + 0.2)
            y = grid.origin[1] + rng.uniform(-0.2, 60 * 0.05 + 0.2)
            yaw = rng.uniform(-math.pi, math.pi)
            got = checker.free(fp, x, y, yaw)
            assert got == cs.is_free(x, y, yaw), (fp, x, y, yaw)
            answers.add(got)
        assert answers == {True, False}
