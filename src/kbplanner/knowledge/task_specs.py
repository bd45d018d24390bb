"""Task specifications and skills (A1-A2): from a robotized task to its actions, skills and bindings.

A1: ``robotized_tasks(model)`` lists the schedule's robotized tasks with their specification id and
elements. A2: ``task_specification(kb, spec_id)`` reads a specification of the construction robot
knowledge base into typed objects: its ordered actions, the skill each uses (inputs, parameters,
required capabilities) and the input bindings (SHACL paths). A broken knowledge base (an unknown
specification id, an action whose skill does not exist, a binding with an undeclared property or a
missing binding) raises :class:`~kbplanner.core.errors.KnowledgeBaseError` naming the file and term.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from decimal import Decimal
from functools import cached_property

from rdflib import Graph, Literal, URIRef
from rdflib.term import Node

from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.core.graph_memo import memo
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.binding_check import check_binding
from kbplanner.knowledge.binding_paths import ShaclPath, path_words
from kbplanner.knowledge.knowledge_base import curie, is_datatype, is_declared_class, label, select, source_of

log = logging.getLogger(__name__)

ParamValue = float | int | str | bool | URIRef


@dataclass(frozen=True)
class ElementRef:
    """A model element (or task) a requirement or a plan refers to."""

    iri: URIRef
    global_id: str
    label: str

    def describe(self) -> str:
        """``GlobalId 'label'`` for messages."""
        return f"{self.global_id} '{self.label}'" if self.label else self.global_id


@dataclass(frozen=True)
class SkillInput:
    """A typed input of a skill and where its value comes from."""

    iri: URIRef
    name: str
    value_class: URIRef | None
    source: URIRef | None
    description: str
    role: URIRef | None = None  # kbp:inputRole: what the executor binds the input by (the name is a label)

    @property
    def from_model(self) -> bool:
        """True when an action must bind this input to the 4D model (a modeling requirement)."""
        return self.source == KBP.FromModel


@dataclass(frozen=True)
class SkillParameter:
    """A tunable parameter of a skill: its kind (e.g. kbp:maxSpeed), default value and unit."""

    iri: URIRef
    kind: URIRef
    default: ParamValue | None
    unit: str


@dataclass(frozen=True)
class Skill:
    """A generic robot skill of the skill database."""

    iri: URIRef
    skill_id: str
    label: str
    kind: URIRef | None
    inputs: tuple[SkillInput, ...]
    parameters: tuple[SkillParameter, ...]
    capabilities: tuple[URIRef, ...]

    def input(self, name: str) -> SkillInput | None:
        """The input called ``name``."""
        return next((i for i in self.inputs if i.name == name), None)

    def input_with_role(self, role: URIRef) -> SkillInput | None:
        """The input whose kbp:inputRole is ``role``."""
        return next((i for i in self.inputs if i.role == role), None)


@dataclass(frozen=True)
class Binding:
    """An action's binding of one skill input to a SHACL path from the element (or the task)."""

    iri: Node
    input: SkillInput
    path: ShaclPath
    path_node: Node
    starts_at_task: bool
    hint: str
    words: str


@dataclass(frozen=True)
class Action:
    """One step of a task specification: a skill customised by bindings and parameter settings."""

    iri: URIRef
    order: int
    label: str
    skill: Skill
    bindings: tuple[Binding, ...]
    settings: tuple[tuple[SkillParameter, ParamValue], ...]

    def binding(self, input_name: str) -> Binding | None:
        """The binding of the input called ``input_name``, if the action binds it."""
        return next((b for b in self.bindings if b.input.name == input_name), None)


@dataclass(frozen=True)
class TaskSpecification:
    """A robot task specification: ordered actions (paper, section 4.2)."""

    iri: URIRef
    spec_id: str
    label: str
    task_kind: URIRef | None
    actions: tuple[Action, ...]

    @cached_property
    def skills(self) -> tuple[Skill, ...]:
        """The distinct skills of the actions, in first-use order."""
        seen: dict[URIRef, Skill] = {}
        for a in self.actions:
            seen.setdefault(a.skill.iri, a.skill)
        return tuple(seen.values())


