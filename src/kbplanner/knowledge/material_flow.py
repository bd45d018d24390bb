"""A2/A6 material flow: where a task's material waits, as its task specification declares it.

A specification whose actions pick (skill kind ``kbp:MoveManipulatorAndGrasp``) names, with
``kbp:materialStoragePath``, a SHACL property path from each element to the ``kbp:MaterialStorage``
where it waits (the wall-framing specifications: ``kbp:storedIn``). The world (A6) places the elements
at what that path reaches; nothing else decides it. A specification without a pick handles no
material: its elements are targets the robot works on where they are or will be (layout marking,
inspection), never bodies at a storage.

The path is rendered to SPARQL text from knowledge-base IRIs only (:func:`sparql_path`) and run with
``initBindings`` ``{"focus": element}``, like every skill input (B2).

Example:
    >>> from kbplanner.knowledge.knowledge_base import load_kb
    >>> from kbplanner.knowledge.task_specs import task_specification
    >>> kb = load_kb()
    >>> flow = material_flow(kb, task_specification(kb, "I-W-F-#1"))
    >>> flow.handles_material, flow.query.split("?focus ")[1][:40]
    (True, '<https://w3id.org/kbplanner/ontology#sto')
    >>> material_flow(kb, task_specification(kb, "L-M-#1")).handles_material
    False
"""

from __future__ import annotations

from dataclasses import dataclass

from rdflib import Graph, URIRef
from rdflib.term import Identifier

from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.core.graph_memo import memo
from kbplanner.core.named_queries import evaluates_text
from kbplanner.core.sparql_cache import prepared_text
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.binding_paths import (
    AlternativePath,
    InversePath,
    PredicatePath,
    SequencePath,
    ShaclPath,
    read_path,
    sparql_path,
)
from kbplanner.knowledge.knowledge_base import curie, source_of
from kbplanner.knowledge.task_specs import TaskSpecification

_QUERY_HEAD = "SELECT ?focus ?value WHERE { ?focus "
_QUERY_TAIL = " ?value . }"


@dataclass(frozen=True)
class MaterialFlow:
    """Whether a specification handles material and, if so, the query from an element to its storage."""

    spec_id: str
    handles_material: bool
    query: str  # constant SPARQL text ("" when no material is handled)
    every_focus: bool = False  # the path has no repetition: the query without ?focus bound gives each one's

    def storages(self, model: Graph, element: Identifier) -> list[URIRef]:
        """The storages the path reaches from ``element`` (sorted; empty when the model lacks them).

        On a loaded model known unedited (:func:`kbplanner.core.graph_memo.memo`), the query runs once
        without ``?focus`` bound and each element's storages are looked up in its rows (a whole-building
        run asks for every element of every task): the same storages."""
        if not self.query:
            return []
        evaluated = evaluates_text(model)
        kept = memo(model) if self.every_focus and not evaluated else None
        if kept is not None:
            key = ("material_flow.storages", self.query)
            if key not in kept:
                found: dict[Identifier, set[URIRef]] = {}
                for r in model.query(prepared_text(self.query) or self.query):
                    if isinstance(r[1], URIRef):  # type: ignore[index]
                        found.setdefault(r[0], set()).add(r[1])  # type: ignore[index, arg-type]
                kept[key] = {k: tuple(sorted(v, key=str)) for k, v in found.items()}
            return list(kept[key].get(element, ()))
        prepared = None if evaluated else prepared_text(self.query)  # parsed once, kept
        rows = model.query(prepared or self.query, initBindings={"focus": element})
        return sorted({r[1] for r in rows if isinstance(r[1], URIRef)}, key=str)  # type: ignore[index]


def material_flow(kb: Graph, spec: TaskSpecification) -> MaterialFlow:
    """The material flow of ``spec`` (see module docstring).

    Raises:
        KnowledgeBaseError: the specification picks but declares no ``kbp:materialStoragePath``.
    """
    picks = any(a.skill.kind == KBP.MoveManipulatorAndGrasp for a in spec.actions)
    node = kb.value(spec.iri, KBP.materialStoragePath)
    if not picks:
        return MaterialFlow(spec.spec_id, False, "")
    if node is None:
        raise KnowledgeBaseError(
            f"task specification {spec.spec_id} picks material but does not say where it waits",
            file=source_of(kb, spec.iri), element=curie(kb, spec.iri),
            fix="add kbp:materialStoragePath with a SHACL path from the element to its kbp:MaterialStorage, "
                "e.g. kbp:materialStoragePath kbp:storedIn")
    path = read_path(kb, node, owner=spec.iri)
    return MaterialFlow(spec.spec_id, True, _QUERY_HEAD + sparql_path(path) + _QUERY_TAIL,
                        every_focus=without_repetition(path))


def without_repetition(path: ShaclPath) -> bool:
    """Whether ``path`` has no ``*``, ``+`` or ``?``: then the value query without ``?focus`` bound gives,
    for each focus, exactly the rows of the query with it bound (a zero-length path would also reach
    focus nodes that are in no triple)."""
    if isinstance(path, PredicatePath):
        return True
    if isinstance(path, InversePath):
        return without_repetition(path.path)
    if isinstance(path, SequencePath):
        return all(without_repetition(p) for p in path.steps)
    if isinstance(path, AlternativePath):
        return all(without_repetition(p) for p in path.options)
    return False
