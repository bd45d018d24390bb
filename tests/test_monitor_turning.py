"""B5 speed and separation monitoring while the robot turns in place or turns its load (issue 11).

A turn moves one end of a long load away from one person and the other end towards another: a
protective stop may only be left by a step away from *everyone* seen. While the arm turns the load
with the base standing still (``ExecSettings.monitor_load_turns``, off by default), the sweep of the
load's ends counts as the robot's speed; and the arm turns the load from where it is, without jumps.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kbplanner.planning.manipulation import robot_name
from kbplanner.robot.lidar import lidar_spec
from kbplanner.simulation.separation_monitor import SeparationMonitor
from kbplanner.simulation.sim_env import SimEnv
from kbplanner.simulation.workers import RouteStop, WorkerMotion, WorkerSpec
from kbplanner.world.footprint import Rect
from sim_project_factory import load_sim_case

ROBOT = (2.5, -1.0, math.pi / 2)  # in the yard south of the door, heading north
# base plus a 2.4 m load across the robot: its ends at site (1.3, -1.0) and (3.7, -1.0)
RECTS = [Rect(0.0, 0.0, 0.99, 0.67), Rect(0.0, 0.0, 0.6, 2.4)]
PARAMS = {"maxSpeed": 0.3, "minSpeed": 0.05, "safetyStopDistance": 0.5}


def _standing(name: str, x: float, y: float) -> WorkerMotion:
    spec = WorkerSpec(f"urn:test:{name}", name, "carpenter", 1.0, (RouteStop("s", "S", x, y, 1e6),))
    return WorkerMotion(spec, [(0.0, 1e6, np.array([[x, y]]), np.zeros(1))])


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return load_sim_case(tmp_path_factory.mktemp("turning") / "p", high_panel=False)


def _monitor(case, workers: list[WorkerMotion]) -> tuple[SimEnv, SeparationMonitor]:  # type: ignore[no-untyped-def]
    env = SimEnv(case.world, robot_name(case.refined), grid=case.grid, workers=workers)
    env.reset(seed=1)
    env.set_base_pose(*ROBOT)
    return env, SeparationMonitor(env, lidar_spec(env.robot, 1.0), PARAMS, max_speed=0.3)


def test_a_turn_that_brings_one_end_of_the_load_towards_another_person_is_a_stop(case) -> None:  # type: ignore[no-untyped-def]
    # turning left (yaw up) the east end comes north, away from "east" south of it, and the west
    # end goes south, towards "west"; both stand within the stop distance of the load's ends
    turn = (ROBOT[0], ROBOT[1], ROBOT[2] + 0.05)
    east = _standing("east", 3.7, -1.85)
    env, mon = _monitor(case, [east])
    try:
        alone = mon.decide(RECTS, ROBOT, turn)
    finally:
        env.close()
    assert alone.sensed is not None and alone.sensed.separation_m < mon.stop_m
    assert not alone.stopped and 0 < alone.fraction < 1  # a step away from the only person seen
    env, mon = _monitor(case, [east, _standing("west", 1.3, -1.95)])
    try:
        both = mon.decide(RECTS, ROBOT, turn)
    finally:
        env.close()
    assert both.sensed is not None and both.sensed.worker == "east"  # the nearer one limits the speed
    assert both.stopped and both.fraction == 0.0  # but the turn comes towards "west": a stop


def test_the_arm_turning_the_load_counts_the_sweep_of_its_ends(case, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    env, mon = _monitor(case, [_standing("near", 3.7, -1.85)])
    try:
        still = mon.decide(RECTS, ROBOT, ROBOT)
        sweep = mon.decide(RECTS, ROBOT, ROBOT, sweep_mps=0.6 * 1.3)
    finally:
        env.close()
    assert still.fraction == 1.0 and not still.stopped  # nothing moves: nothing to monitor
    assert sweep.stopped and sweep.fraction == 0.0 and sweep.protective_m > still.protective_m
    env, mon = _monitor(case, [_standing("far", 3.7, -6.0)])
    try:
        far = mon.decide(RECTS, ROBOT, ROBOT, sweep_mps=0.6 * 1.3)
    finally:
        env.close()
    assert not far.stopped and far.fraction > 0


def test_the_arm_turns_the_load_from_where_it_is_without_jumps(case, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    # the turn to narrow used to start from the lift pose, not from the carry pose the arm was in
    from kbplanner.simulation.executor import simulate
    from kbplanner.simulation.skills import ExecSettings

    case.refined.keep_first(1)
    settings = ExecSettings(keyframes=False)
    r = simulate(case.project, case.refined, seed=3, out_dir=tmp_path / "run", world=case.world,
                 grid=case.grid, settings=settings, workers=[])
    kinds = {e["kind"] for e in r.events}
    assert {"carry_pose", "rotate_to_narrow", "rotate_back"} <= kinds
    nv2 = next(e["step"] for e in r.events if e["kind"] == "rotate_to_narrow")
    rows = [line.split(",") for line in (tmp_path / "run" / "trajectories.csv").read_text().splitlines()[1:]]
    q = np.array([[float(v) for v in row[4:10]] for row in rows if row[12] == str(nv2)])
    t = np.array([float(row[0]) for row in rows if row[12] == str(nv2)])
    rate = np.abs(np.diff(q, axis=0)).max(axis=1) / np.diff(t)
    assert float(rate.max()) <= settings.joint_speed_rps + 0.01
