"""B1-B3, the action-level plan: a robotized task broken into skill calls for one robot.

Takes a loaded :class:`~kbplanner.model.project_data.ProjectData` (one scenario), a robotized task id and
optionally a robot id; returns a :class:`~kbplanner.planning.plan_model.Plan`. Every action, input and
coordinate comes from the graphs; nothing about the case study is written here.

- **A1** the task's specification id -> :func:`kbplanner.knowledge.task_specs.task_specification` (an
  unknown id raises :class:`~kbplanner.core.errors.KnowledgeBaseError` naming it and the known ids).
- **B1** its actions in ``kbp:order``; the task's elements in work order
  (:mod:`kbplanner.planning.element_order`, the rule used is ``Plan.order_rule``); one
  :class:`~kbplanner.planning.plan_model.SkillCall` per (element, action)
  (:mod:`kbplanner.planning.plan_steps`).
- **B2** inputs: every binding's value fetched by SPARQL generated from its SHACL path
  (:mod:`kbplanner.planning.skill_inputs`); inputs whose source is the task's element get the element's
  IRI; inputs the robot or the world supplies at run time (initial pose, map, scan) are listed in the
  plan notes, not in the steps. Parameters: skill default < action setting < jobsite parameter
  (:func:`kbplanner.knowledge.jobsite.action_parameters`), keyed by the parameter kind's local name;
  named arm poses (``kbp:ArmPose`` with ``kbp:jointAngles``) become joint lists (rad).
- **B3** robot: :func:`kbplanner.knowledge.robot_selection.select_robots` assesses every robot. Ranking
  (:mod:`kbplanner.planning.task_and_robot`; ``Plan.selection`` lists all, with rank and reasons):
  robots that fit first; among them the smallest footprint (length x width: the easiest through doors
  and past people), then the largest payload margin over the heaviest element, then the label. The
  first fitting robot is chosen, or the one given. When none fits (or the given robot does not), the
  plan is still made, with ``robot_id`` ``""`` (or the given robot) and every step infeasible with the
  selection's reasons.
- Elements (:mod:`kbplanner.planning.plan_elements`): size = extents of the element mesh in its own
  (installed-pose) frame; storage pose = where :func:`kbplanner.world.build.build_world` places the
  element at its storage (``None`` when it cannot be placed, e.g. no ``kbp:storedIn``); robot start and
  the task storey's elevation from the world.

Several tasks: :func:`plan_tasks` (default every robotized task) reads the building once
(:func:`kbplanner.world.tables.world_tables`) and gives the plans :func:`plan_task` gives for each task.

B4 (base poses, IK arm poses) is not done here: ``base_pose`` and ``arm_poses`` stay empty and
:func:`assign_poses` lets the B4 code fill them in a copy of the plan.
"""

from __future__ import annotations

import copy
import dataclasses
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import datetime

from rdflib import URIRef

from kbplanner.core.errors import KnowledgeBaseError, ProjectError
from kbplanner.knowledge.jobsite import action_parameters, jobsite_parameters
from kbplanner.knowledge.robot_selection import select_robots
from kbplanner.knowledge.skill_kinds import check_executable
from kbplanner.knowledge.task_specs import RobotizedTask, robotized_tasks, task_specification
from kbplanner.model.dates import parse_date
from kbplanner.model.project_data import ProjectData
from kbplanner.planning.element_order import element_order
from kbplanner.planning.plan_elements import plan_elements
from kbplanner.planning.plan_model import Plan, Pose2, SkillCall
from kbplanner.planning.plan_steps import plan_steps, runtime_inputs_note
from kbplanner.planning.task_and_robot import PlanningError, choose_robot, resolve_task, robot_id_of
from kbplanner.world.build import build_world
from kbplanner.world.tables import WorldTables, world_tables
from kbplanner.world.world_types import World

log = logging.getLogger(__name__)

FALLBACK_DATE = datetime(1970, 1, 1)  # world date when neither the caller, the manifest nor the task has one



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
    check_executable(project.kb, spec)  # every skill of an executable kind, every input with a usable role
    params = action_parameters(spec, jobsite_parameters(project.model, project.scenario))  # A5
    sel = select_robots(project.model, project.kb, task.task_id, scenario=project.scenario)  # B3
    chosen, robot_reasons, table = choose_robot(sel, robot_id)
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
    elements = [dataclasses.replace(e, work_sequence=order.sequences.get(URIRef(e.iri)))
                for e in plan_elements(project, task, order.elements, world, notes)]
    if not elements:
        notes.append(f"task {task.task_id} builds no elements: the plan has no steps "
                     "(link its elements with kbp:buildsElement, e.g. by the schedule's elements column)")
    runtime = runtime_inputs_note(spec)
    if runtime:
        notes.append(runtime)
    notes.extend(f"robot selection: {n}" for n in sel.notes)
    steps = plan_steps(project, task, spec, params, elements, robot_reasons)  # B1-B2
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
