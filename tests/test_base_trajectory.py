"""B5 time parameterisation: limits, turning while driving through corners, checks, determinism."""

from __future__ import annotations

import itertools
import math

import numpy as np
import numpy.typing as npt
import pytest

from kbplanner.simulation.base_trajectory import Trajectory, time_parameterize
from kbplanner.simulation.motion_check import path_is_free
from kbplanner.simulation.path_pieces import Run, Spin, blend_corners, split_pieces
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

HUSKY = Footprint((Rect(0.0, 0.0, 0.99, 0.67),), name="husky")
LIMITS = {"max_speed_mps": 0.5, "max_yaw_rate_rps": 2.0, "max_accel_mps2": 1.0, "max_yaw_accel_rps2": 2.0}
H = math.pi / 2


def _room(width_m: float = 6.0) -> ConfigurationSpace:
    n = round(width_m / 0.05)
    occ = np.zeros((n, n), dtype=bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    return ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05), HUSKY, 72)


def _corridor_l(width_m: float) -> ConfigurationSpace:
    """An L-shaped corridor of ``width_m``: east along y = 2, then north along x = 4."""
    occ = np.ones((140, 120), dtype=bool)
    half = round(width_m / 2 / 0.05)
    occ[40 - half:40 + half, 5:80 + half] = False
    occ[40 - half:130, 80 - half:80 + half] = False
    return ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05), HUSKY, 72)


# A turn-drive-turn path: east 3 m, turn left 90 degrees, north 3 m, turn 30 degrees right, 1.5 m, turn.
PATH = [(1.0, 1.0, 0.0), (4.0, 1.0, 0.0), (4.0, 1.0, H), (4.0, 4.0, H), (4.0, 4.0, H - 0.5),
        (4.0 + 1.5 * math.cos(H - 0.5), 4.0 + 1.5 * math.sin(H - 0.5), H - 0.5),
        (4.0 + 1.5 * math.cos(H - 0.5), 4.0 + 1.5 * math.sin(H - 0.5), 0.0)]


def _rates(traj: Trajectory) -> tuple[npt.NDArray[np.float64], ...]:
    """Speed, yaw rate, tangential and yaw acceleration by finite differences of the samples (the
    last sample, at the end time, is left out: it follows a shorter period)."""
    t = np.asarray(traj.t_s)[:-1]
    p = np.asarray(traj.poses)[:-1]
    dt = np.diff(t)
    speed = np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1])) / dt
    yaw_rate = ((np.diff(p[:, 2]) + math.pi) % (2 * math.pi) - math.pi) / dt
    return speed, yaw_rate, np.diff(speed) / dt[1:], np.diff(yaw_rate) / dt[1:]


@pytest.mark.parametrize("space", [None, "room"])
def test_the_trajectory_keeps_speed_yaw_rate_and_accelerations_within_the_limits(space: str | None) -> None:
    cs = _room() if space else None
    traj = time_parameterize(PATH, **LIMITS, rate_hz=10.0, space=cs)
    speed, yaw_rate, acc, yaw_acc = _rates(traj)
    assert speed.max() <= LIMITS["max_speed_mps"] + 1e-9
    assert np.abs(yaw_rate).max() <= LIMITS["max_yaw_rate_rps"] + 1e-9
    assert np.abs(acc).max() <= LIMITS["max_accel_mps2"] * 1.02
    assert np.abs(yaw_acc).max() <= LIMITS["max_yaw_accel_rps2"] * 1.02
    assert traj.poses[0] == PATH[0] and traj.poses[-1] == pytest.approx(PATH[-1])
    assert traj.t_s[0] == 0.0 and np.allclose(np.diff(traj.t_s)[:-1], 0.1)
    assert speed[0] < 0.1 and speed[-1] < 0.1  # from rest, to rest


def test_corners_are_driven_through_without_stopping_where_they_fit_and_it_is_faster() -> None:
    cs = _room()
    pieces = blend_corners(PATH, cs, **LIMITS)
    # both corners rounded: one run from the start to the last waypoint, then the final turn on the spot
    assert [type(p) for p in pieces] == [Run, Spin]
    run = pieces[0]
    assert isinstance(run, Run)
    assert path_is_free(cs, run.poses)
    smooth = time_parameterize(PATH, **LIMITS, space=cs)
    stops = time_parameterize(PATH, **LIMITS)
    assert smooth.duration_s < stops.duration_s - 2.0
    speed, _, _, _ = _rates(smooth)
    t = np.asarray(smooth.t_s)[:-1]
    drive = t[1:] <= t[-1] - 2.0  # before the final turn
    assert speed[drive][5:-10].min() > 0.2  # never stops between the first start and the last stop
    # without a configuration space the robot stops at every corner
    speed0, _, _, _ = _rates(stops)
    assert (speed0 < 1e-9).sum() >= 10


