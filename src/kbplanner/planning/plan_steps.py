"""B1-B2, the steps of a plan: one skill call per (element, action), inputs by SPARQL, effective parameters.

:func:`plan_steps` gives every element of the task each action of its specification, in order, as a
:class:`~kbplanner.planning.plan_model.SkillCall`: inputs fetched by SPARQL generated from the bindings
(:mod:`kbplanner.planning.skill_inputs`), the element's IRI for inputs from the task element, the
parameters of A5 (skill default < action setting < jobsite parameter) with named arm poses as joint
lists (:func:`arm_pose_joints`). :func:`runtime_inputs_note` names the inputs supplied at run time.
Used by :mod:`kbplanner.planning.planner`.
"""

from __future__ import annotations

from rdflib import RDF, RDFS, Graph, Literal, URIRef
from rdflib.collection import Collection
from rdflib.term import Node

from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.jobsite import ActionParameters
from kbplanner.knowledge.knowledge_base import curie, source_of
from kbplanner.knowledge.skill_kinds import local
from kbplanner.knowledge.task_specs import Action, RobotizedTask, TaskSpecification
from kbplanner.model.project_data import ProjectData
from kbplanner.planning.plan_model import ElementInfo, JsonValue, SkillCall
from kbplanner.planning.skill_inputs import resolve_inputs


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



def runtime_inputs_note(spec: TaskSpecification) -> str | None:
    """A plan note naming the skill inputs supplied at run time (robot, world), or None."""
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



def plan_steps(project: ProjectData, task: RobotizedTask, spec: TaskSpecification,
               params: list[ActionParameters], elements: list[ElementInfo],
               robot_reasons: list[str]) -> list[SkillCall]:
    """One skill call per (element, action), numbered from 1; ``robot_reasons`` make every step infeasible."""
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
    roles = {local(si.role): si.name for si in action.skill.inputs if si.role is not None}
    return SkillCall(
        step=n, element=str(el), action=str(action.iri), action_label=action.label, action_order=action.order,
        skill=str(action.skill.iri), skill_id=action.skill.skill_id,
        skill_kind=str(action.skill.kind) if action.skill.kind is not None else "",
        inputs=dict(sorted(inputs.items())), parameters=dict(parameters), notes=notes,
        feasible=not reasons, reason="; ".join(reasons) if reasons else None,
        roles=dict(sorted(roles.items())))