@dataclass(frozen=True)
class RobotizedTask:
    """A schedule task chosen for robotization (A1) with its specification id and elements."""

    iri: URIRef
    task_id: str
    label: str
    spec_id: str | None
    elements: tuple[ElementRef, ...]


def _num(value: Node | None) -> ParamValue | None:
    if value is None:
        return None
    if isinstance(value, Literal):
        py = value.toPython()
        if isinstance(py, Decimal):
            return float(py)
        if isinstance(py, bool | int | float | str):
            return float(py) if isinstance(py, int) and not isinstance(py, bool) else py
        return str(value)
    if isinstance(value, URIRef):
        return value
    return str(value)


def robotized_tasks(model: Graph, task_id: str | None = None) -> list[RobotizedTask]:
    """A1: the robotized tasks of the schedule (sorted by task id), with their elements.

    Example:
        >>> robotized_tasks(Graph())
        []
    """
    kept = memo(model)  # a loaded model, unedited: the same tasks for every task of a whole-building run
    if kept is not None:
        key = ("robotized_tasks", task_id)
        if key not in kept:
            kept[key] = tuple(_robotized_tasks(model, task_id))
        return list(kept[key])
    return _robotized_tasks(model, task_id)


def _robotized_tasks(model: Graph, task_id: str | None) -> list[RobotizedTask]:
    bindings = {"taskId": Literal(task_id)} if task_id is not None else {}
    out: list[RobotizedTask] = []
    for row in select(model, "robotized_tasks", **bindings):
        task = row["task"]
        assert isinstance(task, URIRef)
        elements = tuple(
            ElementRef(iri=r["element"], global_id=str(r["globalId"] or curie(model, r["element"])),
                       label=str(r["label"] or ""))
            for r in select(model, "task_targets", task=task)
            if isinstance(r["element"], URIRef)
        )
        out.append(RobotizedTask(iri=task, task_id=str(row["taskId"]), label=str(row["label"] or ""),
                                 spec_id=str(row["specId"]) if row["specId"] is not None else None,
                                 elements=elements))
    return out


def specification_ids(kb: Graph) -> list[str]:
    """Every task specification id of the knowledge base, sorted."""
    return sorted({str(r["specId"]) for r in select(kb, "task_specifications")})


def skill_ids(kb: Graph) -> list[str]:
    """Every skill id of the knowledge base, sorted."""
    return sorted({str(r["skillId"]) for r in select(kb, "skills")})


def load_skill(kb: Graph, skill: URIRef) -> Skill:
    """Read one skill (by IRI) with its inputs, parameters and required capabilities."""
    rows = [r for r in select(kb, "skills") if r["skill"] == skill]
    if not rows:
        raise KnowledgeBaseError(f"{curie(kb, skill)} is not a skill of the knowledge base",
                                 file=source_of(kb, skill), element=curie(kb, skill),
                                 fix="declare it as kbp:Skill with a kbp:skillId")
    row = rows[0]
    where = source_of(kb, skill)
    inputs = []
    for r in select(kb, "skill_inputs", skill=skill):
        inp = r["input"]
        assert isinstance(inp, URIRef)
        if r["name"] is None:
            raise KnowledgeBaseError("skill input has no kbp:inputName", file=source_of(kb, inp) or where,
                                     element=curie(kb, inp), fix='add kbp:inputName "destination"')
        vc = r["valueClass"]
        if vc is not None and not (isinstance(vc, URIRef)
                                   and (is_declared_class(kb, vc) or is_datatype(kb, vc))):
            raise KnowledgeBaseError(
                f"kbp:valueClass {curie(kb, vc)} of input '{r['name']}' is neither a declared class nor a "
                "datatype", file=source_of(kb, inp) or where, element=curie(kb, inp),
                fix="use a class declared in the ontology (e.g. kbp:Pose) or an XSD datatype "
                    "(e.g. xsd:double)")
        src = r["source"]
        inputs.append(SkillInput(iri=inp, name=str(r["name"]),
                                 value_class=vc if isinstance(vc, URIRef) else None,
                                 source=src if isinstance(src, URIRef) else None,
                                 description=str(r["description"] or ""),
                                 role=r["role"] if isinstance(r["role"], URIRef) else None))
    params = []
    for r in select(kb, "skill_parameters", skill=skill):
        p, kind = r["parameter"], r["kind"]
        assert isinstance(p, URIRef)
        if not isinstance(kind, URIRef):
            raise KnowledgeBaseError("skill parameter has no kbp:parameterKind",
                                     file=source_of(kb, p) or where, element=curie(kb, p),
                                     fix="add kbp:parameterKind kbp:maxSpeed (or another kind)")
        params.append(SkillParameter(iri=p, kind=kind, default=_num(r["default"]), unit=str(r["unit"] or "")))
    caps = tuple(sorted((r["capability"] for r in select(kb, "skill_capabilities", skill=skill)
                         if isinstance(r["capability"], URIRef)), key=str))
    return Skill(iri=skill, skill_id=str(row["skillId"]), label=str(row["label"] or ""),
                 kind=row["kind"] if isinstance(row["kind"], URIRef) else None,
                 inputs=tuple(inputs), parameters=tuple(params), capabilities=caps)


