"""Requirement rows (A3, second half): a pySHACL report of the requirement shapes, translated into rows.

Each violation of a generated shape (:mod:`kbplanner.knowledge.requirement_shapes`) becomes part of a
:class:`Requirement`: task, action, skill, input, element, what is missing in words (from the path's
property labels and ranges) and how to add it. Violations with the same cause are grouped, so eleven
frames without a grasp point read as one requirement with eleven elements.
:func:`kbplanner.knowledge.requirements.derive_requirements` runs the whole step.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from rdflib import RDF, RDFS, Graph, URIRef
from rdflib.term import Node

from kbplanner.core.vocab import KBP
from kbplanner.knowledge.binding_paths import (
    Gap,
    InversePath,
    PredicatePath,
    SequencePath,
    ShaclPath,
    path_curies,
    path_words,
    step_range,
    steps_of,
    walk,
)
from kbplanner.knowledge.knowledge_base import SH, curie, is_datatype, label
from kbplanner.knowledge.requirement_shapes import BindingTarget, RequirementShapes
from kbplanner.knowledge.task_specs import ElementRef

MISSING = "missing"
WRONG_TYPE = "wrong type"

# Placeholder properties of a class are written in this order (then alphabetically).
_PREFERRED = [KBP.x, KBP.y, KBP.z, KBP.roll, KBP.pitch, KBP.yaw,
              KBP.minX, KBP.minY, KBP.minZ, KBP.maxX, KBP.maxY, KBP.maxZ]


@dataclass(frozen=True)
class Requirement:
    """One additional modeling requirement: a binding unmet in the same way for some elements."""

    number: int
    task_id: str
    task_label: str
    spec_id: str
    action_order: int
    action_label: str
    skill_id: str
    skill_label: str
    input_name: str
    value_class: str
    problem: str
    missing: str
    how_to_add: str
    path: str
    elements: tuple[ElementRef, ...]
    shape: URIRef
    target: BindingTarget = field(repr=False, compare=False)
    gap_index: int = 0
    gap_node: Node | None = None

    def as_dict(self) -> dict[str, Any]:
        """The requirement as plain JSON-able values."""
        return {
            "number": self.number, "task": self.task_id, "task_label": self.task_label,
            "specification": self.spec_id, "action": self.action_order, "action_label": self.action_label,
            "skill": self.skill_id, "skill_label": self.skill_label, "input": self.input_name,
            "value_class": self.value_class, "problem": self.problem, "missing": self.missing,
            "how_to_add": self.how_to_add, "path": self.path,
            "elements": [{"globalId": e.global_id, "label": e.label, "iri": str(e.iri)}
                         for e in self.elements],
        }




def class_fill(kb: Graph, cls: URIRef) -> list[tuple[URIRef, URIRef]]:
    """Datatype properties whose rdfs:domain is ``cls`` (a pose's x..yaw), with their range."""
    props = []
    for p in kb.subjects(RDFS.domain, cls):
        rng = kb.value(p, RDFS.range)
        if isinstance(p, URIRef) and isinstance(rng, URIRef) and is_datatype(kb, rng):
            props.append((p, rng))
    rank = {p: i for i, p in enumerate(_PREFERRED)}
    return sorted(props, key=lambda pr: (rank.get(pr[0], len(rank)), str(pr[0])))


def _type_words(kb: Graph, cls: URIRef) -> str:
    fill = class_fill(kb, cls)
    text = curie(kb, cls)
    if fill and not is_datatype(kb, cls):
        text += " with " + ", ".join(curie(kb, p) for p, _ in fill)
        kinds = {curie(kb, r) for _, r in fill}
        text += f" ({', '.join(sorted(kinds))})"
    return text


def _how_to_add(kb: Graph, bt: BindingTarget, steps: tuple[ShaclPath, ...] | None, start: int,
                gap_owner: str) -> str:
    b = bt.binding
    vc = b.input.value_class
    parts: list[str] = []
    if steps is None:
        parts.append(f"give {gap_owner} a value along the path {path_curies(kb, b.path)}"
                     + (f" of type {curie(kb, vc)}" if vc is not None else ""))
    else:
        owner = gap_owner
        for i in range(start, len(steps)):
            step = steps[i]
            last = i == len(steps) - 1
            target = vc if last else step_range(kb, step)
            what = _type_words(kb, target) if target is not None else "a node"
            if isinstance(step, InversePath) and isinstance(step.path, PredicatePath):
                parts.append(f"link {what} to {owner} with {curie(kb, step.path.predicate)} (pointing to it)")
            elif isinstance(step, PredicatePath):
                parts.append(f"give {owner} {curie(kb, step.predicate)} -> {what}")
            owner = f"that {curie(kb, target)}" if target is not None else "that node"
    text = "; ".join(parts)
    if b.hint:
        text += f". {b.hint}"
    return text


def _owner_words(model: Graph, kb: Graph, node: Node, is_focus: bool, bt: BindingTarget) -> str:
    if is_focus:
        return "the task" if bt.binding.starts_at_task else "each element"
    types = sorted((t for t in model.objects(node, RDF.type) if isinstance(t, URIRef)), key=str)
    kind = label(kb, types[0]) if types else "node"
    name = model.value(node, RDFS.label)
    return f"the {kind} '{name}'" if name is not None else f"the {kind} {curie(model, node)}"


@dataclass
class _Group:
    bt: BindingTarget
    problem: str
    gap_index: int
    gap_node: Node | None
    detail: str
    elements: list[ElementRef] = field(default_factory=list)


def translate_report(result_graph: Graph, shapes: RequirementShapes, model: Graph,
                     kb: Graph) -> list[Requirement]:
    """The requirements in a pySHACL report of ``shapes`` on ``model``: violations grouped, numbered."""
    groups: dict[tuple[Any, ...], _Group] = {}
    refs: dict[tuple[URIRef, Node], ElementRef] = {}
    for bt in shapes.targets.values():
        for e in bt.targets:
            refs[(bt.shape, e.iri)] = e
    for res in result_graph.subjects(RDF.type, SH.ValidationResult):
        shape = result_graph.value(res, SH.sourceShape)
        if not isinstance(shape, URIRef) or shape not in shapes.targets:
            continue
        bt = shapes.targets[shape]
        focus = result_graph.value(res, SH.focusNode)
        component = result_graph.value(res, SH.sourceConstraintComponent)
        if focus is None:
            continue
        ref = refs.get((shape, focus)) or ElementRef(iri=URIRef(str(focus)), global_id=curie(model, focus),
                                                      label="")
        steps = steps_of(bt.binding.path)
        if component == SH.MinCountConstraintComponent:
            gap = walk(model, focus, bt.binding.path) or Gap(0, focus)
            key: tuple[Any, ...] = (shape, MISSING, gap.index, gap.node if gap.node != focus else None)
            if key not in groups:
                groups[key] = _Group(bt, MISSING, gap.index, key[3], "")
        else:
            value = result_graph.value(res, SH.value)
            key = (shape, WRONG_TYPE, value if component != SH.DatatypeConstraintComponent else None)
            if key not in groups:
                vc = bt.binding.input.value_class
                what = curie(kb, vc) if vc is not None else "the expected type"
                detail = (f"the value {curie(model, value)} is not a {what}" if value is not None
                          else f"a value is not a {what}")
                groups[key] = _Group(bt, WRONG_TYPE, len(steps or ()) - 1, value, detail)
        groups[key].elements.append(ref)

    ordered = sorted(groups.values(), key=lambda g: (g.bt.task.task_id, g.bt.action.order,
                                                     g.bt.binding.input.name, g.problem, g.gap_index,
                                                     str(g.gap_node or "")))
    out: list[Requirement] = []
    for n, grp in enumerate(ordered, start=1):
        bt = grp.bt
        b = bt.binding
        steps = steps_of(b.path)
        vc = b.input.value_class
        if grp.problem == WRONG_TYPE:
            missing = f"{b.words}: {grp.detail}"
            fix = (f"type the value as {_type_words(kb, vc)}" if vc is not None and not is_datatype(kb, vc)
                   else f"write the value as a {curie(kb, vc) if vc is not None else 'literal'} literal")
        elif grp.gap_node is None or steps is None:
            missing = b.words
            fix = _how_to_add(kb, bt, steps, grp.gap_index if steps else 0,
                              _owner_words(model, kb, bt.task.iri, True, bt))
        else:
            owner = _owner_words(model, kb, grp.gap_node, False, bt)
            rest = steps[grp.gap_index:]
            rest_path: ShaclPath = rest[0] if len(rest) == 1 else SequencePath(rest)
            missing = f"{b.words}: {owner} has no {path_words(kb, rest_path, vc)}"
            fix = _how_to_add(kb, bt, steps, grp.gap_index, owner)
        elements = tuple(sorted(grp.elements, key=lambda e: (e.global_id, str(e.iri))))
        out.append(Requirement(
            number=n, task_id=bt.task.task_id, task_label=bt.task.label, spec_id=bt.spec.spec_id,
            action_order=bt.action.order, action_label=bt.action.label, skill_id=bt.action.skill.skill_id,
            skill_label=bt.action.skill.label, input_name=b.input.name,
            value_class=curie(kb, vc) if vc is not None else "", problem=grp.problem, missing=missing,
            how_to_add=fix, path=path_curies(kb, b.path), elements=elements, shape=bt.shape, target=bt,
            gap_index=grp.gap_index, gap_node=grp.gap_node))
    return out

