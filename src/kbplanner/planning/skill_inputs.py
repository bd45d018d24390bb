"""B2, skill inputs: the value of every bound skill input, fetched by SPARQL generated from its binding.

An action of a task specification binds each model input of its skill to a SHACL property path
(:class:`~kbplanner.knowledge.task_specs.Binding`). The same path that A3 turns into a requirement shape is
rendered here as one constant SPARQL text per binding::

    SELECT ?focus ?value WHERE { ?focus <kbp:storedIn>/<kbp:pickupLocation> ?value }

built only from knowledge-base IRIs written by rdflib's own serialiser (``term.n3()``, see
:func:`kbplanner.knowledge.binding_paths.sparql_path`); nothing from the model (GlobalIds, names, element
IRIs)
ever becomes query text. The query is prepared once per binding and run with ``initBindings``
``{"focus": element}`` (or the task for ``kbp:StartAtTask``). ``?focus`` is also selected so that
stores that require bound variables to be projected (pyoxigraph) accept it.

The value is converted by the input's value class: ``kbp:Pose`` -> ``[x, y, z, roll, pitch, yaw]``
(named query ``plan_pose``), ``kbp:Box`` -> ``[minX, minY, minZ, maxX, maxY, maxZ]`` (``plan_box``),
an IRI (an element, a storage) -> the IRI text, a literal -> its Python value. A missing value is a
result, :class:`InputValue` with ``missing`` saying which input, which path and where it stops; the
plan marks the step infeasible with that reason.

Takes a model graph, a binding and a focus node; returns an :class:`InputValue`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from datetime import date, datetime, time
from decimal import Decimal
from functools import lru_cache
from typing import Any

from rdflib import Graph, Literal, URIRef
from rdflib.plugins.sparql.sparql import Query
from rdflib.term import BNode, Identifier, Node, _is_valid_uri

from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.core.graph_memo import memo
from kbplanner.core.named_queries import evaluates_text
from kbplanner.core.sparql_cache import prepare_text
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.binding_paths import (
    SequencePath,
    ShaclPath,
    path_curies,
    path_properties,
    sparql_path,
    walk,
)
from kbplanner.knowledge.knowledge_base import curie, select
from kbplanner.knowledge.material_flow import without_repetition
from kbplanner.knowledge.task_specs import Binding

log = logging.getLogger(__name__)

JsonValue = Any

# The only parts of a generated query that are not the rendered path: constants.
_QUERY_HEAD = "SELECT ?focus ?value WHERE { ?focus "
_QUERY_TAIL = " ?value . }"


@dataclass(frozen=True)
class InputValue:
    """The value of one skill input for one focus node, or why there is none.

    ``value`` is JSON-ready (a 6-list for poses and boxes, an IRI string, a number or a string);
    ``missing`` is None when a value was found, else a sentence naming the input, the path and where
    the model stops. ``notes`` records choices (several values found: the first is used).
    """

    name: str
    value: JsonValue
    missing: str | None = None
    notes: tuple[str, ...] = ()

    @property
    def found(self) -> bool:
        """True when the input has a value."""
        return self.missing is None


def _check_iris(path: ShaclPath, binding: Binding) -> None:
    for prop in path_properties(path):
        if not _is_valid_uri(str(prop)):
            raise KnowledgeBaseError(
                f"binding path property {str(prop)!r} is not a valid IRI (it contains a character such as "
                "<, >, \", {, }, | or a space)", element=str(binding.iri),
                fix="correct the property IRI of the kbp:bindingPath in the knowledge base")


def value_query(binding: Binding) -> str:
    """The constant SPARQL text that fetches ``binding``'s value from ``?focus``.

    Example:
        >>> from kbplanner.knowledge.knowledge_base import load_kb
        >>> from kbplanner.knowledge.task_specs import task_specification
        >>> b = task_specification(load_kb(), "I-W-F-#1").actions[0].bindings[0]
        >>> print(value_query(b).replace("https://w3id.org/kbplanner/ontology#", "kbp:"))
        SELECT ?focus ?value WHERE { ?focus (<kbp:storedIn>/<kbp:pickupLocation>) ?value . }
    """
    _check_iris(binding.path, binding)
    return _QUERY_HEAD + sparql_path(binding.path) + _QUERY_TAIL


@lru_cache(maxsize=1024)
def _prepared_text(text: str) -> Query:
    return prepare_text(text)


def prepared_query(binding: Binding) -> Query:
    """The prepared (parsed and translated) value query of ``binding``, cached per binding path."""
    return _prepared_text(value_query(binding))


def _plain(node: Node) -> JsonValue:
    """A literal's Python value in JSON-ready form; an IRI's text."""
    if isinstance(node, Literal):
        py = node.toPython()
        if isinstance(py, bool | int | float | str):
            return py
        if isinstance(py, Decimal):
            return float(py)
        if isinstance(py, datetime | date | time):
            return py.isoformat()
        return str(node)
    return str(node)


def _numbers(row: dict[str, Node | None], keys: tuple[str, ...], default: float | None) -> list[float] | None:
    out: list[float] = []
    for k in keys:
        v = row.get(k)
        if v is None:
            if default is None:
                return None
            out.append(default)
            continue
        py = v.toPython() if isinstance(v, Literal) else None
        try:
            out.append(float(py))  # type: ignore[arg-type]
        except (TypeError, ValueError):
            return None
    return out


def pose_numbers(graph: Graph, node: Node) -> list[float] | None:
    """``[x, y, z, roll, pitch, yaw]`` of a pose node (unset angles are 0), None when incomplete.

    Example:
        >>> pose_numbers(Graph(), URIRef("urn:x:nothing")) is None
        True
    """
    rows = select(graph, "plan_pose", pose=node)  # type: ignore[arg-type]
    for row in rows:
        xyz = _numbers(row, ("x", "y", "z"), None)
        angles = _numbers(row, ("roll", "pitch", "yaw"), 0.0)
        if xyz is not None and angles is not None:
            return xyz + angles
    return None


def box_numbers(graph: Graph, node: Node) -> list[float] | None:
    """``[minX, minY, minZ, maxX, maxY, maxZ]`` of a box node, None when incomplete."""
    for row in select(graph, "plan_box", box=node):  # type: ignore[arg-type]
        nums = _numbers(row, ("minX", "minY", "minZ", "maxX", "maxY", "maxZ"), None)
        if nums is not None:
            return nums
    return None


def _where_it_stops(graph: Graph, focus: Node, binding: Binding) -> str:
    """Where the path stops: ``it has no kbp:storedIn (step 1 of kbp:storedIn / kbp:pickupLocation)``."""
    path = path_curies(graph, binding.path)
    gap = walk(graph, focus, binding.path)
    if gap is None:
        return f"nothing at {path}"
    steps = binding.path.steps if isinstance(binding.path, SequencePath) else (binding.path,)
    who = "it" if gap.node == focus else curie(graph, gap.node)
    text = f"{who} has no {path_curies(graph, steps[gap.index])}"
    return text + (f" (step {gap.index + 1} of {path})" if len(steps) > 1 else "")


def _convert(graph: Graph, binding: Binding, node: Node) -> tuple[JsonValue, str | None]:
    """Convert a raw value by the input's value class: (value, None) or (None, why not)."""
    vc = binding.input.value_class
    name = binding.input.name
    if vc == KBP.Pose:
        nums = pose_numbers(graph, node)
        if nums is None:
            return None, (f"the value {curie(graph, node)} of input '{name}' is not a complete pose "
                          "(it needs kbp:x, kbp:y and kbp:z; roll, pitch and yaw default to 0)")
        return nums, None
    if vc == KBP.Box:
        nums = box_numbers(graph, node)
        if nums is None:
            return None, (f"the value {curie(graph, node)} of input '{name}' is not a complete box "
                          "(it needs kbp:minX, minY, minZ, maxX, maxY, maxZ)")
        return nums, None
    if isinstance(node, BNode):
        # A blank node has no stable name to hand over; its label would change from run to run.
        return None, (f"the value of input '{name}' is a blank node: give it an IRI in the model")
    return _plain(node), None