def _load_bindings(kb: Graph, action: URIRef, skill: Skill, spec_id: str, order: int) -> tuple[Binding, ...]:
    bindings: list[Binding] = []
    inputs = {i.iri: i for i in skill.inputs}
    where = f"action {order} of {spec_id}"
    done: set[Node] = set()
    for r in select(kb, "action_bindings", action=action):
        b = r["binding"]
        assert b is not None
        if b in done:  # several rows: repeated values, which check_binding reports below
            continue
        done.add(b)
        file = source_of(kb, b) or source_of(kb, action)
        name = curie(kb, b) if isinstance(b, URIRef) else f"a binding of {where}"
        inp = r["input"]
        if not isinstance(inp, URIRef) or inp not in inputs:
            known = ", ".join(sorted(curie(kb, i) for i in inputs)) or "none"
            raise KnowledgeBaseError(
                f"binding of {where} binds {curie(kb, inp) if inp is not None else 'no input'}, which is "
                f"not an input of skill {skill.skill_id}", file=file, element=name,
                fix=f"set kbp:bindsInput to one of the skill's inputs: {known}")
        path = check_binding(kb, b, action=action)
        si = inputs[inp]
        if any(x.input.iri == inp for x in bindings):
            raise KnowledgeBaseError(
                f"{where} binds input '{si.name}' of {skill.skill_id} twice", file=file, element=name,
                fix="keep one kbp:InputBinding per skill input of an action")
        path_node = kb.value(b, KBP.bindingPath)
        assert path_node is not None
        bindings.append(Binding(iri=b, input=si, path=path, path_node=path_node,
                                starts_at_task=kb.value(b, KBP.pathStart) == KBP.StartAtTask,
                                hint=str(r["hint"] or ""), words=path_words(kb, path, si.value_class)))
    bound = {b.input.iri for b in bindings}
    for si in skill.inputs:
        if si.from_model and si.iri not in bound:
            raise KnowledgeBaseError(
                f"{where} uses skill {skill.skill_id} but does not bind its model input '{si.name}'",
                file=source_of(kb, action), element=curie(kb, action),
                fix=f"add an kbp:InputBinding with kbp:bindsInput {curie(kb, si.iri)} and a kbp:bindingPath")
    return tuple(sorted(bindings, key=lambda b: b.input.name))


def task_specification(kb: Graph, spec_id: str, *, task: str | None = None) -> TaskSpecification:
    """A2: the task specification ``spec_id`` with its actions in order.

    ``task`` (a task id) only makes the error message clearer when the id is unknown.

    Example:
        >>> from kbplanner.knowledge.knowledge_base import load_kb
        >>> spec = task_specification(load_kb(), "I-W-F-#1")
        >>> [(a.order, a.skill.skill_id) for a in spec.actions]
        [(1, 'NV-1'), (2, 'MM-G-1'), (3, 'NV-2'), (4, 'MM-R-1')]
    """
    kept = memo(kb)  # a loaded knowledge base, unedited: robot selection, B1-B3 and the world ask alike
    if kept is None:
        return _task_specification(kb, spec_id, task)
    key = ("task_specification", spec_id)
    if key not in kept:
        kept[key] = _task_specification(kb, spec_id, task)  # an error is raised each time, never kept
    spec: TaskSpecification = kept[key]
    return spec


