# Over 500 lines: A3 in one place (report -> rows -> template); the template writer is next to split.
"""Additional modeling requirements (A3): what the 4D model lacks for the skills of its robotized tasks.

``derive_requirements(model, kb)`` generates the requirement shapes
(:mod:`kbplanner.knowledge.requirement_shapes`),
validates the model against them with pySHACL (the caller's graph is never modified), and translates
each violation into a row: task, action, skill, input, element, what is missing in words (from the
path's property labels and ranges) and how to add it. Violations with the same cause are grouped, so
eleven frames without a grasp point read as one requirement with eleven elements. Inputs the model
already carries produce none. ``RequirementsResult.template()`` writes a Turtle skeleton of exactly
what is missing (minted IRIs, placeholder values) that, once filled in and added to the project,
meets the requirements.
"""

from __future__ import annotations

import csv
import io
import logging
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from pyshacl import validate
from rdflib import RDF, RDFS, XSD, Graph, Literal, URIRef
from rdflib.term import Node

from kbplanner.core.iris import mint, slug
from kbplanner.core.outputs import json_text
from kbplanner.core.rdf_io import bind_prefixes
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
from kbplanner.knowledge.requirement_shapes import (
    BindingTarget,
    RequirementShapes,
    requirement_shapes,
    shape_base,
)
from kbplanner.knowledge.task_specs import ElementRef

log = logging.getLogger(__name__)

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


@dataclass(frozen=True)
class BindingCheck:
    """One generated shape: a binding checked on its targets, and how many lack it."""

    task_id: str
    spec_id: str
    action_order: int
    action_label: str
    skill_id: str
    input_name: str
    needs: str
    targets: int
    unmet: int


