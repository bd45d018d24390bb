"""Path quality figures of a run (simulation/path_quality.py)."""

from __future__ import annotations

import math

import numpy as np

from kbplanner.simulation.path_quality import ArmClock, path_quality, shortest_path_m
from kbplanner.world.footprint import Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid


def test_the_arm_clock_moves_each_joint_at_its_own_limit() -> None:
    clock = ArmClock([0.0, 0.0], [0.5, 1.0])
    clock.update([0.1, 0.3])  # joint 2 dominates: 0.3 s
    clock.update([0.6, 0.3])  # joint 1: 1.0 s
    assert math.isclose(clock.total_s, 1.3)


def test_frames_are_compared_with_shortest_paths_at_top_speed_plus_arm_time() -> None:
    steps = [{"step": 1, "details": {"shortest_m": 4.0, "max_speed_mps": 0.5, "arm_min_s": 1.0}},
             {"step": 2, "details": {"arm_min_s": 3.0}}]
    elements = [{"global_id": "a", "outcome": "installed", "duration_s": 18.0, "steps": steps},
                {"global_id": "b", "outcome": "failed", "duration_s": 5.0, "steps": steps}]
    nav = [{"step": 1, "outcome": "succeeded", "driven_m": 5.0, "shortest_m": 4.0},
           {"step": 3, "outcome": "failed", "driven_m": 1.0, "shortest_m": 4.0}]
    q = path_quality(elements, nav)
    assert [f["global_id"] for f in q["per_element"]] == ["a"]  # failed frames are left out
    assert q["per_element"][0]["lower_bound_s"] == 12.0
    assert q["time_over_lower_bound"] == {"median": 1.5, "max": 1.5, "count": 1}
    assert q["driven_over_shortest"] == {"median": 1.25, "max": 1.25, "count": 1}


def test_the_shortest_path_goes_round_a_wall_and_is_searched_on_the_whole_map_when_the_window_fails() -> None:
    occ = np.zeros((100, 200), dtype=bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    occ[0:80, 100:104] = True  # a wall with a gap at the top
    grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
    fp = Footprint((Rect(0, 0, 0.4, 0.3),))
    start, goal = (2.0, 1.0, 0.0), (8.0, 1.0, 0.0)
    whole = shortest_path_m(grid, grid, start, goal, fp)
    # up past the wall's end (x 5.0-5.2 m, y < 4 m) and down again: about 2 x hypot(3.1, 3.2)
    assert 2 * math.hypot(2.9, 3.0) < whole < 2 * math.hypot(3.3, 3.6)
    window = OccupancyGrid(occ[0:50], origin=(0.0, 0.0), resolution=0.05)  # cut below the gap
    assert shortest_path_m(window, grid, start, goal, fp) == whole
    straight = shortest_path_m(grid, grid, (2.0, 4.6, 0.0), (8.0, 4.6, 0.0), fp)
    assert math.isclose(straight, 6.0, abs_tol=1e-6)
