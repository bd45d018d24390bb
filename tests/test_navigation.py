"""Navigation (B5, NV-1/NV-2): OMPL plans through doors, carries a wide load narrow only where it must."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from kbplanner.simulation.base_trajectory import time_parameterize
from kbplanner.simulation.carry_paths import plan_with_carry_modes
from kbplanner.simulation.grid_yardstick import grid_shortest_path_length
from kbplanner.simulation.motion_check import path_is_free
from kbplanner.simulation.nav_path import NavSettings
from kbplanner.simulation.navigation import plan_path
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import Box, OccupancyGrid, occupancy_from_meshes

BASE = Footprint((Rect(0.0, 0.0, 0.99, 0.67),), name="husky")
# A 1.2 m wide panel: flat across the robot (normal mode), or on its side along the robot (narrow mode).
WIDE = BASE.with_rect(Rect(0.0, 0.0, 0.6, 1.2), name="panel flat across")
NARROW = BASE.with_rect(Rect(0.0, 0.0, 1.2, 0.1), name="panel on its side")
DOOR_X = (4.0, 4.2)  # the dividing wall
START = (1.5, 1.0, 0.5)
GOAL = (6.5, 3.0, -1.0)


def box(x0: float, y0: float, x1: float, y1: float) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=(x1 - x0, y1 - y0, 2.7))
    mesh.apply_translation(((x0 + x1) / 2, (y0 + y1) / 2, 1.35))
    return mesh


def two_rooms(door_width: float, door_center_y: float = 2.0, closed_east_room: bool = False) -> OccupancyGrid:
    """Two 4 x 4 m rooms side by side, joined by one door in the 0.2 m wall at x = 4.0-4.2."""
    lo, hi = door_center_y - door_width / 2, door_center_y + door_width / 2
    walls = [box(-0.2, -0.2, 8.4, 0.0), box(-0.2, 4.0, 8.4, 4.2), box(-0.2, 0.0, 0.0, 4.0),
             box(8.2, 0.0, 8.4, 4.0), box(4.0, 0.0, 4.2, lo), box(4.0, hi, 4.2, 4.0)]
    if closed_east_room:
        walls.append(box(4.0, lo, 4.2, hi))
    return occupancy_from_meshes(walls, (0.05, 1.5), Box(-0.5, -0.5, 8.7, 4.5), 0.05)


@pytest.fixture(scope="module")
def door_09() -> OccupancyGrid:
    return two_rooms(0.9)


def _dense_free(cs: ConfigurationSpace, poses: tuple[tuple[float, float, float], ...], step: float = 0.01
                ) -> bool:
    from kbplanner.simulation.nav_path import densify

    return bool(cs.is_free_many(densify(poses, step, math.radians(1.0))).all())


def test_the_wide_load_is_carried_narrow_only_through_the_door(door_09: OccupancyGrid) -> None:
    plan = plan_with_carry_modes(door_09, START, GOAL, WIDE, NARROW, NavSettings(seed=3), margin_m=0.5)
    assert plan.ok and plan.mode == "narrow", plan.reason
    assert plan.normal_attempt is not None and not plan.normal_attempt.ok
    assert "walled off" in plan.normal_attempt.reason  # the wide load cannot pass the 0.9 m door at all
    assert [e.kind for e in plan.events] == ["rotate_to_narrow", "rotate_back"]
    (seg,) = plan.segments
    poses = plan.path.poses
    to_narrow, back = poses[seg.start_index], poses[seg.end_index]
    # Rotations happen on either side of the door, close to it, and nowhere else.
    assert to_narrow[0] < DOOR_X[0] and back[0] > DOOR_X[1]
    for x, y, _ in (to_narrow, back):
        assert math.hypot(x - sum(DOOR_X) / 2, y - 2.0) < 1.6
    cs_wide = ConfigurationSpace.build(door_09, WIDE)
    cs_narrow = ConfigurationSpace.build(door_09, NARROW)
    assert _dense_free(cs_narrow, poses)
    assert _dense_free(cs_wide, poses[: seg.start_index + 1]) and _dense_free(cs_wide, poses[seg.end_index :])
    assert not _dense_free(cs_wide, poses[seg.start_index : seg.end_index + 1])
    assert plan.extra["narrow_length_m"] == pytest.approx(seg.end_s_m - seg.start_s_m)
    assert seg.end_s_m - seg.start_s_m < 0.5 * plan.path.length_m


def test_a_wide_enough_door_needs_no_rotation() -> None:
    plan = plan_with_carry_modes(two_rooms(1.8), START, GOAL, WIDE, NARROW, NavSettings(seed=3))
    assert plan.ok and plan.mode == "normal" and plan.events == () and plan.segments == ()


def test_a_door_too_narrow_even_for_the_narrow_mode_fails_with_both_reasons() -> None:
    plan = plan_with_carry_modes(two_rooms(0.6), START, GOAL, WIDE, NARROW, NavSettings(seed=3))
    assert not plan.ok and plan.status == "failed"
    assert "narrow carry mode" in plan.reason and "normal mode" in plan.reason
    assert "walled off" in plan.reason


def test_a_start_in_collision_is_a_failed_result_not_an_exception(door_09: OccupancyGrid) -> None:
    path = plan_path(door_09, (4.1, 0.5, 0.0), GOAL, BASE)  # inside the dividing wall
    assert not path.ok and path.reason == "no path: start in collision" and path.poses == ()
    path = plan_path(door_09, START, (0.2, 0.2, 0.0), BASE)  # base overlaps the corner walls
    assert not path.ok and path.reason == "no path: goal in collision"
    path = plan_path(door_09, START, (20.0, 2.0, 0.0), BASE)
    assert not path.ok and "off the map" in path.reason


def test_a_walled_off_goal_fails_with_its_reason_without_using_the_time_budget() -> None:
    closed = two_rooms(0.9, closed_east_room=True)
    path = plan_path(closed, START, GOAL, BASE, NavSettings(time_limit_s=30.0))
    assert not path.ok and "walled off" in path.reason
    assert path.planning_time_s < 1.0


def test_the_time_budget_ends_planning_with_a_reason(door_09: OccupancyGrid) -> None:
    # The door needs hundreds of tree states (about 0.05 s here); 0.1 ms is not enough on any machine.
    settings = NavSettings(time_limit_s=0.0001, seed=3, cell_fallback=False)
    path = plan_path(door_09, START, GOAL, NARROW, settings)
    assert not path.ok and "or 0.0001 s" in path.reason
    assert path.planning_time_s < 0.5


def test_the_work_budget_ends_planning_the_same_way_on_any_machine(door_09: OccupancyGrid) -> None:
    # Ten motion checks cannot cross the door: the same failure, whatever the machine's speed.
    settings = NavSettings(max_motion_checks=10, time_limit_s=60.0, seed=3, cell_fallback=False)
    a = plan_path(door_09, START, GOAL, NARROW, settings)
    b = plan_path(door_09, START, GOAL, NARROW, settings)
    assert not a.ok and a.reason.startswith("no path within 10 motion checks")
    assert a.reason == b.reason


def test_the_same_seed_gives_the_same_path(door_09: OccupancyGrid) -> None:
    cs = ConfigurationSpace.build(door_09, NARROW)
    a = plan_path(cs, START, GOAL, settings=NavSettings(seed=11))
    b = plan_path(cs, START, GOAL, settings=NavSettings(seed=11))
    assert a.ok and a.poses == b.poses and a.length_m == b.length_m
    plans = {plan_path(cs, START, GOAL, settings=NavSettings(seed=s)).poses for s in (1, 2, 3, 4)}
    assert len(plans) > 1  # the seed is really used


def test_planned_paths_are_collision_free_and_within_10_percent_of_the_grid_shortest_path(
    door_09: OccupancyGrid,
) -> None:
    cs = ConfigurationSpace.build(door_09, NARROW)
    shortest = grid_shortest_path_length(cs, START, GOAL)
    assert 5.0 < shortest < 6.5
    for seed in (1, 2, 3):
        path = plan_path(cs, START, GOAL, settings=NavSettings(seed=seed))
        assert path.ok and path.poses[0] == START and path.poses[-1] == pytest.approx(GOAL)
        assert _dense_free(cs, path.poses)
        assert path.length_m <= 1.10 * shortest, (seed, path.length_m, shortest)


def test_grid_shortest_path_length_is_infinite_when_walled_off_and_straight_in_the_open() -> None:
    closed = two_rooms(0.9, closed_east_room=True)
    assert grid_shortest_path_length(closed, START, GOAL, BASE) == math.inf
    assert grid_shortest_path_length(closed, (1.0, 1.0), (3.0, 3.0), BASE) == pytest.approx(math.hypot(2, 2))


def test_time_parameterisation_respects_speed_and_yaw_rate_and_ends_at_the_goal(
    door_09: OccupancyGrid,
) -> None:
    path = plan_path(door_09, START, GOAL, NARROW, NavSettings(seed=3))
    traj = time_parameterize(path, max_speed_mps=1.0, max_yaw_rate_rps=1.0, max_accel_mps2=0.5,
                             max_yaw_accel_rps2=1.0, rate_hz=20.0)
    t = np.array(traj.t_s)
    xyz = np.array(traj.poses)
    assert t[0] == 0.0 and np.allclose(np.diff(t)[:-1], 0.05)
    assert xyz[0] == pytest.approx(START) and xyz[-1] == pytest.approx(GOAL)
    dt = np.diff(t)
    speed = np.hypot(np.diff(xyz[:, 0]), np.diff(xyz[:, 1])) / dt
    yaw_rate = np.abs((np.diff(xyz[:, 2]) + math.pi) % (2 * math.pi) - math.pi) / dt
    assert speed.max() <= 1.0 + 1e-6 and yaw_rate.max() <= 1.0 + 1e-6
    assert traj.duration_s >= path.length_m / 1.0
    # Rest-to-rest per segment: the robot stops at each waypoint.
    assert speed[0] < 0.1 and speed[-1] < 0.1


def test_the_exact_motion_check_catches_a_segment_that_only_clips_a_cell_corner() -> None:
    grid = OccupancyGrid(np.zeros((20, 20), dtype=bool), origin=(0.0, 0.0), resolution=0.05)
    free = np.ones((72, 20, 20), dtype=bool)
    free[:, 10, 10] = False  # one blocked cell: x, y in [0.50, 0.55)
    cs = ConfigurationSpace(grid=grid, footprint=BASE, free=free)
    # A diagonal passing 1 mm inside the cell's top-left corner (0.50, 0.55): it clips 1 mm of it.
    clip = [(0.30, 0.349, 0.0), (0.70, 0.749, 0.0)]
    dense = np.linspace(clip[0], clip[1], 30)  # 1.4 cm samples step over the clipped corner
    assert cs.is_free_many(dense).all()
    assert not path_is_free(cs, clip)
    assert path_is_free(cs, [(0.30, 0.351, 0.0), (0.70, 0.751, 0.0)])  # 1 mm outside the corner
    assert not path_is_free(cs, [(0.525, 0.2, 0.0), (0.525, 0.9, 1.0)])  # straight through, turning
    free[36, 3, 3] = False  # one yaw bin blocked at one cell: turning on the spot through it fails
    assert not path_is_free(cs, [(0.175, 0.175, 3.0), (0.175, 0.175, -3.0)])
    assert path_is_free(cs, [(0.175, 0.175, 2.0), (0.175, 0.175, 0.5)])


def test_skid_steer_paths_turn_on_the_spot_and_drive_straight(door_09: OccupancyGrid) -> None:
    path = plan_path(door_09, START, GOAL, BASE, NavSettings(seed=4))
    assert path.ok and "turn-drive-turn" in path.reason
    mixed = 0
    for (x0, y0, t0), (x1, y1, t1) in zip(path.poses[:-1], path.poses[1:], strict=True):
        if math.hypot(x1 - x0, y1 - y0) < 1e-9:
            continue  # a turn on the spot
        heading = math.atan2(y1 - y0, x1 - x0)
        along = min(abs(math.remainder(t0 - heading, 2 * math.pi)),
                    abs(math.remainder(t0 - heading - math.pi, 2 * math.pi)))
        if not (along < 1e-9 and t0 == t1):
            mixed += 1
    assert mixed == 0 or f"{mixed} segment(s) partly turning while driving" in path.reason
    holonomic = plan_path(door_09, START, GOAL, BASE, NavSettings(seed=4, base_motion="holonomic"))
    assert holonomic.ok and len(holonomic.poses) < len(path.poses)
    assert holonomic.length_m == pytest.approx(path.length_m)


def test_where_free_cells_certainly_cross_the_door_the_cell_path_settles_what_ompl_cannot(
    door_09: OccupancyGrid,
) -> None:
    # Ten motion checks are not enough for RRTConnect; face-adjacent free cells join start and goal,
    # so the cell path (shortened by exact checks) is the answer, the same on every run.
    cs = ConfigurationSpace.build(door_09, NARROW)
    settings = NavSettings(max_motion_checks=10, time_limit_s=60.0, seed=3)
    a = plan_path(cs, START, GOAL, settings=settings)
    b = plan_path(cs, START, GOAL, settings=settings)
    assert a.ok and a.planner.endswith("+cells") and "cell search" in a.reason
    assert a.poses == b.poses
    assert path_is_free(cs, a.poses)
    assert a.length_m < 1.3 * grid_shortest_path_length(cs, START, GOAL)


def test_each_piece_of_a_carry_plan_is_rounded_in_the_space_of_the_footprint_it_is_carried_in(
    door_09: OccupancyGrid,
) -> None:
    from kbplanner.simulation.path_pieces import Run, blend_corners

    plan = plan_with_carry_modes(door_09, START, GOAL, WIDE, NARROW, NavSettings(seed=3), margin_m=0.5)
    pieces = plan.pieces()
    assert [mode for _, mode, _ in pieces] == ["normal", "narrow", "normal"]
    assert [space.footprint for _, _, space in pieces if space is not None] == [WIDE, NARROW, WIDE]
    for poses, _, space in pieces:
        assert space is not None
        runs = [p for p in blend_corners(poses, space, 0.3, 2.0, 1.0, 2.0) if isinstance(p, Run)]
        assert runs and all(path_is_free(space, run.poses) for run in runs)
        assert runs[0].poses[0] == poses[0] and runs[-1].poses[-1][:2] == pytest.approx(poses[-1][:2])
