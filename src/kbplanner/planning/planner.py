# Over 500 lines: B1-B3 of one task in one place (task, robot, parameters, elements, steps); next to split.
"""B1-B3, the action-level plan: a robotized task broken into skill calls for one robot.

Takes a loaded :class:`~kbplanner.model.project_data.ProjectData` (one scenario), a robotized task id and
optionally
a robot id; returns a :class:`~kbplanner.planning.plan_model.Plan`. Every action, input and coordinate comes
from the graphs; nothing about the case study is written here.


- **A1** the task's specification id -> :func:`kbplanner.knowledge.task_specs.task_specification` (an
unknown id
  raises :class:`~kbplanner.core.errors.KnowledgeBaseError` naming it and the known ids).
- **B1** its actions in ``kbp:order``; the task's elements in work order
  (:mod:`kbplanner.planning.element_order`, the rule used is ``Plan.order_rule``); one
  :class:`~kbplanner.planning.plan_model.SkillCall` per (element, action).
- **B2** inputs: every binding's value fetched by SPARQL generated from its SHACL path
  (:mod:`kbplanner.planning.skill_inputs`); inputs whose source is the task's element get the element's IRI;
  inputs the robot or the world supplies at run time (initial pose, map, scan) are listed in the plan
  notes, not in the steps. Parameters: skill default < action setting < jobsite parameter
  (:func:`kbplanner.knowledge.jobsite.action_parameters`), keyed by the parameter kind's local name; named arm
  poses (``kbp:ArmPose`` with ``kbp:jointAngles``) become joint lists (rad).
- **B3** robot: :func:`kbplanner.knowledge.robot_selection.select_robots` assesses every robot. Ranking
  (``Plan.selection`` lists all, with rank and reasons): robots that fit first; among them the
  smallest footprint (length x width: the easiest through doors and past people), then the largest
  payload margin over the heaviest element, then the label. The first fitting robot is chosen, or
  the one given. When none fits (or the given robot does not), the plan is still made, with
  ``robot_id`` ``""`` (or the given robot) and every step infeasible with the selection's reasons.
- Elements: size = extents of the element mesh in its own (installed-pose) frame; storage pose =
  where :func:`kbplanner.world.build.build_world` places the element at its storage (``None`` when it cannot
  be placed, e.g. no ``kbp:storedIn``); robot start and the task storey's elevation from the world.

Several tasks: :func:`plan_tasks` (default every robotized task) reads the building once
(:func:`kbplanner.world.tables.world_tables`) and gives the plans :func:`plan_task` gives for each task.

B4 (base poses, IK arm poses) is not done here: ``base_pose`` and ``arm_poses`` stay empty and
:func:`assign_poses` lets the B4 code fill them in a copy of the plan.
"""

from __future__ import annotations

import copy
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import datetime

import numpy as np
import trimesh
from rdflib import RDF, RDFS, Graph, Literal, URIRef
from rdflib.collection import Collection
from rdflib.term import Node

from kbplanner.core.errors import KbplannerError, KnowledgeBaseError, ProjectError
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.jobsite import ActionParameters, action_parameters, jobsite_parameters
from kbplanner.knowledge.knowledge_base import curie, select, source_of
from kbplanner.knowledge.robot_selection import RobotAssessment, RobotSelection, select_robots
from kbplanner.knowledge.task_specs import (
    Action,
    RobotizedTask,
    TaskSpecification,
    robotized_tasks,
    task_specification,
)
from kbplanner.model.dates import parse_date
from kbplanner.model.ifc_geometry import Pose
from kbplanner.model.project_data import ProjectData
from kbplanner.planning.element_order import element_order
from kbplanner.planning.plan_model import ElementInfo, JsonValue, Plan, Pose2, Pose6, SkillCall
from kbplanner.planning.skill_inputs import resolve_inputs
from kbplanner.world.build import build_world
from kbplanner.world.meshes import load_mesh
from kbplanner.world.tables import WorldTables, world_tables
from kbplanner.world.world_types import World, pose_matrix

log = logging.getLogger(__name__)

FALLBACK_DATE = datetime(1970, 1, 1)  # world date when neither the caller, the manifest nor the task has one


class PlanningError(KbplannerError):
    """The plan cannot be made: unknown task or robot, no task chosen, a world of another task."""


