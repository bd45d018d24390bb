"""B1-B3 on the case study: 11 frames x 4 actions, inputs from the scenario, a bare model, determinism."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest
from rdflib import Graph, URIRef

from conftest import CASE_STUDY
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.requirements import derive_requirements
from kbplanner.planning.plan_model import Plan
from kbplanner.planning.plan_rdf import plan_graph, plan_turtle
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project

EXPECTED = tomllib.loads((CASE_STUDY / "expected.toml").read_text())


@pytest.fixture(scope="module")
def outside() -> tuple[Project, Plan]:
    project = Project.load(CASE_STUDY, scenario="storage-outside")
    return project, plan_task(project)


@pytest.fixture(scope="module")
def bare() -> tuple[Project, Plan]:
    project = Project.load(CASE_STUDY)
    return project, plan_task(project)


def test_the_outside_storage_plan_has_eleven_frames_times_four_feasible_actions(
        outside: tuple[Project, Plan]) -> None:
    _, plan = outside
    assert (plan.task_id, plan.spec_id, plan.scenario) == ("T-FRAME", "I-W-F-#1", "storage-outside")
    assert len(plan.elements) == EXPECTED["frames"]["count"] == 11
    assert len(plan.steps) == 44 and plan.feasible
    assert [s.step for s in plan.steps] == list(range(1, 45))
    for el in plan.elements:
        steps = plan.steps_for(el.iri)
        assert [(s.action_order, s.skill_id) for s in steps] == [
            (1, "NV-1"), (2, "MM-G-1"), (3, "NV-2"), (4, "MM-R-1")]
        assert steps[0].inputs["destination"][:2] == EXPECTED["scenarios"]["storage-outside"]["pickup"][:2]
        assert steps[1].inputs["grasp point"][:3] == EXPECTED["frames"]["grasp_point_local"]
        assert steps[1].inputs["object"] == el.iri
        assert steps[2].inputs["destination"] == steps[3].inputs["target pose"] == el.installed_pose.as_list()
    assert plan.order_rule  # recorded
    assert len({e.iri for e in plan.elements}) == 11


def test_the_plan_takes_robot_start_elevation_sizes_and_storage_poses_from_the_model(
        outside: tuple[Project, Plan]) -> None:
    _, plan = outside
    assert plan.robot_start is not None
    assert [plan.robot_start.x, plan.robot_start.y] == EXPECTED["site"]["robot_start"]
    assert plan.storey_elevation_m == 0.0
    fr = EXPECTED["frames"]
    for e in plan.elements:
        length, thickness, height = e.size_m
        assert fr["min_length_m"] - 1e-3 <= length <= fr["max_length_m"] + 1e-3
        assert thickness == pytest.approx(fr["thickness_m"], abs=1e-4)
        assert height == pytest.approx(fr["height_m"], abs=1e-4)
        assert e.storage_pose is not None and e.mass_kg is not None
    tops = sorted(e.storage_pose.z for e in plan.elements if e.storage_pose is not None)
    assert tops[-1] - tops[0] == pytest.approx(10 * fr["thickness_m"], abs=1e-4)  # one stack, 11 high


def test_the_robot_is_chosen_by_the_ranking_with_every_robot_and_reason_listed(
        outside: tuple[Project, Plan]) -> None:
    _, plan = outside
    assert (plan.robot_id, plan.robot_urdf) == ("husky-ur16e", "husky_ur16e.urdf")
    by_id = {r["robot_id"]: r for r in plan.selection}
    assert set(by_id) == {"husky-ur16e", "husky-ur5", "jackal", "jackal-marker"}
    assert by_id["husky-ur16e"]["chosen"] and by_id["husky-ur16e"]["rank"] == 1
    assert any("payload 5 kg below" in r for r in by_id["husky-ur5"]["reasons"])  # the paper's robot
    assert not by_id["jackal"]["fit"]


def test_parameters_are_skill_defaults_under_the_jobsite_limits_with_arm_poses_as_joint_lists(
        outside: tuple[Project, Plan]) -> None:
    _, plan = outside
    js = EXPECTED["jobsite"]
    nv1, nv2 = plan.steps[0].parameters, plan.steps[2].parameters
    assert [nv1["minSpeed"], nv1["maxSpeed"]] == js["nv1_speed_mps"]
    assert [nv2["minSpeed"], nv2["maxSpeed"]] == js["nv2_speed_mps"]
    assert nv2["safetyStopDistance"] == js["nv2_stop_distance_m"]
    for s in plan.steps:
        for key in ("armPose", "approachPose"):
            if key in s.parameters:
                assert isinstance(s.parameters[key], list) and len(s.parameters[key]) == 6


def test_the_bare_model_is_planned_with_missing_storage_and_grasp_point_reasons_not_a_crash(
        bare: tuple[Project, Plan]) -> None:
    project, plan = bare
    assert len(plan.steps) == 44 and not plan.feasible
    bad = [s for s in plan.steps if not s.feasible]
    assert {s.action_order for s in bad} == {1, 2}
    assert all("missing input 'grasp point'" in (s.reason or "") for s in bad if s.action_order == 2)
    assert all("has no kbp:storedIn" in (s.reason or "") for s in bad if s.action_order == 1)
    # exactly the unmet requirements (A3) of the same bindings
    reqs = derive_requirements(project.model, project.kb, task_id="T-FRAME").requirements
    unmet = {(r.action_order, str(e.iri)) for r in reqs for e in r.elements}
    assert unmet == {(s.action_order, s.element) for s in bad}
    assert len(reqs) == 2  # T-FRAME's share of the bare model's requirements (NV-1, MM-G-1)
    assert all(e.storage_pose is None for e in plan.elements)


def test_planning_twice_gives_byte_identical_json_and_turtle(outside: tuple[Project, Plan]) -> None:
    project, plan = outside
    again = plan_task(project)
    assert again.to_json() == plan.to_json()
    assert plan_turtle(again, project.kb) == plan_turtle(plan, project.kb)
    assert Plan.from_json(plan.to_json()) == plan


def test_the_plan_graph_links_every_step_to_task_specification_action_skill_element_and_robot(
        outside: tuple[Project, Plan], tmp_path: Path) -> None:
    project, plan = outside
    text = plan_turtle(plan, project.kb)
    g = Graph().parse(data=text, format="turtle")
    assert len(g) == len(plan_graph(plan, project.kb))
    q = """SELECT ?plan (COUNT(DISTINCT ?step) AS ?n) (COUNT(DISTINCT ?element) AS ?elements) WHERE {
      ?plan a kbp:Plan ; kbp:planStep ?step ; kbp:forRobot ?robot ; kbp:feasible true .
      ?step a kbp:PlanStep ; kbp:order ?order ; kbp:forTask ?task ; kbp:forSpecification ?spec ;
            kbp:forAction ?action ; kbp:forSkill ?skill ; kbp:forElement ?element ; kbp:forRobot ?robot ;
            kbp:feasible true .
    } GROUP BY ?plan"""
    rows = list(g.query(q, initNs={"kbp": KBP._NS}))
    assert len(rows) == 1
    assert (int(rows[0][1]), int(rows[0][2])) == (44, 11)  # type: ignore[index]
    assert (None, KBP.forTask, URIRef(plan.task_iri)) in g
    assert (URIRef(plan.task_iri), None, None) in project.model
    poses = list(g.subjects(KBP.x, None))
    assert len(poses) == 44  # per frame: pickup, grasp point, install destination, target pose
    assert "_:" not in text  # no blank nodes
