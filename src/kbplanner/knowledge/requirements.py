"""Additional modeling requirements (A3): what the 4D model lacks for the skills of its robotized tasks.

``derive_requirements(model, kb)`` generates the requirement shapes
(:mod:`kbplanner.knowledge.requirement_shapes`),
validates the model against them with pySHACL (the caller's graph is never modified), and translates
each violation into a row: task, action, skill, input, element, what is missing in words (from the
path's property labels and ranges) and how to add it (:mod:`kbplanner.knowledge.requirement_rows`).
Violations with the same cause are grouped, so
eleven frames without a grasp point read as one requirement with eleven elements. Inputs the model
already carries produce none. ``RequirementsResult.template()`` writes a Turtle skeleton of exactly
what is missing (minted IRIs, placeholder values; :mod:`kbplanner.knowledge.requirement_template`)
that, once filled in and added to the project, meets the requirements.
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
from rdflib import RDF, RDFS, Graph, Literal, URIRef

from kbplanner.core.iris import mint
from kbplanner.core.outputs import json_text
from kbplanner.core.rdf_io import bind_prefixes
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.requirement_rows import Requirement, translate_report
from kbplanner.knowledge.requirement_shapes import RequirementShapes, requirement_shapes, shape_base
from kbplanner.knowledge.requirement_template import render_template

log = logging.getLogger(__name__)


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
        return render_template(self.requirements, self.model, self.kb, base)



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
    reqs = translate_report(report, shapes, model, kb)
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
