"""B1/B3, what is planned: the robotized task (A1's choice) and the robot (B3's ranking and choice).

:func:`resolve_task` finds the task (given, ``[simulation] task`` of project.toml, or the only robotized
one). :func:`rank_robots` orders the assessed robots of
:func:`kbplanner.knowledge.robot_selection.select_robots`: robots that fit first; among them the smallest
footprint (length x width), then the largest payload margin over the heaviest element, then the label.
:func:`choose_robot` takes the first fitting robot, or the one given, and gives the selection table of
the plan. Used by :mod:`kbplanner.planning.planner`.
"""

from __future__ import annotations

from kbplanner.core.errors import KbplannerError
from kbplanner.knowledge.robot_selection import RobotAssessment, RobotSelection
from kbplanner.knowledge.task_specs import RobotizedTask, robotized_tasks
from kbplanner.model.project_data import ProjectData
from kbplanner.planning.plan_model import JsonValue


class PlanningError(KbplannerError):
    """The plan cannot be made: unknown task or robot, no task chosen, a world of another task."""



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


def choose_robot(sel: RobotSelection, wanted: str | None) -> tuple[RobotAssessment | None, list[str],
                                                                    list[dict[str, JsonValue]]]:
    """The robot chosen (``wanted``, else the first that fits; None when none fits), the reasons the
    plan's steps are infeasible for it, and the selection table (every robot, ranked).

    Raises:
        PlanningError: ``wanted`` is no robot of the knowledge base (the message lists them).
    """
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


def robot_id_of(a: RobotAssessment | None) -> str:
    """The id of an assessed robot, ``""`` for none."""
    return robot_id_from_iri(str(a.robot.iri)) if a is not None else ""
