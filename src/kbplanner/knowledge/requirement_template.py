"""Requirement template (A3, last part): a Turtle skeleton of exactly what the requirements say is missing.

:func:`render_template` (used by :meth:`kbplanner.knowledge.requirements.RequirementsResult.template`)
mints IRIs for the missing nodes and writes placeholder values with TODO comments; once filled in and
added to the project, the file meets the requirements (A3 -> A4).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rdflib import RDF, XSD, Graph, Literal, URIRef
from rdflib.term import Node

from kbplanner.core.iris import mint, slug
from kbplanner.core.rdf_io import bind_prefixes
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.binding_paths import (
    Gap,
    InversePath,
    PredicatePath,
    path_curies,
    step_range,
    steps_of,
    walk,
)
from kbplanner.knowledge.knowledge_base import is_datatype, label
from kbplanner.knowledge.requirement_rows import WRONG_TYPE, Requirement, class_fill
from kbplanner.knowledge.requirement_shapes import shape_base

_PLACEHOLDER: dict[URIRef, Literal] = {
    XSD.double: Literal(0.0), XSD.float: Literal("0.0", datatype=XSD.float),
    XSD.decimal: Literal("0.0", datatype=XSD.decimal), XSD.integer: Literal(0),
    XSD.boolean: Literal(False), XSD.dateTime: Literal("2000-01-01T00:00:00", datatype=XSD.dateTime),
}


def _placeholder(datatype: URIRef) -> Literal:
    if datatype in _PLACEHOLDER:
        return _PLACEHOLDER[datatype]
    return Literal("TODO", datatype=datatype if datatype != XSD.string else None)


def render_template(requirements: Sequence[Requirement], model: Graph, kb: Graph, base: str | None) -> str:
    """The Turtle skeleton of what ``requirements`` (derived from ``model`` and ``kb``) say is missing.

    Placeholders are 0.0 with TODO comments; IRIs are minted under ``base`` (default: the task's).
    """
    return _Template(requirements, model, kb, base).render()


class _Template:
    """Builds the Turtle skeleton of a list of requirements."""

    def __init__(self, requirements: Sequence[Requirement], model: Graph, kb: Graph,
                 base: str | None) -> None:
        self.requirements = requirements
        self.kb = kb
        self.model = model
        self.base = base
        self.ns = Graph()
        bind_prefixes(self.ns)
        self.minted: dict[tuple[Any, ...], URIRef] = {}
        self.taken: set[URIRef] = set()
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
        n = 2
        while iri in self.taken:  # another node (another path or requirement) has this name: never share it
            iri = mint(base, kind, f"{local}-{n}")
            n += 1
        self.minted[key] = iri
        self.taken.add(iri)
        self.keys[iri] = local
        return iri, True

    def _fill(self, subject: URIRef, cls: URIRef, out: dict[Node, list[tuple[Node, Node]]]) -> None:
        out.setdefault(subject, []).append((RDF.type, cls))
        for p, rng in class_fill(self.kb, cls):
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
                    # one node per subject and predicate: the same path from the same node is one value,
                    # any other predicate (another requirement's) gets a node of its own
                    key: tuple[Any, ...] = ("node", parent, step_pred, inv is not None, cls)
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
        for req in self.requirements:
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
        if not self.requirements:
            lines.append("# Nothing is missing.")
        return "\n".join(lines) + "\n"