# --------------------------------------------------------------------------------------------
# Task and robot
# --------------------------------------------------------------------------------------------


def resolve_task(project: ProjectData, task_id: str | None = None) -> RobotizedTask:
    """The robotized task ``task_id``; default ``[simulation] task`` of the manifest, else the only one.

    Raises:
        PlanningError: the id is not a robotized task (the message lists them), or there are several
            and none is chosen.
    """
    tasks = robotized_tasks(project.model)
    known = ", ".join(t.task_id for t in tasks) or "none"
    if task_id is None:
        default = project.manifest.simulation.get("task")
        if default is not None:
            task_id = str(default)
        elif len(tasks) == 1:
            return tasks[0]
        else:
            what = "no robotized task" if not tasks else "several robotized tasks"
            raise PlanningError(
                f"no task chosen: the model has {what} and project.toml has no [simulation] task",
                file=project.manifest.path,
                element=known, fix="give --task ID (robotized tasks: " + known + ") or mark a task robotized "
                                   "with a kbp:taskSpecificationId in the schedule")
    match = [t for t in tasks if t.task_id == task_id]
    if not match:
        raise PlanningError(f"no robotized task with id {task_id!r}", file=project.manifest.path,
                            element=task_id, fix=f"choose one of the robotized tasks: {known}")
    return match[0]


def robot_id_from_iri(iri: str) -> str:
    """The short id of a robot of the knowledge base: its IRI's local name (``husky-ur5``).

    Example:
        >>> robot_id_from_iri("https://w3id.org/kbplanner/kb#husky-ur5")
        'husky-ur5'
    """
    return iri.rsplit("#", 1)[-1].rsplit("/", 1)[-1]


def _footprint_m2(a: RobotAssessment) -> float:
    return round(a.robot.length_m * a.robot.width_m, 6)


def _payload_margin(a: RobotAssessment, sel: RobotSelection) -> float | None:
    if a.robot.payload_kg is None:
        return None
    heaviest = sel.heaviest[0] if sel.heaviest is not None else 0.0
    return round(a.robot.payload_kg - heaviest, 6)


def rank_robots(sel: RobotSelection) -> list[RobotAssessment]:
    """Robots in choice order: fit first, then smallest footprint, largest payload margin, label."""
    def key(a: RobotAssessment) -> tuple[bool, float, float, str, str]:
        margin = _payload_margin(a, sel)
        return (not a.fit, _footprint_m2(a), -(margin if margin is not None else -1e9), a.robot.label,
                str(a.robot.iri))

    return sorted(sel.assessments, key=key)


def _failed(a: RobotAssessment) -> str:
    return ", ".join(c.message for c in a.reasons)


def _choose_robot(sel: RobotSelection, wanted: str | None) -> tuple[RobotAssessment | None, list[str],
                                                                     list[dict[str, JsonValue]]]:
    ranked = rank_robots(sel)
    chosen: RobotAssessment | None = None
    reasons: list[str] = []
    if wanted is not None:
        match = [a for a in ranked
                 if wanted in (robot_id_from_iri(str(a.robot.iri)), str(a.robot.iri), a.robot.label)]
        if not match:
            known = ", ".join(sorted(robot_id_from_iri(str(a.robot.iri)) for a in ranked)) or "none"
            raise PlanningError(f"unknown robot {wanted!r}", element=wanted,
                                fix=f"choose one of the robots of the knowledge base: {known}")
        chosen = match[0]
        if not chosen.fit:
            reasons.append(f"robot {chosen.robot.label} does not fit the task: {_failed(chosen)}")
    else:
        chosen = next((a for a in ranked if a.fit), None)
        if chosen is None:
            reasons.append("no robot of the knowledge base fits the task: "
                           + "; ".join(f"{a.robot.label}: {_failed(a)}" for a in ranked))
    table: list[dict[str, JsonValue]] = []
    for rank, a in enumerate(ranked, start=1):
        table.append({
            "rank": rank,
            "robot_id": robot_id_from_iri(str(a.robot.iri)),
            "iri": str(a.robot.iri),
            "label": a.robot.label,
            "urdf": a.robot.urdf,
            "fit": a.fit,
            "chosen": chosen is not None and a.robot.iri == chosen.robot.iri,
            "footprint_m2": _footprint_m2(a),
            "payload_margin_kg": _payload_margin(a, sel),
            "reasons": [c.message for c in a.reasons],
            "checks": [{"check": c.check, "ok": c.ok, "message": c.message} for c in a.checks],
        })
    return chosen, reasons, table


