"""B5 NV-1/NV-2 liveness: a base pose the conservative map calls blocked is still reached (issue 11).

The map marks every cell a wall, a storage or an installed element touches, so a base pose B4 chose a
few centimetres from one may lie in cells the map calls blocked for every footprint (storage-inside
seed 17, F08: the robot with the frame carried either way). The navigation then plans to the nearest
free pose and makes the last few centimetres straight (event ``unstick`` at the base pose), as it
does when it starts in such cells.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from kbplanner.planning.base_poses import UNSTICK_RADIUS_M, PoseChecker, nearest_free_pose
from kbplanner.planning.manipulation import robot_name
from kbplanner.planning.plan_model import Pose2
from kbplanner.robot.robot_table import robot_spec
from kbplanner.simulation.executor import simulate
from kbplanner.simulation.skills import ExecSettings
from sim_project_factory import load_sim_case


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    c = load_sim_case(tmp_path_factory.mktemp("unstick") / "p", high_panel=False)
    c.refined.keep_first(1)
    return c


def test_a_base_pose_in_blocked_cells_is_reached_by_a_short_straight_move(case, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    nav = case.refined.steps[0]  # NV-1 to the pickup location, facing the storage
    assert nav.base_pose is not None
    spec = robot_spec(robot_name(case.refined))
    checker = PoseChecker(case.grid)
    g = nav.base_pose
    # step towards the storage until the map calls the base pose blocked
    goal = next(
        (g.x + d * math.cos(g.yaw), g.y + d * math.sin(g.yaw), g.yaw)
        for d in (k * 0.01 for k in range(1, 60))
        if not checker.free(spec.footprint(), g.x + d * math.cos(g.yaw), g.y + d * math.sin(g.yaw), g.yaw)
    )
    near = nearest_free_pose(checker, goal, [spec.footprint()])
    assert near is not None and math.hypot(near[0] - goal[0], near[1] - goal[1]) <= UNSTICK_RADIUS_M
    nav.base_pose = Pose2(*goal)
    simulate(case.project, case.refined, seed=3, out_dir=tmp_path / "run", world=case.world, grid=case.grid,
             settings=ExecSettings(keyframes=False), workers=[])
    events = [json.loads(line) for line in (tmp_path / "run" / "events.jsonl").read_text().splitlines()]
    first = [e for e in events if e["step"] == 1]
    assert not [e for e in first if e["kind"] == "step_failed"], first
    unstick = [e for e in first if e["kind"] == "unstick"]
    assert unstick and unstick[0]["details"]["at"] == "base pose"
    step = math.hypot(near[0] - goal[0], near[1] - goal[1])
    assert unstick[0]["details"]["distance_m"] == pytest.approx(step, abs=1e-3)
    rows = [line.split(",") for line in (tmp_path / "run" / "trajectories.csv").read_text().splitlines()[1:]]
    last = [r for r in rows if r[12] == "1"][-1]
    assert math.hypot(float(last[1]) - goal[0], float(last[2]) - goal[1]) < 0.01
