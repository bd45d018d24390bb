"""Requirement shapes (A3): SHACL shapes generated from the input bindings of the knowledge base.

No shape is written by hand per skill. For every robotized task of the model, every action of its task
specification and every binding of a model input (``kbp:FromModel``), one ``sh:PropertyShape`` is
generated: the binding's path (copied as SHACL path structure), ``sh:minCount 1`` and ``sh:class`` or
``sh:datatype`` of the input's value class, targeting the task's elements (``sh:targetNode``) or the
task itself. Each shape gets an IRI minted from task id, action order and input name, and is linked to
task, action, skill, input and binding (``kbp:forTask`` ...), so a violation maps back to a row of the
additional modeling requirements. Takes the model and KB graphs; returns a :class:`RequirementShapes`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from rdflib import RDF, RDFS, XSD, Graph, Literal, URIRef

from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.core.iris import DATA_ROOT, mint
from kbplanner.core.rdf_io import bind_prefixes
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.binding_paths import copy_path
from kbplanner.knowledge.knowledge_base import SH, is_datatype
from kbplanner.knowledge.task_specs import (
    Action,
    Binding,
    ElementRef,
    RobotizedTask,
    TaskSpecification,
    robotized_tasks,
    task_specification,
)

log = logging.getLogger(__name__)

GENERATED_BASE = DATA_ROOT + "generated/"


@dataclass(frozen=True)
class BindingTarget:
    """What one generated shape checks: a binding of an action of a robotized task, on its targets."""

    shape: URIRef
    task: RobotizedTask
    spec: TaskSpecification
    action: Action
    binding: Binding
    targets: tuple[ElementRef, ...]


@dataclass
class RequirementShapes:
    """The generated shapes graph and, per shape IRI, what it checks."""

    graph: Graph
    targets: dict[URIRef, BindingTarget] = field(default_factory=dict)
    tasks: list[RobotizedTask] = field(default_factory=list)
    specs: dict[str, TaskSpecification] = field(default_factory=dict)
    unknown_specs: dict[str, str] = field(default_factory=dict)

    @property
    def value_classes(self) -> set[URIRef]:
        """Every class the shapes check with sh:class."""
        return {t.binding.input.value_class for t in self.targets.values()
                if t.binding.input.value_class is not None
                and not str(t.binding.input.value_class).startswith(str(XSD))}


def shape_base(task: URIRef) -> str:
    """Base IRI for generated terms: the project's data base when the task IRI is minted under it."""
    text = str(task)
    if text.startswith(DATA_ROOT):
        project = text[len(DATA_ROOT):].split("/", 1)[0]
        if project:
            return f"{DATA_ROOT}{project}/"
    return GENERATED_BASE


def _task_target(task: RobotizedTask) -> ElementRef:
    return ElementRef(iri=task.iri, global_id=task.task_id, label=task.label)


def _add_shape(g: Graph, kb: Graph, bt: BindingTarget) -> None:
    b, a, t = bt.binding, bt.action, bt.task
    s = bt.shape
    g.add((s, RDF.type, SH.PropertyShape))
    g.add((s, SH.path, copy_path(b.path, g)))
    g.add((s, SH.minCount, Literal(1)))
    vc = b.input.value_class
    if vc is not None:
        g.add((s, SH.datatype if is_datatype(kb, vc) else SH["class"], vc))
    g.add((s, SH.name, Literal(f"{a.skill.skill_id} {b.input.name}")))
    g.add((s, SH.message, Literal(
        f"{t.task_id} action {a.order} '{a.label}' ({a.skill.skill_id} {b.input.name}) needs: {b.words}")))
    g.add((s, RDFS.label, Literal(f"requirement of {t.task_id}: {a.skill.skill_id} {b.input.name}")))
    for target in bt.targets:
        g.add((s, SH.targetNode, target.iri))
    g.add((s, KBP.forTask, t.iri))
    g.add((s, KBP.forAction, a.iri))
    g.add((s, KBP.forSkill, a.skill.iri))
    g.add((s, KBP.forInput, b.input.iri))
    if isinstance(b.iri, URIRef):  # blank bindings would put random ids into written files
        g.add((s, KBP.forBinding, b.iri))


def requirement_shapes(model: Graph, kb: Graph, *, task_id: str | None = None,
                       skip_unknown: bool = False) -> RequirementShapes:
    """A3: generate one SHACL property shape per (robotized task, action, model input binding).

    A robotized task without a specification id, or naming an id that the knowledge base lacks, raises
    :class:`KnowledgeBaseError`; with ``skip_unknown=True`` it is recorded in ``unknown_specs`` instead
    (validation reports it as a result).

    Example:
        >>> from kbplanner.knowledge.knowledge_base import load_kb
        >>> len(requirement_shapes(Graph(), load_kb()).graph)
        0
    """
    g = Graph()
    bind_prefixes(g)
    g.bind("sh", SH)
    out = RequirementShapes(graph=g)
    for task in robotized_tasks(model, task_id):
        out.tasks.append(task)
        if task.spec_id is None:
            if skip_unknown:
                out.unknown_specs[task.task_id] = ""
                continue
            raise KnowledgeBaseError(
                f"robotized task {task.task_id} has no task specification id",
                element=task.task_id,
                fix="give the task kbp:taskSpecificationId (e.g. I-W-F-#1) in the schedule")
        if task.spec_id not in out.specs:
            try:
                out.specs[task.spec_id] = task_specification(kb, task.spec_id, task=task.task_id)
            except KnowledgeBaseError:
                if not skip_unknown:
                    raise
                out.unknown_specs[task.task_id] = task.spec_id
                continue
        spec = out.specs[task.spec_id]
        base = shape_base(task.iri)
        for action in spec.actions:
            for binding in action.bindings:
                targets = (_task_target(task),) if binding.starts_at_task else task.elements
                if not targets:
                    continue
                key = f"{task.task_id}|{spec.spec_id}|{action.order}|{binding.input.name}"
                bt = BindingTarget(shape=mint(base, "requirement-shape", key), task=task, spec=spec,
                                   action=action, binding=binding, targets=targets)
                out.targets[bt.shape] = bt
                _add_shape(g, kb, bt)
    log.info("generated %d requirement shapes for %d robotized tasks", len(out.targets), len(out.tasks))
    return out