@dataclass
class RequirementsResult:
    """The additional modeling requirements of a model, with the shapes and report they come from."""

    requirements: list[Requirement]
    checks: list[BindingCheck]
    shapes: RequirementShapes
    report: Graph
    model: Graph = field(repr=False)
    kb: Graph = field(repr=False)
    seconds: float = 0.0

    @property
    def met(self) -> bool:
        """True when the model already holds every bound input."""
        return not self.requirements

    # ---- rows and formats ---------------------------------------------------------------------
    TABLE_COLUMNS = ("#", "task", "action", "skill", "input", "elements", "missing", "how to add")
    CSV_COLUMNS = ("requirement", "task", "specification", "action", "action_label", "skill", "input",
                   "globalId", "element_label", "element", "problem", "missing", "how_to_add", "path")

    def table_rows(self) -> list[tuple[Any, ...]]:
        """One row per requirement, elements summarised (for a terminal table)."""
        rows = []
        for r in self.requirements:
            ids = [e.global_id for e in r.elements]
            shown = ", ".join(ids[:3]) + (f", ... (+{len(ids) - 3})" if len(ids) > 3 else "")
            rows.append((r.number, r.task_id, f"{r.action_order} {r.action_label}", r.skill_id, r.input_name,
                         f"{len(ids)}: {shown}", r.missing, r.how_to_add))
        return rows

    def csv_rows(self) -> list[tuple[Any, ...]]:
        """One row per (requirement, element)."""
        return [(r.number, r.task_id, r.spec_id, r.action_order, r.action_label, r.skill_id, r.input_name,
                 e.global_id, e.label, str(e.iri), r.problem, r.missing, r.how_to_add, r.path)
                for r in self.requirements for e in r.elements]

    def to_csv(self) -> str:
        """CSV text, one line per (requirement, element)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.CSV_COLUMNS)
        w.writerows(self.csv_rows())
        return buf.getvalue()

    def to_json(self) -> str:
        """JSON text: requirements with their element lists, and every binding checked."""
        data = {
            "requirements": [r.as_dict() for r in self.requirements],
            "checked": [c.__dict__ for c in self.checks],
        }
        return json_text(data, name="requirements.json", sort_keys=False) + "\n"

    def to_graph(self) -> Graph:
        """The requirements as RDF (``kbp:ModelingRequirement``), with minted IRIs."""
        g = Graph()
        bind_prefixes(g)
        for r in self.requirements:
            t = r.target
            node = mint(shape_base(t.task.iri), "requirement", f"{r.task_id}|{r.shape}|{r.number}")
            g.add((node, RDF.type, KBP.ModelingRequirement))
            g.add((node, RDFS.label, Literal(f"{r.skill_id} {r.input_name} for {r.task_id}")))
            g.add((node, KBP.forTask, t.task.iri))
            g.add((node, KBP.forAction, t.action.iri))
            g.add((node, KBP.forSkill, t.action.skill.iri))
            g.add((node, KBP.forInput, t.binding.input.iri))
            if isinstance(t.binding.iri, URIRef):
                g.add((node, KBP.forBinding, t.binding.iri))
            g.add((node, KBP.requirementText, Literal(r.missing)))
            g.add((node, KBP.howToAdd, Literal(r.how_to_add)))
            g.add((node, KBP.order, Literal(r.number)))
            for e in r.elements:
                g.add((node, KBP.missingFor, e.iri))
        return g

    def text(self) -> str:
        """A readable summary: each requirement with its elements, then the bindings already met."""
        lines: list[str] = []
        if not self.requirements:
            lines.append("No additional modeling requirements: the model holds every bound skill input.")
        for r in self.requirements:
            lines.append(f"{r.number}. {r.task_id} action {r.action_order} '{r.action_label}' "
                         f"uses {r.skill_id} ({r.skill_label}): input '{r.input_name}'")
            lines.append(f"   {r.problem}: {r.missing}")
            lines.append(f"   for {len(r.elements)} element(s): "
                         + ", ".join(e.describe() for e in r.elements))
            lines.append(f"   how to add it: {r.how_to_add}")
        met = [c for c in self.checks if c.unmet == 0]
        if met:
            lines.append("Already in the model:")
            for c in met:
                lines.append(f"   {c.task_id} action {c.action_order} '{c.action_label}' {c.skill_id} "
                             f"'{c.input_name}': {c.needs} ({c.targets} target(s))")
        return "\n".join(lines) + "\n"

    def template(self, base: str | None = None) -> str:
        """A Turtle skeleton of exactly what is missing; placeholders are 0.0 with TODO comments.

        Adding the file as it is to the model meets the requirements (with wrong values); filling
        in the placeholders makes them right.
        """
        return _Template(self, base).render()


# ---- translating a SHACL report into requirements ---------------------------------------------

def _class_fill(kb: Graph, cls: URIRef) -> list[tuple[URIRef, URIRef]]:
    """Datatype properties whose rdfs:domain is ``cls`` (a pose's x..yaw), with their range."""
    props = []
    for p in kb.subjects(RDFS.domain, cls):
        rng = kb.value(p, RDFS.range)
        if isinstance(p, URIRef) and isinstance(rng, URIRef) and is_datatype(kb, rng):
            props.append((p, rng))
    rank = {p: i for i, p in enumerate(_PREFERRED)}
    return sorted(props, key=lambda pr: (rank.get(pr[0], len(rank)), str(pr[0])))


def _type_words(kb: Graph, cls: URIRef) -> str:
    fill = _class_fill(kb, cls)
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


def _translate(result_graph: Graph, shapes: RequirementShapes, model: Graph, kb: Graph) -> list[Requirement]:
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


def subclass_axioms(kb: Graph, classes: Iterable[URIRef] = ()) -> Graph | None:
    """The subclass axioms pySHACL needs to check ``sh:class`` of classes that have subclasses, or None."""
    needed = [c for c in classes if (None, RDFS.subClassOf, c) in kb]
    if not needed:
        return None
    ont = Graph()
    for t in kb.triples((None, RDFS.subClassOf, None)):
        ont.add(t)
    return ont


def run_requirement_shapes(model: Graph, kb: Graph, shapes: RequirementShapes) -> Graph:
    """Validate ``model`` against generated shapes; returns pySHACL's report graph (model untouched)."""
    if not shapes.targets:
        return Graph()
    ont = subclass_axioms(kb, shapes.value_classes)
    _conforms, report, _text = validate(model, shacl_graph=shapes.graph, ont_graph=ont, inference="none",
                                        advanced=False, allow_warnings=True)
    assert isinstance(report, Graph)
    return report


def derive_requirements(model: Graph, kb: Graph, *, task_id: str | None = None) -> RequirementsResult:
    """A3: the additional modeling requirements of every robotized task (or only ``task_id``).

    Raises :class:`~kbplanner.core.errors.KnowledgeBaseError` when a robotized task names no or an unknown
    task specification, or the knowledge base is broken; a model that lacks information is a result.

    Example:
        >>> from kbplanner.knowledge.knowledge_base import load_kb
        >>> derive_requirements(Graph(), load_kb()).requirements
        []
    """
    t0 = time.perf_counter()
    shapes = requirement_shapes(model, kb, task_id=task_id)
    report = run_requirement_shapes(model, kb, shapes)
    reqs = _translate(report, shapes, model, kb)
    unmet: dict[URIRef, int] = {}
    for r in reqs:
        unmet[r.shape] = unmet.get(r.shape, 0) + len(r.elements)
    checks = [BindingCheck(task_id=bt.task.task_id, spec_id=bt.spec.spec_id, action_order=bt.action.order,
                           action_label=bt.action.label, skill_id=bt.action.skill.skill_id,
                           input_name=bt.binding.input.name, needs=bt.binding.words,
                           targets=len(bt.targets), unmet=unmet.get(bt.shape, 0))
              for bt in sorted(shapes.targets.values(),
                               key=lambda b: (b.task.task_id, b.action.order, b.binding.input.name))]
    dt = time.perf_counter() - t0
    log.info("%d requirements from %d bindings in %.2f s", len(reqs), len(checks), dt)
    return RequirementsResult(requirements=reqs, checks=checks, shapes=shapes, report=report, model=model,
                              kb=kb, seconds=dt)


# ---- the Turtle template ------------------------------------------------------------------------

_PLACEHOLDER: dict[URIRef, Literal] = {
    XSD.double: Literal(0.0), XSD.float: Literal("0.0", datatype=XSD.float),
    XSD.decimal: Literal("0.0", datatype=XSD.decimal), XSD.integer: Literal(0),
    XSD.boolean: Literal(False), XSD.dateTime: Literal("2000-01-01T00:00:00", datatype=XSD.dateTime),
}


def _placeholder(datatype: URIRef) -> Literal:
    if datatype in _PLACEHOLDER:
        return _PLACEHOLDER[datatype]
    return Literal("TODO", datatype=datatype if datatype != XSD.string else None)


class _Template:
    """Builds the Turtle skeleton of a :class:`RequirementsResult`."""

    def __init__(self, result: RequirementsResult, base: str | None) -> None:
        self.r = result
        self.kb = result.kb
        self.model = result.model
        self.base = base
        self.ns = Graph()
        bind_prefixes(self.ns)
        self.minted: dict[tuple[Any, ...], URIRef] = {}
        self.keys: dict[Node, str] = {}

    def _local(self, node: Node) -> str:
        if node in self.keys:
            return self.keys[node]
        gid = self.model.value(node, KBP.globalId)
        if gid is not None:
            return str(gid)
        text = str(node)
        return text.rstrip("/").rsplit("/", 1)[-1].rsplit("#", 1)[-1]

    def _n3(self, term: Node) -> str:
        return term.n3(self.ns.namespace_manager)

    def _node(self, key: tuple[Any, ...], cls: URIRef | None, local: str, base: str) -> tuple[URIRef, bool]:
        if key in self.minted:
            return self.minted[key], False
        kind = slug(label(self.kb, cls)) if cls is not None else "node"
        iri = mint(base, kind, local)
        self.minted[key] = iri
        self.keys[iri] = local
        return iri, True

    def _fill(self, subject: URIRef, cls: URIRef, out: dict[Node, list[tuple[Node, Node]]]) -> None:
        out.setdefault(subject, []).append((RDF.type, cls))
        for p, rng in _class_fill(self.kb, cls):
            out[subject].append((p, _placeholder(rng)))

    def _requirement(self, req: Requirement) -> tuple[list[str], dict[Node, list[tuple[Node, Node]]]]:
        bt = req.target
        b = bt.binding
        vc = b.input.value_class
        base = self.base or shape_base(bt.task.iri)
        comments = [f"# TODO requirement {req.number}: {req.task_id} action {req.action_order} "
                    f"'{req.action_label}' ({req.skill_id} {req.input_name})",
                    f"#   {req.problem}: {req.missing}",
                    f"#   for {len(req.elements)} element(s); replace every placeholder (0.0) "
                    "with real values"]
        if b.hint:
            comments.append(f"#   hint: {b.hint}")
        triples: dict[Node, list[tuple[Node, Node]]] = {}
        steps = steps_of(b.path)
        if req.problem == WRONG_TYPE:
            if isinstance(req.gap_node, URIRef) and vc is not None and not is_datatype(self.kb, vc):
                self._fill(req.gap_node, vc, triples)
            else:
                comments.append("#   TODO: replace the wrongly typed value in the model (cannot be added)")
            return comments, triples
        if steps is None:
            comments.append(f"#   TODO: add a value along {path_curies(self.kb, b.path)} "
                            "(not generated for this kind of path)")
            return comments, triples
        shared = f"{req.task_id}-{req.skill_id}-{slug(req.input_name)}"
        for el in req.elements:
            gap = walk(self.model, el.iri, b.path) or Gap(0, el.iri)
            parent: Node = gap.node
            for i in range(gap.index, len(steps)):
                step = steps[i]
                last = i == len(steps) - 1
                cls = vc if last else step_range(self.kb, step)
                pred = step.predicate if isinstance(step, PredicatePath) else None
                inv = step.path.predicate if isinstance(step, InversePath) and isinstance(
                    step.path, PredicatePath) else None
                if last and cls is not None and is_datatype(self.kb, cls):
                    if pred is not None:
                        triples.setdefault(parent, []).append((pred, _placeholder(cls)))
                    break
                step_pred = pred if pred is not None else inv
                p_label = slug(label(self.kb, step_pred)) if step_pred is not None else "value"
                if last or parent != el.iri:
                    key: tuple[Any, ...] = ("node", parent, i)
                    local = f"{self._local(parent)}-{p_label}"
                else:
                    key = ("shared", req.number, i)
                    local = shared
                node, new = self._node(key, cls, local, base)
                if pred is not None:
                    triples.setdefault(parent, []).append((pred, node))
                elif inv is not None:
                    triples.setdefault(node, []).append((inv, parent))
                if new:
                    if cls is not None:
                        self._fill(node, cls, triples)
                    else:
                        triples.setdefault(node, [])
                parent = node
        return comments, triples

    def render(self) -> str:
        lines = ["# Additional modeling requirements: a skeleton written by kbplanner (A3 -> A4).",
                 "# Fill in every placeholder, then add this file to the project (augmentation or a scenario",
                 "# overlay in project.toml) and run 'kbplanner requirements' again.",
                 f"@prefix kbp: <{KBP._NS}> .",
                 f"@prefix rdf: <{RDF}> .",
                 f"@prefix xsd: <{XSD}> .",
                 ""]
        self.ns.bind("rdf", RDF, override=True)
        for req in self.r.requirements:
            comments, triples = self._requirement(req)
            lines.extend(comments)
            for subject, pos in triples.items():
                seen: list[tuple[Node, Node]] = []
                for po in pos:
                    if po not in seen:
                        seen.append(po)
                if not seen:
                    continue
                body = " ;\n    ".join(
                    ("a" if p == RDF.type else self._n3(p)) + " " + self._n3(o) for p, o in seen)
                lines.append(f"{self._n3(subject)}\n    {body} .")
            lines.append("")
        if not self.r.requirements:
            lines.append("# Nothing is missing.")
        return "\n".join(lines) + "\n"
