"""Proximity on hand-made trajectories with known answers, including the footprint and the carried load."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kbplanner.analysis.proximity import (
    SsmParameters,
    intervals_below,
    point_to_rects_distance,
    robot_speed,
    time_below_s,
)
from kbplanner.world.footprint import Rect

BASE = Rect(0.0, 0.0, 1.0, 0.6)  # 1.0 m long, 0.6 m wide, centred on the robot origin
LOAD = Rect(0.0, 0.0, 0.2, 2.4)  # a frame carried across the robot: 2.4 m wide


def _d(px: float, py: float, rx: float = 0.0, ry: float = 0.0, yaw: float = 0.0,
       rects: tuple[Rect, ...] = (BASE,)) -> float:
    return float(point_to_rects_distance(np.array([px]), np.array([py]), np.array([rx]), np.array([ry]),
                                         np.array([yaw]), rects)[0])


def test_distance_to_the_base_footprint_is_to_its_nearest_edge_or_corner() -> None:
    assert _d(2.0, 0.0) == pytest.approx(1.5)  # in front: 2.0 - 0.5
    assert _d(0.0, 1.3) == pytest.approx(1.0)  # to the side: 1.3 - 0.3
    assert _d(1.5, 1.3) == pytest.approx(math.hypot(1.0, 1.0))  # diagonal: to the corner
    assert _d(0.1, 0.1) == 0.0  # inside


def test_the_carried_element_makes_a_worker_at_the_side_closer() -> None:
    without = _d(0.0, 1.5)
    with_load = _d(0.0, 1.5, rects=(BASE, LOAD))
    assert without == pytest.approx(1.2)
    assert with_load == pytest.approx(0.3)  # the load reaches 1.2 m to the side


def test_the_footprint_turns_with_the_robot() -> None:
    # Robot at (5, 5) facing +y: its 1.0 m length now runs along y.
    assert _d(5.0, 7.0, 5.0, 5.0, math.pi / 2) == pytest.approx(1.5)
    assert _d(6.3, 5.0, 5.0, 5.0, math.pi / 2) == pytest.approx(1.0)


def test_intervals_below_a_threshold_have_known_start_end_minimum_and_place() -> None:
    t = np.arange(0.0, 10.0, 1.0)
    # A worker walks past the robot standing at the origin facing +x, along y = 1.3, x from -4.5 to 4.5.
    wx = np.linspace(-4.5, 4.5, 10)
    wy = np.full(10, 1.3)
    d = point_to_rects_distance(wx, wy, np.zeros(10), np.zeros(10), np.zeros(10), [BASE])
    ivs = intervals_below(t, d, 1.5, worker="w", threshold="1.5 m", wx=wx, wy=wy)
    assert len(ivs) == 1
    iv = ivs[0]
    # Samples at x = -0.5 and 0.5 (t = 4, 5) are 1.0 m away; x = +-1.5 (t = 3, 6) are 1.414 m away.
    assert (iv.start_s, iv.end_s) == (3.0, 7.0)
    assert iv.min_distance_m == pytest.approx(1.0)
    assert iv.t_min_s == 4.0 and iv.x_m == pytest.approx(-0.5) and iv.y_m == pytest.approx(1.3)
    assert iv.duration_s == 4.0


def test_no_interval_when_always_far_and_one_per_approach() -> None:
    t = np.arange(6.0)
    far = np.full(6, 3.0)
    assert intervals_below(t, far, 1.0, worker="w", threshold="1 m", wx=far, wy=far) == []
    d = np.array([2.0, 0.5, 2.0, 0.4, 0.3, 2.0])
    ivs = intervals_below(t, d, 1.0, worker="w", threshold="1 m", wx=t, wy=t)
    assert [(i.start_s, i.end_s, i.min_distance_m) for i in ivs] == [(1.0, 2.0, 0.5), (3.0, 5.0, 0.3)]


def test_the_analysis_uses_the_simulation_s_s_p_and_time_below() -> None:
    # one definition (issue 11): the analysis' S_p is the executor's, with the same constants
    from kbplanner.simulation import separation

    assert SsmParameters is separation.SsmParameters
    p = SsmParameters()
    s0 = float(p.separation_m(0.0))
    assert s0 == pytest.approx(1.6 * 0.14 + 1.08 + 0.1)
    # T_s = v / a: v_h v / a + v T_r + v^2 / (2 a)
    assert float(p.separation_m(1.0)) == pytest.approx(s0 + 1.6 + 0.14 + 0.5)
    assert SsmParameters.from_dict(p.as_dict()) == p


def test_time_below_counts_time_of_the_run_not_worker_seconds() -> None:
    t = np.arange(6.0)
    a = np.array([2.0, 0.5, 0.5, 2.0, 2.0, 2.0])
    b = np.array([2.0, 2.0, 0.5, 0.5, 2.0, 2.0])  # overlaps a at t = 2
    assert time_below_s(t, [a, b], 1.0) == pytest.approx(3.0)
    assert time_below_s(t, [a], np.array([1.0, 1.0, 0.4, 1.0, 1.0, 1.0])) == pytest.approx(1.0)


def test_robot_speed_from_positions() -> None:
    t = np.array([0.0, 1.0, 2.0, 3.0])
    v = robot_speed(t, np.array([0.0, 0.3, 0.6, 0.6]), np.zeros(4))
    assert v.tolist() == pytest.approx([0.0, 0.3, 0.3, 0.0])
