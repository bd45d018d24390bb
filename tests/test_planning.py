"""B1-B3 planning on small graphs: order, robot ranking, specifications from Turtle, errors, B4 hook."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from rdflib import RDF, Graph, Literal, URIRef

from kb_fixtures import BASE, add_pose, frame_gid, make_model
from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.core.iris import element_iri, mint, task_iri
from kbplanner.core.vocab import BOT, KBP
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.planning.element_order import RULE_GLOBAL_ID, RULE_NEAREST, RULE_SEQUENCE, element_order
from kbplanner.planning.plan_model import Plan, Pose2
from kbplanner.planning.planner import PoseChoice, assign_poses, plan_task
from kbplanner.planning.task_and_robot import PlanningError
from kbplanner.project import Calendar, Manifest, Project
from kbplanner.world.world_types import pose_matrix

TEST = "https://example.org/test-kb#"


def _mesh_from_bounds(model: Graph, el: URIRef) -> trimesh.Trimesh:
    b = model.value(el, KBP.bounds)
    lo = np.array([float(model.value(b, p)) for p in (KBP.minX, KBP.minY, KBP.minZ)])  # type: ignore[arg-type]
    hi = np.array([float(model.value(b, p)) for p in (KBP.maxX, KBP.maxY, KBP.maxZ)])  # type: ignore[arg-type]
    mesh = trimesh.creation.box(extents=hi - lo)
    mesh.apply_translation((lo + hi) / 2)
    return mesh


def small_project(directory: Path, model: Graph, *, kb_extra: tuple[Path, ...] = (),
                  simulation: dict[str, Any] | None = None,
                  meshes: dict[URIRef, trimesh.Trimesh] | None = None) -> Project:
    """A project over an in-memory model: what an import gives (bot:Element, site-frame meshes)."""
    for el, mesh_file in sorted(model.subject_objects(KBP.meshFile)):
        assert isinstance(el, URIRef)
        model.add((el, RDF.type, BOT.Element))
        path = directory / str(mesh_file)
        path.parent.mkdir(parents=True, exist_ok=True)
        mesh = (meshes or {}).get(el) or _mesh_from_bounds(model, el)
        mesh.export(path)
    manifest = Manifest(
        path=directory / "project.toml", name="test-site", description="", base=BASE, seed=0,
        ifc=directory / "model.ifc", schedule=None, schedule_from_ifc=False, site=(), jobsite=(),
        knowledge_base=kb_extra, augmentation=(), calendar=Calendar(), simulation=simulation or {},
        scenarios={})
    return Project(manifest=manifest, scenario=None, model=model, kb=load_kb(list(kb_extra)),
                   import_dir=directory)


def _frames(n: int) -> list[URIRef]:
    return [element_iri(BASE, frame_gid(i)) for i in range(1, n + 1)]


# ---- B1: element order ------------------------------------------------------------------------


def test_the_work_sequence_orders_the_elements_when_it_is_modelled() -> None:
    g = make_model(4, storage=True)
    f = _frames(4)
    for el, seq in zip(f, (3, 1, 4, 2), strict=True):
        g.add((el, KBP.workSequence, Literal(seq)))
    order = element_order(g, task_iri(BASE, "T1"))
    assert order.elements == (f[1], f[3], f[0], f[2])
    assert order.rule == RULE_SEQUENCE


def _restack(g: Graph, top_first: list[URIRef]) -> None:
    for n, el in enumerate(top_first):
        g.set((el, KBP.stackIndex, Literal(len(top_first) - 1 - n)))


def test_without_a_work_sequence_the_install_location_nearest_the_pickup_comes_first() -> None:
    g = make_model(4, storage=True)  # pickup at (-4.2, 3.0); frames at x = 5.5, 6.5, 7.5, 8.5, y = 4.5
    f = _frames(4)
    _restack(g, f)  # the nearest on top: the stack does not change the order
    order = element_order(g, task_iri(BASE, "T1"), robot_start=(20.0, 4.5))
    assert order.elements == tuple(f)  # measured from the pickup, not from the robot start
    assert order.rule == RULE_NEAREST
    assert order.distances_m[f[0]] == pytest.approx(math.hypot(9.7, 1.5), abs=1e-6)


def test_without_a_storage_the_distance_is_from_the_robot_start_and_ties_go_by_global_id() -> None:
    g = make_model(4)
    f = _frames(4)
    order = element_order(g, task_iri(BASE, "T1"), robot_start=(20.0, 4.5))
    assert order.elements == tuple(reversed(f))
    tie = element_order(g, task_iri(BASE, "T1"), robot_start=(7.0, 4.5))  # 1.5 m from frames 2 and 3
    assert tie.elements[:2] == (f[1], f[2])
    assert element_order(g, task_iri(BASE, "T1")).rule == RULE_GLOBAL_ID


def test_elements_with_a_work_sequence_come_first_and_the_rest_by_distance() -> None:
    g = make_model(3, storage=True)
    f = _frames(3)
    _restack(g, [f[2], f[0], f[1]])
    g.add((f[2], KBP.workSequence, Literal(1)))
    order = element_order(g, task_iri(BASE, "T1"))
    assert order.elements == (f[2], f[0], f[1])
    assert order.rule.startswith(RULE_SEQUENCE) and RULE_NEAREST in order.rule


# ---- B1-B3: plans of small projects ----------------------------------------------------------


def test_a_complete_small_model_gives_one_step_per_element_and_action_with_inputs_and_parameters(
        tmp_path: Path) -> None:
    g = make_model(3, storage=True, grasp_points=True, jobsite=True)
    plan = plan_task(small_project(tmp_path, g))
    assert [(s.step, s.action_order, s.skill_id) for s in plan.steps[:4]] == [
        (1, 1, "NV-1"), (2, 2, "MM-G-1"), (3, 3, "NV-2"), (4, 4, "MM-R-1")]
    assert len(plan.steps) == 12 and plan.feasible
    # frame 1 is nearest but lies at the bottom of the stack (stackIndex 0): top of the stack first
    assert [s.element for s in plan.steps[::4]] == [str(e) for e in reversed(_frames(3))]
    assert plan.steps[1].inputs == {"grasp point": [0.0, 0.0, 1.2, 0.0, 0.0, 0.0],
                                    "object": str(_frames(3)[2])}
    nv2 = plan.steps[2].parameters
    assert (nv2["maxSpeed"], nv2["minSpeed"]) == (0.3, 0.1)  # the limit caps the 0.3 default, sets the min.
    assert nv2["safetyStopDistance"] == 1.0  # skill default above the site minimum 0.8
    assert plan.steps[0].parameters["safetyStopDistance"] == 0.8  # site minimum above the 0.5 default
    assert plan.steps[0].parameters["armPose"] == [0.0, -2.9, 2.7, -1.4, -1.5708, 0.0]
    assert all(s.base_pose is None and s.arm_poses == {} for s in plan.steps)  # B4 fills them
    e = plan.elements[0]
    assert e.size_m == pytest.approx((0.6, 0.1, 2.4))
    assert e.mass_kg == 4.5 and e.storage_pose is not None
    assert plan.task_iri == str(task_iri(BASE, "T1")) and plan.spec_id == "I-W-F-#1"


def test_the_bare_small_model_is_planned_with_every_missing_input_as_a_reason(tmp_path: Path) -> None:
    plan = plan_task(small_project(tmp_path, make_model(2)))
    assert len(plan.steps) == 8
    bad = {(s.action_order, s.element) for s in plan.steps if not s.feasible}
    assert bad == {(o, str(e)) for o in (1, 2) for e in _frames(2)}
    grasp = [s.reason for s in plan.steps if s.action_order == 2]
    assert all(r is not None and "missing input 'grasp point'" in r for r in grasp)
    assert all(e.storage_pose is None for e in plan.elements)


def test_element_sizes_come_from_the_mesh_seen_from_the_installed_pose(tmp_path: Path) -> None:
    g = make_model(1, storage=True, grasp_points=True)
    el = _frames(1)[0]
    pose = g.value(el, KBP.installedPose)
    g.set((pose, KBP.yaw, Literal(math.pi / 2)))  # type: ignore[arg-type]
    box = trimesh.creation.box(extents=(0.7, 0.09, 2.4))
    box.apply_translation((0.0, 0.0, 1.2))
    from kbplanner.model.ifc_geometry import Pose

    box.apply_transform(pose_matrix(Pose(5.5, 4.5, 0.0, 0.0, 0.0, math.pi / 2)))  # site frame, turned
    plan = plan_task(small_project(tmp_path, g, meshes={el: box}))
    assert plan.elements[0].size_m == pytest.approx((0.7, 0.09, 2.4), abs=1e-6)


def test_robots_are_ranked_fit_first_then_smallest_footprint_then_payload_margin(tmp_path: Path) -> None:
    plan = plan_task(small_project(tmp_path, make_model(2, storage=True, grasp_points=True)))
    ranks = [(r["robot_id"], r["fit"], r["chosen"]) for r in plan.selection]
    # both Huskies fit with the same footprint: the UR16e has the larger payload margin over 4.5 kg
    assert ranks == [("husky-ur16e", True, True), ("husky-ur5", True, False), ("jackal", False, False),
                     ("jackal-marker", False, False)]
    assert plan.robot_id == "husky-ur16e" and plan.robot_urdf == "husky_ur16e.urdf"
    assert plan.selection[1]["payload_margin_kg"] == pytest.approx(0.5)
    assert plan.selection[2]["reasons"]


def test_when_no_robot_fits_the_plan_is_made_with_every_step_infeasible_and_the_reasons(
        tmp_path: Path) -> None:
    g = make_model(2, storage=True, grasp_points=True, frame_mass=20.0)
    plan = plan_task(small_project(tmp_path, g))
    assert plan.robot_id == "" and plan.robot_urdf == ""
    assert len(plan.steps) == 8 and not any(s.feasible for s in plan.steps)
    assert all(s.reason and s.reason.startswith("no robot of the knowledge base fits")
               and "payload 16 kg below" in s.reason for s in plan.steps)
    assert [r["fit"] for r in plan.selection] == [False, False, False, False]


def test_a_given_robot_that_does_not_fit_makes_every_step_infeasible_with_its_reasons(tmp_path: Path) -> None:
    project = small_project(tmp_path, make_model(2, storage=True, grasp_points=True))
    plan = plan_task(project, robot_id="jackal")
    assert plan.robot_id == "jackal"
    assert all(not s.feasible and "missing capability" in (s.reason or "") for s in plan.steps)
    assert next(r for r in plan.selection if r["robot_id"] == "jackal")["chosen"]


def _screw_spec(tmp_path: Path) -> Path:
    ttl = f"""@prefix kbp: <https://w3id.org/kbplanner/ontology#> .