def _task_specification(kb: Graph, spec_id: str, task: str | None) -> TaskSpecification:
    rows = select(kb, "task_specifications", specId=Literal(spec_id))
    if not rows:
        known = ", ".join(specification_ids(kb)) or "none"
        who = f"task {task} names" if task else "the"
        raise KnowledgeBaseError(
            f"{who} task specification id {spec_id!r}, which is not in the knowledge base",
            element=spec_id,
            fix=f"set kbp:taskSpecificationId to one of: {known}; or add a kbp:TaskSpecification with "
                "this kbp:specificationId to a project knowledge-base file",
        )
    if len(rows) > 1:
        raise KnowledgeBaseError(
            f"task specification id {spec_id!r} is declared {len(rows)} times",
            file=", ".join(sorted({source_of(kb, r["spec"]) or "?" for r in rows if r["spec"] is not None})),
            element=spec_id,
            fix="give each task specification its own kbp:specificationId")
    spec = rows[0]["spec"]
    assert isinstance(spec, URIRef)
    actions: list[Action] = []
    skills: dict[URIRef, Skill] = {}
    for r in select(kb, "specification_actions", spec=spec):
        action = r["action"]
        assert isinstance(action, URIRef)
        file = source_of(kb, action) or source_of(kb, spec)
        if r["order"] is None:
            raise KnowledgeBaseError(f"action {curie(kb, action)} of {spec_id} has no kbp:order", file=file,
                                     element=curie(kb, action), fix="add kbp:order 1 (2, 3, ...)")
        order = int(r["order"].toPython()) if isinstance(r["order"], Literal) else 0
        skill = r["skill"]
        if not isinstance(skill, URIRef) or r["skillId"] is None:
            known = ", ".join(skill_ids(kb))
            what = curie(kb, skill) if skill is not None else "no skill (kbp:usesSkill is missing)"
            raise KnowledgeBaseError(
                f"action {order} '{label(kb, action)}' of {spec_id} uses {what}, which is not a skill of the "
                "knowledge base", file=file, element=curie(kb, action),
                fix=f"use one of the skills {known}, or declare the skill (kbp:Skill with kbp:skillId)")
        if skill not in skills:
            skills[skill] = load_skill(kb, skill)
        sk = skills[skill]
        settings: list[tuple[SkillParameter, ParamValue]] = []
        params = {p.iri: p for p in sk.parameters}
        for s in select(kb, "action_settings", action=action):
            par, val = s["parameter"], _num(s["value"])
            if not isinstance(par, URIRef) or par not in params or val is None:
                raise KnowledgeBaseError(
                    f"a parameter setting of action {order} of {spec_id} sets "
                    f"{curie(kb, par) if par is not None else 'nothing'}"
                    + (" without a kbp:value" if val is None else f", not a parameter of {sk.skill_id}"),
                    file=file, element=curie(kb, action),
                    fix="kbp:setsParameter must name a parameter of the action's skill, with a kbp:value")
            settings.append((params[par], val))
        actions.append(Action(iri=action, order=order, label=str(r["label"] or label(kb, action)),
                              skill=sk, bindings=_load_bindings(kb, action, sk, spec_id, order),
                              settings=tuple(sorted(settings, key=lambda x: str(x[0].kind)))))
    if not actions:
        raise KnowledgeBaseError(f"task specification {spec_id} has no actions", file=source_of(kb, spec),
                                 element=curie(kb, spec),
                                 fix="add kbp:hasAction with ordered kbp:Action nodes")
    orders = [a.order for a in actions]
    if len(set(orders)) != len(orders):
        raise KnowledgeBaseError(f"actions of {spec_id} share a kbp:order ({sorted(orders)})",
                                 file=source_of(kb, spec), element=curie(kb, spec),
                                 fix="number the actions 1, 2, 3, ... without repeats")
    row = rows[0]
    return TaskSpecification(iri=spec, spec_id=spec_id, label=str(row["label"] or ""),
                             task_kind=row["taskKind"] if isinstance(row["taskKind"], URIRef) else None,
                             actions=tuple(sorted(actions, key=lambda a: a.order)))