# --------------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------------


def arm_pose_joints(kb: Graph, pose: URIRef) -> list[float] | None:
    """Joint angles (rad) of a named arm pose (``kbp:ArmPose`` with an RDF list ``kbp:jointAngles``).

    None when ``pose`` is not a ``kbp:ArmPose``. A malformed pose raises KnowledgeBaseError.

    Example:
        >>> from kbplanner.knowledge.knowledge_base import KB, load_kb
        >>> arm_pose_joints(load_kb(), KB["pose-navigate"])[:3]
        [0.0, -2.9, 2.7]
    """
    if (pose, RDF.type, KBP.ArmPose) not in kb:
        return None
    lst = kb.value(pose, KBP.jointAngles)
    values: list[Node] = list(Collection(kb, lst)) if lst is not None else []
    joints: list[float] = []
    for v in values:
        py = v.toPython() if isinstance(v, Literal) else None
        if isinstance(py, bool) or not isinstance(py, int | float):
            try:
                joints.append(float(py))  # type: ignore[arg-type]
                continue
            except (TypeError, ValueError):
                joints = []
                break
        joints.append(float(py))
    if not joints:
        raise KnowledgeBaseError("named arm pose has no joint angles", file=source_of(kb, pose),
                                 element=curie(kb, pose),
                                 fix="give it kbp:jointAngles ( 0.0 -1.5 1.3 -1.37 -1.5708 0.0 ) in radians")
    return joints


def _parameters(kb: Graph, ap: ActionParameters, spec_id: str) -> dict[str, JsonValue]:
    out: dict[str, JsonValue] = {}
    for p in ap.parameters:
        v = p.value
        if isinstance(v, URIRef):
            joints = arm_pose_joints(kb, v)
            if joints is None and kb.value(p.kind, RDFS.range) == KBP.ArmPose:
                raise KnowledgeBaseError(
                    f"parameter {curie(kb, p.kind)} of action {ap.action.order} of {spec_id} is "
                    f"{curie(kb, v)}, which is not a kbp:ArmPose (set by {p.source})",
                    file=source_of(kb, ap.action.iri), element=curie(kb, ap.action.iri),
                    fix="name a kbp:ArmPose with kbp:jointAngles (e.g. kb:pose-navigate)")
            out[p.name] = joints if joints is not None else str(v)
        else:
            out[p.name] = v
    return out


# --------------------------------------------------------------------------------------------
# Elements
# --------------------------------------------------------------------------------------------


def _f(v: Node | None) -> float | None:
    if isinstance(v, Literal):
        try:
            return float(v.toPython())
        except (TypeError, ValueError):
            return None
    return None


def local_size(project: ProjectData, mesh_file: str, installed: Pose6) -> tuple[float, float, float]:
    """Extents (m) of an element's mesh along its own x, y, z: the mesh moved into its installed frame.

    Raises:
        InputFileError: the mesh file is missing or unreadable.
    """
    mesh = load_mesh(project.mesh_path(mesh_file))
    pose = Pose(installed.x, installed.y, installed.z, installed.roll, installed.pitch, installed.yaw)
    pts = trimesh.transform_points(np.asarray(mesh.vertices, dtype=np.float64),
                                   np.linalg.inv(pose_matrix(pose)))
    if len(pts) == 0:
        return (0.0, 0.0, 0.0)
    ext = pts.max(axis=0) - pts.min(axis=0)
    return (round(float(ext[0]), 6) + 0.0, round(float(ext[1]), 6) + 0.0, round(float(ext[2]), 6) + 0.0)


def _pose6(p: Pose) -> Pose6:
    return Pose6(p.x, p.y, p.z, p.roll, p.pitch, p.yaw)