@prefix kb: <https://w3id.org/kbplanner/kb#> .
@prefix owl: <http://www.w3.org/2002/07/owl#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix t: <{TEST}> .

t:screwPoint a owl:ObjectProperty ; rdfs:range kbp:Pose ; rdfs:label "screw point" .
t:torque a owl:DatatypeProperty ; rdfs:label "torque (N m)" .

t:SC-1 a kbp:Skill ; kbp:skillId "SC-1" ; rdfs:label "screw" ; kbp:skillKind kbp:Fasten ;
    kbp:hasInput t:SC-1-point , t:SC-1-object ; kbp:hasParameter t:SC-1-torque ;
    kbp:requiresCapability kbp:Manipulation6DoF .
t:SC-1-point a kbp:SkillInput ; kbp:inputName "screw point" ; kbp:valueClass kbp:Pose ;
    kbp:inputSource kbp:FromModel ; kbp:inputRole kbp:TargetPoseRole .
t:SC-1-object a kbp:SkillInput ; kbp:inputName "element" ; kbp:valueClass kbp:Element ;
    kbp:inputSource kbp:FromTaskElement ; kbp:inputRole kbp:WorkElementRole .
t:SC-1-torque a kbp:SkillParameter ; kbp:parameterKind t:torque ; kbp:defaultValue 5.0 ; kbp:unit "N m" .

