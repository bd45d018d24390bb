"""B4 on the small test project: arm poses come from IK and do what they claim, base poses are free,
carry footprints follow from forward kinematics, problems become infeasible steps with reasons."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator

import numpy as np
import pytest

from kbplanner.planning.base_poses import PoseChecker, escapes
from kbplanner.planning.carry import NARROW, NORMAL, geometry_from_joints, transform
from kbplanner.planning.manipulation import (
    KIND_GRASP,
    KIND_NAVIGATION,
    KIND_NAVIGATION_WITH_OBJECT,
    KIND_RELEASE,
    refine_plan,
    robot_name,
)
from kbplanner.planning.plan_model import Plan, Pose2, SkillCall
from kbplanner.planning.pose_frames import target_variants, tool_frame
from kbplanner.robot.robot_model import RobotModel
from kbplanner.simulation.sim_env import angle_between
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid
from sim_project_factory import SimCase, load_sim_case

SEED = 3


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory) -> SimCase:
    return load_sim_case(tmp_path_factory.mktemp("simproj"), seed=SEED)


@pytest.fixture(scope="module")
def robot(case: SimCase) -> Iterator[RobotModel]:
    model = RobotModel.load(robot_name(case.refined))
    yield model
    model.close()


def _steps(plan: Plan, label: str) -> dict[str, SkillCall]:
    iri = next(e.iri for e in plan.elements if e.label == label)
    return {s.skill_kind: s for s in plan.steps_for(iri)}


def test_every_step_of_a_reachable_panel_gets_base_and_arm_poses(case: SimCase) -> None:
    steps = _steps(case.refined, "Panel P1")
    nv1, pick, nv2, place = (steps[k] for k in (KIND_NAVIGATION, KIND_GRASP, KIND_NAVIGATION_WITH_OBJECT,
                                                 KIND_RELEASE))
    assert all(s.feasible for s in (nv1, pick, nv2, place))
    assert nv1.base_pose == pick.base_pose  # NV-1 drives to the pick pose
    assert nv2.base_pose == place.base_pose
    assert set(pick.arm_poses) == {"initial", "approach", "pre_grasp", "grasp", "lift", "final"}
    assert set(nv2.arm_poses) == {"initial", "carry_normal", "carry_narrow", "final"}
    assert set(place.arm_poses) == {"initial", "orient", "pre_place", "place", "retract", "final"}
    assert any("base pose" in n for n in pick.notes)
    assert any("base pose: sampled" in n for n in place.notes)


def test_grasp_and_place_joints_put_tool_and_element_where_the_model_says(case: SimCase,
                                                                          robot: RobotModel) -> None:
    steps = _steps(case.refined, "Panel P1")
    pick, place = steps[KIND_GRASP], steps[KIND_RELEASE]
    we = case.world.element(pick.element)
    assert we is not None and we.pose is not None and we.installed_pose is not None
    assert we.local_bounds is not None
    stored = transform(we.pose.x, we.pose.y, we.pose.z, we.pose.roll, we.pose.pitch, we.pose.yaw)
    b = pick.base_pose
    robot.set_base_pose(b.x, b.y, b.yaw)
    tool = tool_frame(robot, pick.arm_poses["grasp"])
    grasp_point = (stored @ np.array([*we.local_bounds.center, 1.0]))[:3]
    assert float(np.linalg.norm(tool[:3, 3] - grasp_point)) < 0.01  # IK tolerance: 1 cm
    tie = np.linalg.inv(stored) @ tool
    b = place.base_pose
    robot.set_base_pose(b.x, b.y, b.yaw)
    element = tool_frame(robot, place.arm_poses["place"]) @ np.linalg.inv(tie)
    ip = we.installed_pose
    goal = transform(ip.x, ip.y, ip.z, ip.roll, ip.pitch, ip.yaw)
    best = min((float(np.linalg.norm(element[:3, 3] - g[:3, 3])), math.degrees(angle_between(element, g)))
               for _, g in target_variants(we.local_bounds, goal))
    assert best[0] < 0.006 and best[1] < 1.1  # the place pose is solved to 5 mm and 1 degree


def test_base_poses_are_free_for_the_base_and_a_carry_footprint(case: SimCase, robot: RobotModel) -> None:
    steps = _steps(case.refined, "Panel P1")
    checker = PoseChecker(case.grid)
    fp = robot.spec.footprint()
    for kind in (KIND_GRASP, KIND_RELEASE):
        b = steps[kind].base_pose
        assert checker.free(fp, b.x, b.y, b.yaw)
    # carry footprints by forward kinematics: the panel flat across the robot, or on its side along it
    pick, nv2 = steps[KIND_GRASP], steps[KIND_NAVIGATION_WITH_OBJECT]
    we = case.world.element(pick.element)
    assert we is not None and we.pose is not None and we.local_bounds is not None
    b = pick.base_pose
    robot.set_base_pose(b.x, b.y, b.yaw)
    stored = transform(we.pose.x, we.pose.y, we.pose.z, we.pose.roll, we.pose.pitch, we.pose.yaw)
    tie = np.linalg.inv(stored) @ tool_frame(robot, pick.arm_poses["grasp"])
    geo = geometry_from_joints(robot, we.local_bounds, tie, nv2.arm_poses["carry_normal"],
                               nv2.arm_poses["carry_narrow"])
    normal, narrow = geo.mode(NORMAL).rect, geo.mode(NARROW).rect
    assert normal.width == pytest.approx(2.4, abs=0.05) and normal.length == pytest.approx(0.6, abs=0.1)
    assert narrow.length == pytest.approx(2.4, abs=0.05) and narrow.width < 0.15
    assert any(checker.free(geo.footprint(m), b.x, b.y, b.yaw) for m in (NORMAL, NARROW))
    # the element rests above the robot's top plate in both modes
    for m in (NORMAL, NARROW):
        corners = np.c_[we.local_bounds.corners(), np.ones(8)] @ geo.mode(m).element_in_base.T
        assert corners[:, 2].min() > robot.spec.base.height_m


def test_the_arm_poses_are_solved_per_element_not_taken_from_a_table(case: SimCase,
                                                                      robot: RobotModel) -> None:
    p1, p2 = _steps(case.refined, "Panel P1"), _steps(case.refined, "Panel P2")
    assert p1[KIND_RELEASE].arm_poses["place"] != p2[KIND_RELEASE].arm_poses["place"]
    named = [list(q) for q in robot.spec.poses.values()]
    for steps in (p1, p2):
        for key in ("grasp", "lift"):
            assert steps[KIND_GRASP].arm_poses[key] not in named


def test_refining_twice_with_one_seed_gives_the_same_plan(case: SimCase) -> None:
    again = refine_plan(case.plan, case.world, seed=SEED, grid=case.grid)
    assert again.to_json() == case.refined.to_json()
    assert case.plan.steps[1].arm_poses == {}  # the input plan is not changed


def test_a_panel_under_others_still_at_the_storage_cannot_be_picked(case: SimCase) -> None:
    top = case.plan.steps[0].element  # P1, on top of the stack: do it last
    steps = [s for s in case.plan.steps if s.element != top]
    steps += [s for s in case.plan.steps if s.element == top]
    swapped = dataclasses.replace(case.plan, steps=[dataclasses.replace(s, step=n)
                                                    for n, s in enumerate(steps, start=1)])
    refined = refine_plan(swapped, case.world, seed=SEED, grid=case.grid)
    p2_pick = _steps(refined, "Panel P2")[KIND_GRASP]
    assert not p2_pick.feasible
    assert "lies under 1 element(s)" in (p2_pick.reason or "")
    assert "kbp:workSequence" in (p2_pick.reason or "")


def test_a_too_heavy_panel_is_infeasible_with_the_payload_and_the_next_steps_skipped(case: SimCase) -> None:
    heavy = [dataclasses.replace(e, mass_kg=30.0) if e.label == "Panel P1" else e for e in case.plan.elements]
    plan = dataclasses.replace(case.plan, elements=heavy)
    refined = refine_plan(plan, case.world, seed=SEED, grid=case.grid)
    steps = _steps(refined, "Panel P1")
    assert "payload of 16 kg" in (steps[KIND_GRASP].reason or "")
    assert (steps[KIND_RELEASE].reason or "").startswith("skipped: step")


def test_pose_checker_agrees_with_the_navigation_configuration_space() -> None:
    rng = np.random.default_rng(5)
    occ = rng.random((60, 80)) < 0.004
    grid = OccupancyGrid(occ, origin=(-1.0, 2.0), resolution=0.05)
    fp = Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(0.1, 0.2, 0.3, 1.5, 0.3)))
    cs = ConfigurationSpace.build(grid, fp)
    checker = PoseChecker(grid)
    poses = np.c_[rng.uniform(-1.0, 3.0, 2000), rng.uniform(2.0, 5.0, 2000), rng.uniform(-4.0, 4.0, 2000)]
    ours = [checker.free(fp, *p) for p in poses.tolist()]
    theirs = cs.is_free_many(poses).tolist()
    assert ours == theirs
    assert 0.05 < np.mean(ours) < 0.95  # both answers occur


def test_a_robot_in_a_closed_room_does_not_escape_and_one_with_a_door_does() -> None:
    occ = np.zeros((240, 240), dtype=bool)  # 12 x 12 m, a 3 x 3 m room in the middle
    occ[90:150, [90, 149]] = True
    occ[[90, 149], 90:150] = True
    fp = Footprint((Rect(0.0, 0.0, 0.99, 0.67),))
    inside = Pose2(6.0, 6.0, 0.0)
    assert not escapes(OccupancyGrid(occ, (0.0, 0.0), 0.05), fp, inside)
    occ[149, 110:130] = False  # a 1.0 m door in the north wall
    assert escapes(OccupancyGrid(occ, (0.0, 0.0), 0.05), fp, inside)
