"""B5 navigation (outlier12): a cell route's turns on the spot taken into its drives where they fit,
never reversing (``spin_merge.turn_while_driving``)."""

from __future__ import annotations

import itertools
import math

from kbplanner.simulation.base_trajectory import time_parameterize
from kbplanner.simulation.carry_paths import cell_alternatives
from kbplanner.simulation.motion_check import path_is_free
from kbplanner.simulation.nav_path import NavSettings, Pose2D, wrap
from kbplanner.simulation.spin_merge import DRIVEN_OFF_HEADING_RAD, MAX_OFF_HEADING_RAD, turn_while_driving
from kbplanner.world.footprint import ConfigurationSpace
from test_carry_route import rooms
from test_navigation import BASE, GOAL, START, two_rooms


def _time(cs: ConfigurationSpace, poses: list[Pose2D]) -> float:
    return time_parameterize(poses, 0.5, 2.0, 1.0, 2.0, 10.0, cs).duration_s


def _drives(poses: list[Pose2D]) -> list[tuple[Pose2D, Pose2D]]:
    return [(a, b) for a, b in itertools.pairwise(poses) if math.hypot(b[0] - a[0], b[1] - a[1]) > 1e-9]


def _turned_on_the_spot(poses: list[Pose2D]) -> float:
    return sum(abs(wrap(b[2] - a[2])) for a, b in itertools.pairwise(poses)
               if math.hypot(b[0] - a[0], b[1] - a[1]) <= 1e-9)


def _xy(poses: list[Pose2D]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for x, y, _ in poses:
        if not out or math.hypot(x - out[-1][0], y - out[-1][1]) > 1e-9:
            out.append((x, y))
    return out


def _never_backwards(poses: list[Pose2D]) -> bool:
    for a, b in _drives(poses):
        heading = math.atan2(b[1] - a[1], b[0] - a[0])
        for u in (0.0, 0.25, 0.5, 0.75, 1.0):
            yaw = a[2] + u * wrap(b[2] - a[2])
            if abs(wrap(heading - yaw)) > MAX_OFF_HEADING_RAD + 1e-9:
                return False
    return True


def test_a_turn_before_a_drive_in_the_open_is_taken_while_driving() -> None:
    cs = ConfigurationSpace.build(two_rooms(1.2), BASE)
    poses = [(1.5, 1.5, 0.0), (1.5, 1.5, math.pi / 2), (1.5, 3.0, math.pi / 2)]  # turn left, drive north
    got = turn_while_driving(cs, poses)
    assert got == [poses[0], poses[2]]
    assert path_is_free(cs, got) and _never_backwards(got)
    assert _time(cs, got) < _time(cs, poses)


def test_a_turn_that_would_drive_backwards_is_only_partly_taken() -> None:
    cs = ConfigurationSpace.build(two_rooms(1.2), BASE)
    # facing south, turn round to the north, drive north: all of it on the drive would start backwards
    poses = [(1.5, 1.5, -math.pi / 2), (1.5, 1.5, math.pi / 2 - 1e-3), (1.5, 3.0, math.pi / 2 - 1e-3)]
    got = turn_while_driving(cs, poses)
    assert got[0] == poses[0] and got[-1] == poses[-1] and _xy(got) == _xy(poses)
    assert _never_backwards(got)
    assert 0.0 < _turned_on_the_spot(got) < _turned_on_the_spot(poses)
    assert path_is_free(cs, got)


def test_cell_routes_keep_their_drives_and_ends_and_stay_free_and_forwards() -> None:
    for cs, start, goal in ((ConfigurationSpace.build(rooms(1.8, 0.2), BASE), START, GOAL),
                            (ConfigurationSpace.build(two_rooms(0.9), BASE), (1.0, 1.0, math.pi), GOAL)):
        routes = cell_alternatives(cs, start, goal, NavSettings(seed=3))
        assert routes
        changed = 0
        for r in routes:
            poses = list(r.poses)
            got = turn_while_driving(cs, poses)
            assert got[0] == poses[0] and got[-1] == poses[-1]
            assert _xy(got) == _xy(poses)  # the same drives: the same length
            assert path_is_free(cs, got)
            assert _turned_on_the_spot(got) <= _turned_on_the_spot(poses) + 1e-9
            # a drive it changed never goes backwards (the cell route's own drives are left as they were)
            own = set(_drives(poses))
            for a, b in _drives(got):
                assert (a, b) in own or _never_backwards([a, b])
            changed += got != poses
        assert changed or start != START  # in the wide door's rooms a turn is taken while driving


def test_with_a_smaller_off_heading_a_turn_is_taken_into_its_drive_only_that_far() -> None:
    """heading14: every route driven takes its turns into its drives within ``DRIVEN_OFF_HEADING_RAD``
    (45 degrees) of the yaw: a quarter turn before a drive is taken half (45 degrees) into it."""
    cs = ConfigurationSpace.build(two_rooms(1.2), BASE)
    poses = [(1.5, 1.5, 0.0), (1.5, 1.5, math.pi / 2), (1.5, 3.0, math.pi / 2)]  # turn left, drive north
    got = turn_while_driving(cs, poses, DRIVEN_OFF_HEADING_RAD)
    assert got == [poses[0], (1.5, 1.5, math.pi / 4), poses[2]]
    for a, b in _drives(got):
        heading = math.atan2(b[1] - a[1], b[0] - a[0])
        assert max(abs(wrap(heading - a[2])), abs(wrap(heading - b[2]))) <= DRIVEN_OFF_HEADING_RAD + 1e-9
    assert path_is_free(cs, got)
    assert _time(cs, got) < _time(cs, poses)
    assert turn_while_driving(cs, poses) == [poses[0], poses[2]]  # the default: up to 90 degrees off