t:S a kbp:TaskSpecification ; kbp:specificationId "SCREW-#1" ; rdfs:label "fasten frames" ;
    kbp:hasAction t:S-a1 , t:S-a2 , t:S-a3 .
t:S-a1 a kbp:Action ; kbp:order 1 ; rdfs:label "drive to the frame" ; kbp:usesSkill kb:NV-1 ;
    kbp:hasBinding t:S-a1-dest .
t:S-a1-dest a kbp:InputBinding ; kbp:bindsInput kb:NV-1-destination ; kbp:bindingPath kbp:installedPose .
t:S-a2 a kbp:Action ; kbp:order 2 ; rdfs:label "screw the top" ; kbp:usesSkill t:SC-1 ;
    kbp:hasBinding t:S-a2-point ; kbp:hasSetting t:S-a2-torque .
t:S-a2-point a kbp:InputBinding ; kbp:bindsInput t:SC-1-point ; kbp:bindingPath t:screwPoint .
t:S-a2-torque a kbp:ParameterSetting ; kbp:setsParameter t:SC-1-torque ; kbp:value 8.0 .
t:S-a3 a kbp:Action ; kbp:order 3 ; rdfs:label "screw the bottom" ; kbp:usesSkill t:SC-1 ;
    kbp:hasBinding t:S-a3-point .
