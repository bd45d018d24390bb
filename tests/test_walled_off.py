"""Walled-off goals (B5 navigation): told from the plane where it can, and known from the whole map in its
windows (:func:`kbplanner.simulation.navigation.apart_in_plane`, ``plan_path(known_walled_off=...)``)."""

from __future__ import annotations

import pytest

from kbplanner.planning.base_poses import window
from kbplanner.simulation.carry_paths import plan_with_carry_modes
from kbplanner.simulation.nav_path import NavSettings
from kbplanner.simulation.navigation import WALLED_OFF, apart_in_plane, is_walled_off, plan_path
from kbplanner.world.footprint import ConfigurationSpace
from test_navigation import BASE, GOAL, NARROW, START, WIDE, two_rooms


def _labelled(cs: ConfigurationSpace, a: tuple[float, float, float], b: tuple[float, float, float]) -> bool:
    """Walled off as labelling the whole space answers it (face- or 26-connected)."""
    return not (cs.joined(a, b, diagonal=False) or cs.joined(a, b, diagonal=True))


def test_the_plane_tells_a_closed_room_apart_without_labelling_the_space() -> None:
    cs = ConfigurationSpace.build(two_rooms(0.9, closed_east_room=True), BASE)
    assert apart_in_plane(cs, START, GOAL) and is_walled_off(cs, START, GOAL)
    assert cs.memo == {}  # no (bin, y, x) labels were made
    assert _labelled(cs, START, GOAL)


def test_the_plane_never_calls_joined_poses_apart_and_the_answer_is_the_labels_one() -> None:
    for door, fp, walled in ((0.9, BASE, False), (0.9, WIDE, True), (0.6, NARROW, True), (1.8, WIDE, False)):
        cs = ConfigurationSpace.build(two_rooms(door), fp)
        assert is_walled_off(cs, START, GOAL) == _labelled(cs, START, GOAL) == walled, (door, fp.name)
        if apart_in_plane(cs, START, GOAL):
            assert walled


def test_a_goal_known_walled_off_fails_with_the_reason_planning_gives() -> None:
    grid = two_rooms(0.6)
    settings = NavSettings(seed=3)
    planned = plan_path(grid, START, GOAL, WIDE, settings)
    known = plan_path(grid, START, GOAL, WIDE, settings, known_walled_off=True)
    assert planned.reason == known.reason == WALLED_OFF and not known.ok
    # the ends are checked first, as planning checks them
    assert plan_path(grid, (4.1, 0.5, 0.0), GOAL, WIDE, settings, known_walled_off=True).reason == (
        "no path: start in collision")
    both = plan_with_carry_modes(grid, START, GOAL, WIDE, NARROW, settings)
    both_walled = frozenset({WIDE, NARROW})
    told = plan_with_carry_modes(grid, START, GOAL, WIDE, NARROW, settings, walled_off=both_walled)
    assert not both.ok and both.reason == told.reason and both.path.poses == told.path.poses == ()


def test_walled_off_on_the_whole_map_is_walled_off_in_every_window() -> None:
    grid = two_rooms(0.6)
    whole = ConfigurationSpace.build(grid, NARROW)
    assert is_walled_off(whole, START, GOAL)
    for margin in (0.5, 1.0, 3.0):
        sub = window(grid, [START[:2], GOAL[:2]], margin)
        assert is_walled_off(ConfigurationSpace.build(sub, NARROW), START, GOAL)


def test_a_search_walled_off_in_the_plane_stops_without_labelling_the_space() -> None:
    cs = ConfigurationSpace.build(two_rooms(0.9, closed_east_room=True), BASE)
    path = plan_path(cs, START, GOAL, settings=NavSettings(seed=3, time_limit_s=30.0))
    assert not path.ok and path.reason == WALLED_OFF
    assert cs.memo == {}  # neither the face- nor the 26-connected labels were needed


def test_the_plane_stops_a_walled_off_search_at_its_own_count(monkeypatch: pytest.MonkeyPatch) -> None:
    from kbplanner.simulation import navigation
    from kbplanner.simulation.motion_check import ExactMotion

    cs = ConfigurationSpace.build(two_rooms(0.9, closed_east_room=True), BASE)
    checks = 0
    fast = ExactMotion.free6

    def counting(self: ExactMotion, *motion: float) -> bool:
        nonlocal checks
        checks += 1
        return fast(self, *motion)

    monkeypatch.setattr(ExactMotion, "free6", counting)
    monkeypatch.setattr(navigation, "PLANE_AFTER_CHECKS", 300)
    path = plan_path(cs, START, GOAL, settings=NavSettings(seed=3, time_limit_s=60.0))
    assert not path.ok and path.reason == WALLED_OFF
    assert 300 <= checks < 400  # the planner ends the iteration it is in, then stops
    assert cs.memo == {}