def _order(node: Node) -> tuple[bool, str]:
    return not isinstance(node, URIRef | Literal), str(node)


def _values(graph: Graph, binding: Binding, focus: Identifier) -> list[Node]:
    """The values ``binding``'s path reaches from ``focus``, sorted. On a loaded model known unedited
    (:func:`kbplanner.core.graph_memo.memo`) and a path without repetition, the query runs once without
    ``?focus`` bound and each focus is looked up in its rows (the same values)."""
    kept = memo(graph) if without_repetition(binding.path) and not evaluates_text(graph) else None
    if kept is None:
        result = graph.query(prepared_query(binding), initBindings={"focus": focus})
        return sorted({row[1] for row in result if row[1] is not None}, key=_order)  # type: ignore[index]
    key = ("skill_inputs.values", value_query(binding))
    if key not in kept:
        found: dict[Node, set[Node]] = {}
        for row in graph.query(prepared_query(binding)):
            if row[1] is not None:  # type: ignore[index]
                found.setdefault(row[0], set()).add(row[1])  # type: ignore[index]
        kept[key] = {k: tuple(sorted(v, key=_order)) for k, v in found.items()}
    return list(kept[key].get(focus, ()))


def resolve_input(graph: Graph, binding: Binding, focus: Identifier, *, describe: str = "") -> InputValue:
    """B2: the value of ``binding``'s input, starting at ``focus`` (an element or the task).

    ``describe`` names the focus in the reason when the value is missing (default: its short IRI).
    Several values: the first in sorted order is used and a note says so.
    """
    name = binding.input.name
    values = _values(graph, binding, focus)
    who = describe or curie(graph, focus)
    if not values:
        return InputValue(name, None, missing=(
            f"missing input '{name}' ({binding.words}) of {who}: {_where_it_stops(graph, focus, binding)}"))
    notes: tuple[str, ...] = ()
    if len(values) > 1:
        notes = (f"input '{name}': {len(values)} values at {path_curies(graph, binding.path)} for {who}; "
                 f"using {curie(graph, values[0])}",)
    value, why = _convert(graph, binding, values[0])
    if why is not None:
        return InputValue(name, None, missing=f"{why} ({who})", notes=notes)
    return InputValue(name, value, notes=notes)


def resolve_inputs(graph: Graph, bindings: tuple[Binding, ...], *, element: Identifier, task: Identifier,
                   element_name: str = "", task_name: str = "") -> list[InputValue]:
    """The values of several bindings of one action, each from the element or (StartAtTask) the task."""
    return [resolve_input(graph, b, task if b.starts_at_task else element,
                          describe=task_name if b.starts_at_task else element_name)
            for b in bindings]