def _elements(project: ProjectData, task: RobotizedTask, order: tuple[URIRef, ...], world: World,
              notes: list[str]) -> list[ElementInfo]:
    rows: dict[URIRef, dict[str, Node | None]] = {}
    for r in select(project.model, "plan_element_info", task=task.iri):
        el = r["element"]
        if isinstance(el, URIRef):
            rows.setdefault(el, r)
    at_storage = {e.iri: e for e in world.task_elements}
    out: list[ElementInfo] = []
    no_pose: list[str] = []
    no_mesh: list[str] = []
    for el in order:
        r = rows[el]
        gid = str(r["globalId"]) if r["globalId"] is not None else curie(project.model, el)
        nums = [_f(r[k]) for k in ("x", "y", "z")]
        angles = [_f(r[k]) or 0.0 for k in ("roll", "pitch", "yaw")]
        if any(v is None for v in nums):
            no_pose.append(gid)
            installed = Pose6(0.0, 0.0, 0.0)
        else:
            installed = Pose6(*(float(v or 0.0) for v in nums), *angles)
        mesh_file = str(r["meshFile"]) if r["meshFile"] is not None else None
        size = (0.0, 0.0, 0.0)
        if mesh_file is not None:
            size = local_size(project, mesh_file, installed)
        else:
            no_mesh.append(gid)
        placed = at_storage.get(str(el))
        out.append(ElementInfo(
            iri=str(el), global_id=gid, label=str(r["label"]) if r["label"] is not None else gid,
            mass_kg=_f(r["mass"]), size_m=size, installed_pose=installed,
            storage_pose=_pose6(placed.pose) if placed is not None and placed.pose is not None else None,
            mesh_file=mesh_file))
    if no_pose:
        notes.append(f"{len(no_pose)} element(s) have no installed pose (first: {no_pose[0]}): "
                     "installed_pose is 0, 0, 0 there")
    if no_mesh:
        notes.append(f"{len(no_mesh)} element(s) have no mesh (kbp:meshFile; first: {no_mesh[0]}): "
                     "size 0, 0, 0")
    by_reason: dict[str, list[str]] = {}
    for o in world.unplaced():
        if URIRef(o.iri) in rows:
            by_reason.setdefault(o.reason, []).append(o.global_id)
    for reason, gids in sorted(by_reason.items()):
        notes.append(f"{len(gids)} element(s) have no storage pose (first: {sorted(gids)[0]}): {reason}")
    return out


# --------------------------------------------------------------------------------------------
# The plan
# --------------------------------------------------------------------------------------------


def _world_date(project: ProjectData, task: RobotizedTask, at: datetime | None) -> tuple[datetime, str]:
    if at is not None:
        return at, "given"
    default = project.manifest.simulation.get("date")
    try:
        when = project.world_date(task.task_id)  # the one rule: ProjectData.world_date
    except ProjectError:
        return FALLBACK_DATE, "no date known (task elements are placed at their storage whatever the date)"
    if default is not None and when == parse_date(str(default)):
        return when, "[simulation] date of project.toml"
    return when, f"start of task {task.task_id}"


def _runtime_inputs(spec: TaskSpecification) -> str | None:
    parts = []
    for skill in spec.skills:
        bound = {b.input.iri for a in spec.actions if a.skill.iri == skill.iri for b in a.bindings}
        given = [f"{i.name} ({curie_local(i.source) if i.source is not None else 'unspecified source'})"
                 for i in skill.inputs if i.iri not in bound and i.source != KBP.FromTaskElement]
        if given:
            parts.append(f"{skill.skill_id}: {', '.join(given)}")
    if not parts:
        return None
    return "inputs supplied at run time, not in the steps: " + "; ".join(parts)


def curie_local(iri: URIRef) -> str:
    """``kbp:FromWorld`` -> ``FromWorld``."""
    return str(iri).rsplit("#", 1)[-1]


def _steps(project: ProjectData, task: RobotizedTask, spec: TaskSpecification, params: list[ActionParameters],
           elements: list[ElementInfo], robot_reasons: list[str]) -> list[SkillCall]:
    by_action: dict[URIRef, dict[str, JsonValue]] = {
        ap.action.iri: _parameters(project.kb, ap, spec.spec_id) for ap in params}
    steps: list[SkillCall] = []
    n = 0
    task_name = f"task {task.task_id}"
    for info in elements:
        el = URIRef(info.iri)
        name = f"{info.global_id} '{info.label}'" if info.label != info.global_id else info.global_id
        for action in spec.actions:
            n += 1
            steps.append(_step(project.model, n, el, name, task, task_name, action, by_action[action.iri],
                               robot_reasons))
    return steps


