"""B4's carry-leg check (planning/carry_reach.py): the robot holding a frame reaches an install base pose only
through openings its carry footprints pass; the reason names the element installed before that closes
the way, and the install order feedback moves the blocked element before it (planning/install_order.py)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from kbplanner.planning.carry import CarryGeometry, CarryMode
from kbplanner.planning.carry_reach import (
    CarryReach,
    blocker_in,
    carry_footprints,
    carry_leg_reason,
    first_blocker,
    reaches_alone,
)
from kbplanner.planning.feasibility import fix_for
from kbplanner.planning.install_order import blocked_move, move_before
from kbplanner.planning.plan_model import Pose2
from kbplanner.world.footprint import Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid
from test_install_order import _plan, _refined

RES = 0.05
BASE = Footprint((Rect(0.0, 0.0, 0.6, 0.4),), "base")


def _geometry(normal: Rect, narrow: Rect) -> CarryGeometry:
    eye = np.eye(4)
    return CarryGeometry(BASE, CarryMode("normal", (0.0,), eye, normal, 0.1),
                         CarryMode("narrow", (0.0,), eye, narrow, 0.1))


#: a 2.4 x 0.75 m frame held flat, its long side across the heading (normal), or on its side along it
FRAME = _geometry(Rect(0.0, 0.0, 0.75, 2.4), Rect(0.0, 0.0, 2.4, 0.15))


def _two_rooms(door_m: float) -> OccupancyGrid:
    """Two 6 x 6 m rooms side by side (a wall at x = 6 m) joined by one door ``door_m`` wide at y = 3 m."""
    occ = np.zeros((120, 240), dtype=bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    occ[:, 120] = True
    half = round(door_m / RES / 2)
    occ[60 - half:60 + half, 120] = False
    return OccupancyGrid(occ, origin=(0.0, 0.0), resolution=RES)


PICK = Pose2(3.0, 3.0, 0.0)
INSTALL = Pose2(9.0, 3.0, 0.0)


def test_a_frame_carried_narrow_passes_a_door_its_normal_carry_does_not() -> None:
    grid = _two_rooms(0.8)
    reach = CarryReach(grid, carry_footprints(FRAME), PICK, (INSTALL.x, INSTALL.y))
    assert reach.reaches(INSTALL)
    normal_only = CarryReach(grid, carry_footprints(FRAME)[:1], PICK, (INSTALL.x, INSTALL.y))
    assert not normal_only.reaches(INSTALL)  # flat, 0.75 x 2.4 m: through 0.8 m neither way


def test_a_door_narrower_than_both_carry_footprints_walls_the_install_off_with_figures() -> None:
    grid = _two_rooms(0.45)  # the base (0.4 m) passes, with the frame on its side (0.15 m) too, not grown
    reach = CarryReach(grid, carry_footprints(FRAME), PICK, (INSTALL.x, INSTALL.y))
    assert not reach.reaches(INSTALL)
    assert not reaches_alone(grid, BASE, PICK, [INSTALL], (INSTALL.x, INSTALL.y))
    wide = _two_rooms(0.7)  # the robot alone passes; the flat frame (0.75 x 2.4 m) does not
    wide_geo = _geometry(Rect(0.0, 0.0, 0.75, 2.4), Rect(0.0, 0.0, 0.75, 2.4))  # no narrow carry at all
    assert not CarryReach(wide, carry_footprints(wide_geo), PICK, (INSTALL.x, INSTALL.y)).reaches(INSTALL)
    assert reaches_alone(wide, BASE, PICK, [INSTALL], (INSTALL.x, INSTALL.y))
    reason = carry_leg_reason(wide_geo, PICK, 5, True, None)
    assert reason.startswith("carry way walled off")
    assert "normal 0.75 m long x 2.40 m wide" in reason and "(3.00, 3.00)" in reason and "5 free" in reason
    assert "the robot alone gets there" in reason
    assert "storage" in fix_for(reason, pick=False) and "split" in fix_for(reason, pick=False)


def test_the_element_installed_in_the_doorway_is_named_and_moving_before_it_unblocks() -> None:
    grid = _two_rooms(0.9)
    door = shapely.box(5.9, 2.6, 6.6, 3.4)  # a frame installed in front of the door, room 2 side
    far = shapely.box(1.0, 5.0, 1.2, 5.8)  # one in a corner of room 1: closes nothing
    installed = [("urn:A", "A", far), ("urn:B", "B", door)]
    blocker = first_blocker(grid, installed, FRAME, PICK, [INSTALL], (INSTALL.x, INSTALL.y))
    assert blocker is not None and blocker.iri == "urn:B"
    assert first_blocker(grid, installed[:1], FRAME, PICK, [INSTALL], (INSTALL.x, INSTALL.y)) is None
    reason = carry_leg_reason(FRAME, PICK, 3, False, blocker)
    assert blocker_in(reason) == "urn:B"
    assert "install this element before B" in reason
    assert fix_for(reason, pick=False).startswith("install this element before the element the reason names")
    # B4's order feedback: C (blocked by B) goes before B, though B stands 10 m from it
    plan = _plan({"A": 0.0, "B": 20.0, "C": 30.0})
    refined = _refined(plan, "C", reason)
    move = blocked_move(plan, refined, {}, 3.0, set())
    assert move == ("urn:C", "urn:B")
    assert [e.label for e in move_before(plan, *move).elements] == ["A", "C", "B"]


def test_a_named_blocker_with_a_work_sequence_is_not_passed() -> None:
    plan = _plan({"A": 0.0, "B": 20.0, "C": 30.0}, sequences={"B": 1})
    reason = carry_leg_reason(FRAME, PICK, 3, False, first_blocker(
        _two_rooms(0.9), [("urn:B", "B", shapely.box(5.9, 2.6, 6.6, 3.4))], FRAME, PICK, [INSTALL],
        (INSTALL.x, INSTALL.y)))
    assert blocked_move(plan, _refined(plan, "C", reason), {}, 3.0, set()) is None


@pytest.mark.parametrize("start", [Pose2(3.0, 0.1, 0.0)])
def test_a_start_in_collision_is_left_for_the_nearest_free_pose_as_the_navigation_does(start: Pose2) -> None:
    grid = _two_rooms(0.9)
    reach = CarryReach(grid, carry_footprints(FRAME), start, (INSTALL.x, INSTALL.y))
    assert reach.start != start and abs(reach.start.x - start.x) + abs(reach.start.y - start.y) <= 0.5 * 2
    assert not reach.start_blocked()


def test_a_way_one_carry_mode_drives_is_direct_and_a_closed_one_is_none() -> None:
    grid = _two_rooms(0.8)
    reach = CarryReach(grid, carry_footprints(FRAME), PICK, (INSTALL.x, INSTALL.y))
    assert reach.way(INSTALL) == 2  # narrow all the way, as the navigation's first plan
    assert reach.way(Pose2(4.0, 3.0, 0.0)) == 2  # the same room
    closed = CarryReach(_two_rooms(0.45), carry_footprints(FRAME), PICK, (INSTALL.x, INSTALL.y))
    assert closed.way(INSTALL) == 0


def test_a_frame_that_fits_only_flat_at_the_pick_is_turned_behind_the_robot_as_the_navigation_does() -> None:
    grid = _two_rooms(0.8)
    facing_wall = Pose2(1.0, 3.0, np.pi)  # on its side (2.4 m along the heading) it would touch the wall
    reach = CarryReach(grid, carry_footprints(FRAME), facing_wall, (INSTALL.x, INSTALL.y))
    assert reach.way(INSTALL) == 1  # flat it does not pass the door, on its side it does not fit here
    assert reach.turn_route(INSTALL) is None  # turned a little behind the robot, then through on its side