t:S-a3-point a kbp:InputBinding ; kbp:bindsInput t:SC-1-point ; kbp:bindingPath t:screwPoint .
"""
    path = tmp_path / "screw.ttl"
    path.write_text(ttl)
    return path


def test_a_specification_written_only_in_a_test_turtle_file_gives_a_different_plan(tmp_path: Path) -> None:
    g = make_model(2, spec_id="SCREW-#1")
    for i, el in enumerate(_frames(2)):
        g.add((el, URIRef(TEST + "screwPoint"), add_pose(g, mint(BASE, "pose", f"screw-{i}"), 0.0, 0.0, 2.0)))
    plan = plan_task(small_project(tmp_path, g, kb_extra=(_screw_spec(tmp_path),)))
    assert plan.spec_id == "SCREW-#1" and len(plan.steps) == 6 and plan.feasible
    assert [(s.action_label, s.skill_id) for s in plan.steps[:3]] == [
        ("drive to the frame", "NV-1"), ("screw the top", "SC-1"), ("screw the bottom", "SC-1")]
    assert plan.steps[1].skill_kind == str(KBP.Fasten)
    assert plan.steps[1].roles == {"TargetPoseRole": "screw point", "WorkElementRole": "element"}
    assert plan.steps[1].inputs == {"element": str(_frames(2)[0]),
                                    "screw point": [0.0, 0.0, 2.0, 0.0, 0.0, 0.0]}
    assert (plan.steps[1].parameters, plan.steps[2].parameters) == ({"torque": 8.0}, {"torque": 5.0})
    # no gripping needed: the Jackal lacks the arm, the Husky + UR5 is fine with any frame mass
    assert plan.robot_id == "husky-ur16e"


def test_an_unknown_specification_id_is_a_clear_error_naming_the_known_ids(tmp_path: Path) -> None:
    project = small_project(tmp_path, make_model(1, spec_id="NOPE-#9"))
    with pytest.raises(KnowledgeBaseError) as err:
        plan_task(project)
    assert "NOPE-#9" in str(err.value) and "I-W-F-#1" in str(err.value) and "T1" in str(err.value)


def test_an_unknown_task_or_robot_is_a_clear_error_listing_the_known_ids(tmp_path: Path) -> None:
    project = small_project(tmp_path, make_model(1, storage=True, grasp_points=True))
    with pytest.raises(PlanningError, match=r"no robotized task with id 'T0'[\s\S]*robotized tasks: T1"):
        plan_task(project, "T0")
    with pytest.raises(PlanningError, match=r"unknown robot 'ur5'[\s\S]*husky-ur16e, husky-ur5, jackal"):
        plan_task(project, robot_id="ur5")


def test_the_manifest_task_is_the_default_and_several_robotized_tasks_need_a_choice(tmp_path: Path) -> None:
    g = make_model(1, storage=True, grasp_points=True)
    from kb_fixtures import add_task

    add_task(g, "T2", "More frames", [_frames(1)[0]], robotized=True, spec_id="I-W-F-#2")
    with pytest.raises(PlanningError, match="several robotized tasks"):
        plan_task(small_project(tmp_path, g))
    plan = plan_task(small_project(tmp_path, g, simulation={"task": "T2"}))
    assert (plan.task_id, plan.spec_id) == ("T2", "I-W-F-#2")
    assert plan.steps[2].parameters["armPose"][5] == pytest.approx(1.5708)  # carried on its side


def test_assign_poses_fills_a_copy_and_can_mark_a_step_infeasible(tmp_path: Path) -> None:
    plan = plan_task(small_project(tmp_path, make_model(1, storage=True, grasp_points=True)))

    def b4(p: Plan, step: Any) -> PoseChoice | None:
        if step.skill_id == "MM-G-1":
            return PoseChoice(base_pose=Pose2(-4.2, 3.0, math.pi), arm_poses={"final": [0.0] * 6})
        if step.skill_id == "MM-R-1":
            return PoseChoice(feasible=False, reason="no IK solution within reach")
        return None

    filled = assign_poses(plan, b4)
    assert plan.steps[1].base_pose is None and plan.feasible  # the input plan is unchanged
    assert filled.steps[1].base_pose == Pose2(-4.2, 3.0, math.pi)
    assert filled.steps[1].arm_poses == {"final": [0.0] * 6}
    assert (filled.steps[3].feasible, filled.steps[3].reason) == (False, "no IK solution within reach")
    assert Plan.from_json(filled.to_json()) == filled


def test_a_robotized_task_without_elements_gives_an_empty_plan_with_a_note(tmp_path: Path) -> None:
    g = make_model(0)
    plan = plan_task(small_project(tmp_path, g))
    assert plan.steps == [] and plan.elements == []
    assert any("builds no elements" in n for n in plan.notes)


@pytest.mark.parametrize(("old", "new", "words"), [
    ("kbp:skillKind kbp:Fasten", "kbp:skillKind t:Screwing",
     ["skill SC-1 has kind t:Screwing, which the executor does not implement",
      "kbp:Fasten, kbp:FollowToolPath", "kbp:Inspect"]),
    ("kbp:inputRole kbp:TargetPoseRole", "kbp:inputRole kbp:ToolPathRole",
     ["input 'screw point' of skill SC-1 has role kbp:ToolPathRole", "cannot use",
      "kbp:ContactForceRole, kbp:DwellTimeRole"]),
    ("kbp:inputRole kbp:TargetPoseRole", "",
     ["input 'screw point' of skill SC-1 has no kbp:inputRole", "kbp:TargetPoseRole"]),
])
def test_a_kind_outside_the_set_or_an_unusable_role_is_an_error_before_planning(
        tmp_path: Path, old: str, new: str, words: list[str]) -> None:
    spec = _screw_spec(tmp_path)
    kind = "t:Screwing a kbp:SkillKind .\n"
    spec.write_text(spec.read_text().replace(old, new).replace("t:torque a owl:", kind + "t:torque a owl:"))
    g = make_model(2, spec_id="SCREW-#1")
    with pytest.raises(KnowledgeBaseError) as err:
        plan_task(small_project(tmp_path, g, kb_extra=(spec,)))
    text = str(err.value)
    assert "screw.ttl" in text and "fix:" in text
    for w in words:
        assert w in text