def _step(model: Graph, n: int, el: URIRef, name: str, task: RobotizedTask, task_name: str, action: Action,
          parameters: dict[str, JsonValue], robot_reasons: list[str]) -> SkillCall:
    values = resolve_inputs(model, action.bindings, element=el, task=task.iri, element_name=name,
                            task_name=task_name)
    inputs: dict[str, JsonValue] = {}
    for si in action.skill.inputs:
        if si.source == KBP.FromTaskElement:
            inputs[si.name] = str(el)
    missing: list[str] = []
    notes: list[str] = []
    for v in values:
        notes.extend(v.notes)
        if v.missing is None:
            inputs[v.name] = v.value
        else:
            missing.append(v.missing)
    reasons = [*robot_reasons, *missing]
    return SkillCall(
        step=n, element=str(el), action=str(action.iri), action_label=action.label, action_order=action.order,
        skill=str(action.skill.iri), skill_id=action.skill.skill_id,
        skill_kind=str(action.skill.kind) if action.skill.kind is not None else "",
        inputs=dict(sorted(inputs.items())), parameters=dict(parameters), notes=notes,
        feasible=not reasons, reason="; ".join(reasons) if reasons else None)


def plan_task(project: ProjectData, task_id: str | None = None, robot_id: str | None = None, *,
              at: datetime | None = None, world: World | None = None,
              tables: WorldTables | None = None) -> Plan:
    """B1-B3: the action-level plan of a robotized task for one robot (see the module docstring).

    ``task_id`` defaults to ``[simulation] task`` of project.toml (or the only robotized task);
    ``robot_id`` (a robot's id, IRI or label) overrides the ranking; ``at`` is the date of the world
    that places the elements at their storage (default ``[simulation] date``, else the task's start);
    a ``world`` already built for the task may be passed to save building it again, or the
    project's :func:`~kbplanner.world.tables.world_tables` to build it without reading the whole building
    again (:func:`plan_tasks` does that for several tasks).

    Raises:
        PlanningError: unknown task or robot; a world built for another task.
        KnowledgeBaseError: the task's specification id is missing or unknown, a malformed arm pose.

    Example:
        >>> p = Project.load("data/case_study", scenario="storage-outside")  # doctest: +SKIP
        >>> plan = plan_task(p)  # doctest: +SKIP
        >>> len(plan.steps), plan.robot_id, plan.feasible  # doctest: +SKIP
        (44, 'husky-ur16e', True)
    """
    return _plan(project, resolve_task(project, task_id), robot_id, at=at, world=world, tables=tables)


def _plan(project: ProjectData, task: RobotizedTask, robot_id: str | None, *, at: datetime | None,
          world: World | None, tables: WorldTables | None) -> Plan:
    if task.spec_id is None:
        raise KnowledgeBaseError(f"robotized task {task.task_id} has no task specification id",
                                 file=project.manifest.path, element=task.task_id,
                                 fix="set kbp:taskSpecificationId (the schedule's task_specification column)")
    spec = task_specification(project.kb, task.spec_id, task=task.task_id)  # A1-A2
    params = action_parameters(spec, jobsite_parameters(project.model, project.scenario))  # A5
    sel = select_robots(project.model, project.kb, task.task_id, scenario=project.scenario)  # B3
    chosen, robot_reasons, table = _choose_robot(sel, robot_id)
    notes: list[str] = []
    if world is None:
        when, why = _world_date(project, task, at)
        world = build_world(project, when, task.task_id, tables=tables)
        notes.append(f"storage poses from the world at {when.isoformat()} ({why})")
    elif world.task_id != task.task_id:
        raise PlanningError(f"the world given was built for task {world.task_id!r}, not {task.task_id!r}",
                            element=task.task_id, fix="build the world with the same task id")
    start = world.robot_start
    order = element_order(project.model, task.iri, (start.x, start.y) if start is not None else None)  # B1
    elements = _elements(project, task, order.elements, world, notes)
    if not elements:
        notes.append(f"task {task.task_id} builds no elements: the plan has no steps "
                     "(link its elements with kbp:buildsElement, e.g. by the schedule's elements column)")
    runtime = _runtime_inputs(spec)
    if runtime:
        notes.append(runtime)
    notes.extend(f"robot selection: {n}" for n in sel.notes)
    steps = _steps(project, task, spec, params, elements, robot_reasons)  # B1-B2
    storey = world.storey(world.task_storey)
    plan = Plan(
        project=project.name, scenario=project.scenario, task_id=task.task_id, task_label=task.label,
        spec_id=spec.spec_id, robot_id=robot_id_of(chosen), robot_label=chosen.robot.label if chosen else "",
        robot_urdf=chosen.robot.urdf if chosen else "", order_rule=order.rule, elements=elements, steps=steps,
        robot_start=Pose2(start.x, start.y, start.yaw) if start is not None else None,
        storey_elevation_m=storey.elevation_m if storey is not None else 0.0, selection=table, notes=notes,
        task_iri=str(task.iri), spec_iri=str(spec.iri))
    bad = sum(1 for s in steps if not s.feasible)
    log.info("plan of %s (%s): %d steps, %d infeasible, robot %s", task.task_id, spec.spec_id, len(steps),
             bad, plan.robot_id or "none")
    return plan


