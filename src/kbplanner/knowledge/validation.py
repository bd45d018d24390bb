"""Validation of the augmented 4D model (A4, A5): a standard SHACL report plus readable rows.

``validate_model(model, kb)`` validates a *copy* of the model (the caller's graph is never modified)
against the well-formedness shapes of ``shapes/`` (schedule, robotized tasks, poses, boxes, elements,
doors, storages, site layout, jobsite parameters), any ``extra_shapes`` and, unless
``include_requirements=False``, the requirement shapes generated from the knowledge base (A3), so an
augmented model conforms only when every additional modeling requirement is met. The copy also holds
the knowledge base's class hierarchy and its specification, skill and action index, so that SHACL-SPARQL
constraints can check, e.g., that a task names a task specification that exists.
Returns a :class:`ValidationResult` (``conforms``, ``report_graph``, ``rows``, ``text()``).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pyshacl import validate
from rdflib import RDF, RDFS, Graph, Literal, URIRef
from rdflib.compare import to_canonical_graph
from rdflib.plugins.sparql import prepareQuery
from rdflib.term import Node

from kbplanner.core.output_dirs import FILE_SIGNATURE
from kbplanner.core.outputs import atomic_write_text
from kbplanner.core.rdf_io import bind_prefixes, parse_turtle
from kbplanner.core.resources import shape_files
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import SH, curie
from kbplanner.knowledge.requirement_shapes import RequirementShapes, requirement_shapes

log = logging.getLogger(__name__)

_SEVERITY = {SH.Violation: "Violation", SH.Warning: "Warning", SH.Info: "Info"}
_SEVERITY_ORDER = {"Violation": 0, "Warning": 1, "Info": 2}


@dataclass(frozen=True)
class ValidationRow:
    """One SHACL result in words: severity, the node (GlobalId or task id and name), path, value, message."""

    severity: str
    focus: str
    focus_label: str
    path: str
    value: str
    message: str
    shape: str
    kind: str

    def line(self) -> str:
        """The row as one line of text."""
        who = self.focus + (f" '{self.focus_label}'" if self.focus_label else "")
        where = f" {self.path}" if self.path else ""
        val = f" = {self.value}" if self.value else ""
        return f"[{self.severity}] {who}{where}{val}: {self.message}"


@dataclass
class ValidationResult:
    """The outcome of :func:`validate_model`."""

    conforms: bool
    report_graph: Graph
    rows: list[ValidationRow] = field(default_factory=list)
    seconds: float = 0.0
    shapes: RequirementShapes | None = None

    @property
    def violations(self) -> list[ValidationRow]:
        """The rows of severity Violation."""
        return [r for r in self.rows if r.severity == "Violation"]

    def text(self) -> str:
        """A readable report: the verdict, then one line per result."""
        n_v = len(self.violations)
        head = ("The model conforms." if self.conforms
                else f"The model does not conform: {n_v} violation(s).")
        others = len(self.rows) - n_v
        if others:
            head += f" {others} warning(s)/note(s)."
        return "\n".join([head, *(r.line() for r in self.rows)]) + "\n"

    def write(self, path: Path) -> None:
        """Write the report as Turtle (standard SHACL, canonical blank nodes), or as text for ``.txt``.

        The first line is kbplanner's signature (a Turtle comment), so that a later run may replace the
        file and no other (the output rule, :mod:`kbplanner.core.output_dirs`).
        """
        path = Path(path)
        head = f"{FILE_SIGNATURE} validate: the SHACL validation report\n"
        if path.suffix == ".txt":
            atomic_write_text(path, head + self.text())
            return
        canon = to_canonical_graph(self.report_graph)
        out = Graph()
        bind_prefixes(out)
        out.bind("sh", SH)
        for t in canon:
            out.add(t)
        atomic_write_text(path, head + out.serialize(format="turtle"))


_TARGETS = (SH.targetClass, SH.targetNode, SH.targetSubjectsOf, SH.targetObjectsOf)


def flatten_property_shapes(g: Graph) -> Graph:
    """Give each ``sh:property`` shape of a targeted node shape that node shape's targets, and unlink it.

    Equivalent results (same focus nodes, same source shape), but pySHACL validates a targeted
    property shape once over all focus nodes instead of once per focus node: about 5x faster on
    thousands of poses.
    """
    for node in sorted({s for p in _TARGETS for s in g.subjects(p, None)}, key=str):
        targets = [(p, o) for p in _TARGETS for o in g.objects(node, p)]
        for prop in sorted(g.objects(node, SH.property), key=str):
            if not isinstance(prop, URIRef) or any((prop, p, None) in g for p in _TARGETS):
                continue
            if sum(1 for _ in g.subjects(SH.property, prop)) != 1:
                continue  # shared by several node shapes: leave as written
            for p, o in targets:
                g.add((prop, p, o))
            g.remove((node, SH.property, prop))
    return g


def well_formedness_shapes(extra: Graph | None = None) -> Graph:
    """The shapes of ``shapes/*.ttl`` (plus ``extra``) in one graph, property shapes flattened."""
    g = Graph()
    for p in shape_files():
        parse_turtle(p, into=g)
    if extra is not None:
        for t in extra:
            g.add(t)
    return flatten_property_shapes(g)


SHAPES_NS = "https://w3id.org/kbplanner/shapes#"
_INDEX_TYPES = (KBP.TaskSpecification, KBP.Skill, KBP.Action)
_INDEX_PROPS = (KBP.specificationId, KBP.skillId)


class _PreparedQueryGraph(Graph):
    """A graph that parses each SPARQL text once: pySHACL runs a SHACL-SPARQL constraint's text again
    for every focus node (with the focus node bound), and parsing is most of the cost of such a query."""

    def __init__(self) -> None:
        super().__init__()
        self._prepared: dict[tuple[str, tuple[tuple[str, str], ...]], Any] = {}

    def query(self, query_object: Any, processor: Any = "sparql", result: Any = "sparql",
              initNs: Any = None, initBindings: Any = None,
              use_store_provided: bool = True, **kwargs: Any) -> Any:
        """``Graph.query`` with the parsed form of a query text kept for the next call."""
        if isinstance(query_object, str) and processor == "sparql":
            ns = dict(initNs) if initNs else dict(self.namespaces())
            key = (query_object, tuple(sorted((str(k), str(v)) for k, v in ns.items())))
            prepared = self._prepared.get(key)
            if prepared is None:
                prepared = prepareQuery(query_object, initNs=ns)
                self._prepared[key] = prepared
            query_object = prepared
        return super().query(query_object, processor, result, initNs, initBindings, use_store_provided,
                             **kwargs)


def _data_copy(model: Graph, kb: Graph) -> Graph:
    """The model plus the KB class hierarchy and KB index, in a new graph."""
    data = _PreparedQueryGraph()
    bind_prefixes(data)
    data.bind("kbps", SHAPES_NS)
    data.addN((s, p, o, data) for s, p, o in model)
    for t in kb.triples((None, RDFS.subClassOf, None)):
        data.add(t)
    for cls in _INDEX_TYPES:
        for s in kb.subjects(RDF.type, cls):
            data.add((s, RDF.type, cls))
    for p in _INDEX_PROPS:
        for t in kb.triples((None, p, None)):
            data.add(t)
    return data


def _focus_words(data: Graph, node: Node, *, owner: bool = True) -> tuple[str, str]:
    """How a node is named in a row: GlobalId, task id, or (for a pose or box) whose property it is."""
    gid = data.value(node, KBP.globalId)
    if gid is not None:
        return str(gid), str(data.value(node, RDFS.label) or "")
    tid = data.value(node, KBP.taskId)
    if tid is not None:
        return f"task {tid}", str(data.value(node, RDFS.label) or "")
    lbl = data.value(node, RDFS.label)
    if lbl is None and owner:
        for s, p in sorted(data.subject_predicates(node), key=lambda sp: (str(sp[0]), str(sp[1]))):
            sid, slabel = _focus_words(data, s, owner=False)
            if slabel or data.value(s, KBP.globalId) is not None or data.value(s, KBP.taskId) is not None:
                return f"{curie(data, p)} of {sid}", slabel
    return curie(data, node), str(lbl) if lbl is not None else ""


def _path_words(report: Graph, data: Graph, path: Node | None) -> str:
    if path is None:
        return ""
    if isinstance(path, URIRef):
        return curie(data, path)
    items = list(report.items(path)) if (path, RDF.first, None) in report else []
    if items:
        return " / ".join(curie(data, i) for i in items)
    inv = report.value(path, SH.inversePath)
    if inv is not None:
        return "^" + curie(data, inv)
    return "(path)"


def _rows(report: Graph, data: Graph, req: RequirementShapes | None) -> list[ValidationRow]:
    rows = []
    for res in report.subjects(RDF.type, SH.ValidationResult):
        focus = report.value(res, SH.focusNode)
        shape = report.value(res, SH.sourceShape)
        sev_node = report.value(res, SH.resultSeverity)
        sev = _SEVERITY.get(sev_node, "Violation") if isinstance(sev_node, URIRef) else "Violation"
        msgs = sorted(str(m) for m in report.objects(res, SH.resultMessage))
        value = report.value(res, SH.value)
        focus_id, focus_label = _focus_words(data, focus) if focus is not None else ("", "")
        if value is not None and not isinstance(value, Literal):
            vid, vlabel = _focus_words(data, value)
            value_text = vid + (f" '{vlabel}'" if vlabel else "")
        else:
            value_text = str(value) if value is not None else ""
        kind = "requirement" if req is not None and shape in req.targets else "well-formedness"
        rows.append(ValidationRow(
            severity=sev, focus=focus_id, focus_label=focus_label,
            path=_path_words(report, data, report.value(res, SH.resultPath)), value=value_text,
            message=msgs[0] if msgs else "", shape=curie(data, shape) if shape is not None else "",
            kind=kind))
    rows.sort(key=lambda r: (_SEVERITY_ORDER[r.severity], r.kind != "well-formedness", r.focus, r.path,
                             r.value, r.message))
    return rows


def validate_model(model: Graph, kb: Graph, *, extra_shapes: Graph | None = None,
                   include_requirements: bool = True) -> ValidationResult:
    """A4: validate (a copy of) the model; never modifies ``model``.

    Example:
        >>> from kbplanner.knowledge.knowledge_base import load_kb
        >>> validate_model(Graph(), load_kb()).conforms
        True
    """
    t0 = time.perf_counter()
    shapes = well_formedness_shapes(extra_shapes)
    req: RequirementShapes | None = None
    if include_requirements:
        req = requirement_shapes(model, kb, skip_unknown=True)
        for t in req.graph:
            shapes.add(t)
    data = _data_copy(model, kb)
    conforms, report, _text = validate(data, shacl_graph=shapes, inference="none", advanced=False,
                                       allow_warnings=True)
    assert isinstance(report, Graph)
    bind_prefixes(report)
    report.bind("sh", SH)
    rows = _rows(report, data, req)
    dt = time.perf_counter() - t0
    log.info("validated %d triples in %.2f s: %s", len(model), dt,
             "conforms" if conforms else "does not conform")
    return ValidationResult(conforms=bool(conforms), report_graph=report, rows=rows, seconds=dt, shapes=req)