def _lines_only(path: list[tuple[float, float, float]]) -> ConfigurationSpace:
    """A configuration space free (at every yaw) only on the cells the path's straight drives cross."""
    grid = OccupancyGrid(np.zeros((120, 120), dtype=bool), origin=(0.0, 0.0), resolution=0.05)
    free = np.zeros((72, 120, 120), dtype=bool)
    for a, b in itertools.pairwise(path):
        for u in np.linspace(0.0, 1.0, 400):
            ix, iy = grid.cell_of(a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]))
            free[:, iy, ix] = True
    return ConfigurationSpace(grid=grid, footprint=HUSKY, free=free)


def test_a_corner_whose_curve_is_not_free_keeps_its_turn_on_the_spot() -> None:
    path = [(1.0, 2.0, 0.0), (4.0, 2.0, 0.0), (4.0, 2.0, H), (4.0, 5.0, H)]
    corridor, lines = _corridor_l(1.3), _lines_only(path)
    assert path_is_free(corridor, path) and path_is_free(lines, path)
    rounded = blend_corners(path, corridor, **LIMITS)
    assert [type(p) for p in rounded] == [Run]  # a curve fits the 1.3 m corridor
    assert path_is_free(corridor, rounded[0].poses)  # type: ignore[union-attr]
    kept = blend_corners(path, lines, **LIMITS)
    assert kept == split_pieces(path)
    assert [type(p) for p in kept] == [Run, Spin, Run]


def test_small_turns_cost_little_and_are_passed_at_speed() -> None:
    cs = _room(8.0)
    end = (4.0 + 3 * math.cos(0.2), 1.0 + 3 * math.sin(0.2), 0.2)
    path = [(1.0, 1.0, 0.0), (4.0, 1.0, 0.0), (4.0, 1.0, 0.2), end]
    traj = time_parameterize(path, **LIMITS, space=cs)
    speed, _, _, _ = _rates(traj)
    # full speed through an 11 degree corner (chords of the curve: a little under the speed along it)
    assert speed[10:-10].min() >= LIMITS["max_speed_mps"] - 1e-3
    length = 6.0
    assert traj.duration_s <= length / 0.5 + 0.5 / 1.0 + 0.2  # straight-line time + accelerating/braking


def test_time_parameterisation_is_deterministic() -> None:
    cs = _room()
    a = time_parameterize(PATH, **LIMITS, space=cs)
    b = time_parameterize(list(PATH), **LIMITS, space=_room())
    assert a == b


def test_a_corner_next_to_a_drive_that_turns_as_it_goes_is_rounded_in_se2_within_the_limits() -> None:
    cs = _room()
    # the planner's SE(2) fallback: 1.5 m turning by 0.6 rad as it drives, a turn on the spot, then straight
    end = (2.5 + 2 * math.cos(1.0), 1.0 + 2 * math.sin(1.0), 1.0)
    path = [(1.0, 1.0, 0.0), (2.5, 1.0, 0.6), (2.5, 1.0, 1.0), end]
    pieces = blend_corners(path, cs, **LIMITS)
    assert [type(p) for p in pieces] == [Run]
    assert path_is_free(cs, pieces[0].poses)  # type: ignore[union-attr]
    traj = time_parameterize(path, **LIMITS, space=cs)
    assert traj.duration_s < time_parameterize(path, **LIMITS).duration_s
    speed, yaw_rate, acc, yaw_acc = _rates(traj)
    assert speed.max() <= LIMITS["max_speed_mps"] + 1e-9
    assert np.abs(yaw_rate).max() <= LIMITS["max_yaw_rate_rps"] + 1e-9
    assert np.abs(acc).max() <= LIMITS["max_accel_mps2"] * 1.02
    assert np.abs(yaw_acc).max() <= LIMITS["max_yaw_accel_rps2"] * 1.02
    assert speed[5:-5].min() > 0.05  # no stop at the corner
    assert traj.poses[-1] == pytest.approx(path[-1])