def plan_tasks(project: ProjectData, task_ids: Sequence[str] | None = None, robot_id: str | None = None, *,
               at: datetime | None = None) -> list[Plan]:
    """B1-B3 for several robotized tasks (default: every one, in schedule order): one plan per task.

    The plans are those of :func:`plan_task` for each task, but the building is read once
    (:func:`~kbplanner.world.tables.world_tables`) and each task's world is built from those tables, so
    planning every storey of a building grows linearly with its size instead of with storeys x
    elements. ``robot_id`` and ``at`` apply to every task, as in :func:`plan_task`.

    Raises:
        PlanningError: an unknown task or robot (before any plan is made).
        KnowledgeBaseError: a task's specification id is missing or unknown, a malformed arm pose.

    Example:
        >>> p = ProjectData.load("runs/b10x10", scenario="storage-in-units")  # doctest: +SKIP
        >>> [plan.task_id for plan in plan_tasks(p)][:2]  # doctest: +SKIP
        ['T-FRAME-L01', 'T-FRAME-L02']
    """
    known = {t.task_id: t for t in robotized_tasks(project.model)}
    ids = list(task_ids) if task_ids is not None else list(known)
    for task_id in ids:
        if task_id not in known:
            resolve_task(project, task_id)  # raises PlanningError naming the robotized tasks
    tables = world_tables(project)
    return [_plan(project, known[task_id], robot_id, at=at, world=None, tables=tables) for task_id in ids]


def robot_id_of(a: RobotAssessment | None) -> str:
    """The id of an assessed robot, ``""`` for none."""
    return robot_id_from_iri(str(a.robot.iri)) if a is not None else ""


# --------------------------------------------------------------------------------------------
# B4 hook
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PoseChoice:
    """What B4 decides for one step: base pose, arm poses, or that the step cannot be done."""

    base_pose: Pose2 | None = None
    arm_poses: dict[str, list[float]] = field(default_factory=dict)
    feasible: bool = True
    reason: str | None = None
    notes: tuple[str, ...] = ()


def assign_poses(plan: Plan, choose: Callable[[Plan, SkillCall], PoseChoice | None]) -> Plan:
    """A copy of ``plan`` with B4's choices: ``choose(plan, step)`` for every feasible step.

    ``choose`` returns None to leave a step as it is. A choice with ``feasible=False`` marks the step
    infeasible with its reason (e.g. no IK solution); the input plan is not changed.

    Example:
        >>> p = Plan("p", None, "T", "", "S", "", "", "", "rule")
        >>> assign_poses(p, lambda plan, step: None).steps
        []
    """
    out = copy.deepcopy(plan)
    for step in out.steps:
        if not step.feasible:
            continue
        choice = choose(out, step)
        if choice is None:
            continue
        if choice.base_pose is not None:
            step.base_pose = choice.base_pose
        if choice.arm_poses:
            step.arm_poses = {k: [float(v) for v in vals] for k, vals in sorted(choice.arm_poses.items())}
        step.notes.extend(choice.notes)
        if not choice.feasible:
            step.feasible = False
            step.reason = choice.reason or "infeasible (B4 gave no reason)"
    return out
