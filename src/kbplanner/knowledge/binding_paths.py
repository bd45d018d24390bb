"""Binding paths (A2-A3, B2): the SHACL property paths that bind a skill input to the 4D model.

An input binding of the knowledge base names a SHACL property path: an IRI, an RDF list (a sequence),
or a node with ``sh:inversePath``, ``sh:alternativePath``, ``sh:zeroOrMorePath``, ``sh:oneOrMorePath``
or ``sh:zeroOrOnePath``. ``read_path`` turns that RDF structure into a small typed tree; the tree is
copied into generated SHACL shapes (``copy_path``, A3), rendered as a SPARQL property path from
knowledge-base IRIs only (``sparql_path``, B2), described in words for users (``path_words``) and
walked through a model to find where information stops (``walk``).
"""

from __future__ import annotations

from dataclasses import dataclass

from rdflib import RDF, RDFS, Graph, URIRef
from rdflib.collection import Collection
from rdflib.term import BNode, Node

from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.knowledge.knowledge_base import SH, curie, is_declared_property, label, source_of


@dataclass(frozen=True)
class PredicatePath:
    """One property step."""

    predicate: URIRef


@dataclass(frozen=True)
class SequencePath:
    """Steps one after another."""

    steps: tuple[ShaclPath, ...]


@dataclass(frozen=True)
class InversePath:
    """A step followed backwards (object to subject)."""

    path: ShaclPath


@dataclass(frozen=True)
class AlternativePath:
    """Any one of several paths."""

    options: tuple[ShaclPath, ...]


@dataclass(frozen=True)
class RepeatPath:
    """``*`` (zeroOrMore), ``+`` (oneOrMore) or ``?`` (zeroOrOne) repetition of a path."""

    path: ShaclPath
    mode: str


ShaclPath = PredicatePath | SequencePath | InversePath | AlternativePath | RepeatPath

_REPEATS = {SH.zeroOrMorePath: "*", SH.oneOrMorePath: "+", SH.zeroOrOnePath: "?"}
_REPEAT_PRED = {v: k for k, v in _REPEATS.items()}


def _where(kb: Graph, owner: Node) -> tuple[str | None, str]:
    return source_of(kb, owner), curie(kb, owner)


def read_path(kb: Graph, node: Node, *, owner: Node) -> ShaclPath:
    """Read the SHACL path at ``node`` of ``kb``; ``owner`` (the binding) is named in errors.

    Every property of the path must be declared in the knowledge base, so that a typo in a binding
    is an error naming the binding's file rather than a requirement nobody can satisfy.
    """
    file, where = _where(kb, owner)
    if isinstance(node, URIRef):
        if node == RDF.nil:
            raise KnowledgeBaseError("binding path is an empty list", file=file, element=where,
                                     fix="give at least one property, e.g. kbp:bindingPath kbp:installedPose")
        if not is_declared_property(kb, node):
            raise KnowledgeBaseError(
                f"binding path uses the undeclared property {curie(kb, node)}",
                file=file, element=where,
                fix=f"declare {curie(kb, node)} as an owl:ObjectProperty or owl:DatatypeProperty "
                    "(with rdfs:label and rdfs:range) in the knowledge base, or correct its spelling",
            )
        return PredicatePath(node)
    if (node, RDF.first, None) in kb:
        items = list(Collection(kb, node))
        if not items:
            raise KnowledgeBaseError("binding path is an empty list", file=file, element=where,
                                     fix="give at least one property")
        steps = tuple(read_path(kb, item, owner=owner) for item in items)
        return steps[0] if len(steps) == 1 else SequencePath(steps)
    inverse = kb.value(node, SH.inversePath)
    if inverse is not None:
        return InversePath(read_path(kb, inverse, owner=owner))
    alternatives = kb.value(node, SH.alternativePath)
    if alternatives is not None:
        opts = tuple(read_path(kb, item, owner=owner) for item in Collection(kb, alternatives))
        if len(opts) < 2:
            raise KnowledgeBaseError("sh:alternativePath needs a list of at least two paths",
                                     file=file, element=where, fix="write sh:alternativePath ( p1 p2 )")
        return AlternativePath(opts)
    for pred, mode in _REPEATS.items():
        inner = kb.value(node, pred)
        if inner is not None:
            return RepeatPath(read_path(kb, inner, owner=owner), mode)
    raise KnowledgeBaseError(
        "binding path is not a SHACL property path",
        file=file, element=where,
        fix="use a property IRI, a list ( p1 p2 ) for a sequence, or [ sh:inversePath p ] and the other "
            "SHACL path forms",
    )


def copy_path(path: ShaclPath, into: Graph) -> Node:
    """Write ``path`` into ``into`` as SHACL path syntax and return its root node."""
    if isinstance(path, PredicatePath):
        return path.predicate
    if isinstance(path, SequencePath):
        head = BNode()
        Collection(into, head, [copy_path(s, into) for s in path.steps])
        return head
    node = BNode()
    if isinstance(path, InversePath):
        into.add((node, SH.inversePath, copy_path(path.path, into)))
    elif isinstance(path, AlternativePath):
        lst = BNode()
        Collection(into, lst, [copy_path(o, into) for o in path.options])
        into.add((node, SH.alternativePath, lst))
    else:
        into.add((node, _REPEAT_PRED[path.mode], copy_path(path.path, into)))
    return node


def sparql_path(path: ShaclPath) -> str:
    """The path as SPARQL 1.1 property path text, built only from IRIs of the knowledge base.

    Example:
        >>> from kbplanner.core.vocab import KBP
        >>> sparql_path(SequencePath((PredicatePath(KBP.storedIn), PredicatePath(KBP.pickupLocation))))
        '(<https://w3id.org/kbplanner/ontology#storedIn>/<https://w3id.org/kbplanner/ontology#pickupLocation>)'
    """
    if isinstance(path, PredicatePath):
        return path.predicate.n3()
    if isinstance(path, SequencePath):
        return "(" + "/".join(sparql_path(s) for s in path.steps) + ")"
    if isinstance(path, InversePath):
        return "^" + sparql_path(path.path)
    if isinstance(path, AlternativePath):
        return "(" + "|".join(sparql_path(o) for o in path.options) + ")"
    return "(" + sparql_path(path.path) + ")" + path.mode


def path_properties(path: ShaclPath) -> list[URIRef]:
    """Every property IRI the path mentions, in order."""
    if isinstance(path, PredicatePath):
        return [path.predicate]
    if isinstance(path, SequencePath | AlternativePath):
        parts = path.steps if isinstance(path, SequencePath) else path.options
        return [p for part in parts for p in path_properties(part)]
    return path_properties(path.path)


def path_curies(graph: Graph, path: ShaclPath) -> str:
    """Compact text of the path: ``kbp:storedIn / kbp:pickupLocation``."""
    if isinstance(path, PredicatePath):
        return curie(graph, path.predicate)
    if isinstance(path, SequencePath):
        return " / ".join(path_curies(graph, s) for s in path.steps)
    if isinstance(path, InversePath):
        return "^" + path_curies(graph, path.path)
    if isinstance(path, AlternativePath):
        return "(" + " | ".join(path_curies(graph, o) for o in path.options) + ")"
    return "(" + path_curies(graph, path.path) + ")" + path.mode


def _step_words(kb: Graph, path: ShaclPath) -> str:
    if isinstance(path, PredicatePath):
        return label(kb, path.predicate)
    if isinstance(path, InversePath):
        return f"is {_step_words(kb, path.path)} of"
    if isinstance(path, AlternativePath):
        return "(" + " or ".join(_step_words(kb, o) for o in path.options) + ")"
    if isinstance(path, RepeatPath):
        how = {"*": "zero or more times", "+": "one or more times", "?": "optionally"}[path.mode]
        return f"{_step_words(kb, path.path)} ({how})"
    return path_words(kb, path)


def step_range(kb: Graph, step: ShaclPath) -> URIRef | None:
    """The class a step leads to: rdfs:range of a property, rdfs:domain of an inverse one."""
    if isinstance(step, PredicatePath):
        r = kb.value(step.predicate, RDFS.range)
        return r if isinstance(r, URIRef) else None
    if isinstance(step, InversePath) and isinstance(step.path, PredicatePath):
        d = kb.value(step.path.predicate, RDFS.domain)
        return d if isinstance(d, URIRef) else None
    return None


def path_words(kb: Graph, path: ShaclPath, value_class: URIRef | None = None) -> str:
    """The path in words from property labels and ranges.

    Example: ``stored in -> material storage -> robot pickup location (pose)``.
    """
    steps = path.steps if isinstance(path, SequencePath) else (path,)
    parts: list[str] = []
    for i, step in enumerate(steps):
        parts.append(_step_words(kb, step))
        if i < len(steps) - 1:
            rng = step_range(kb, step)
            if rng is not None:
                parts.append(label(kb, rng))
    text = " -> ".join(parts)
    if value_class is not None:
        text += f" ({label(kb, value_class)})"
    return text


def steps_of(path: ShaclPath) -> tuple[ShaclPath, ...] | None:
    """The steps of a path that can be walked one at a time (predicates and inverses), else None."""
    steps = path.steps if isinstance(path, SequencePath) else (path,)
    for s in steps:
        if isinstance(s, PredicatePath):
            continue
        if isinstance(s, InversePath) and isinstance(s.path, PredicatePath):
            continue
        return None
    return steps


def follow(graph: Graph, node: Node, step: ShaclPath) -> list[Node]:
    """Values reached from ``node`` over one walkable step, sorted for determinism."""
    if isinstance(step, PredicatePath):
        return sorted(graph.objects(node, step.predicate), key=str)
    if isinstance(step, InversePath) and isinstance(step.path, PredicatePath):
        return sorted(graph.subjects(step.path.predicate, node), key=str)
    raise ValueError("not a walkable step")


@dataclass(frozen=True)
class Gap:
    """Where a walk along a path stopped: ``node`` lacks step number ``index`` (0-based)."""

    index: int
    node: Node


def walk(graph: Graph, start: Node, path: ShaclPath) -> Gap | None:
    """Follow a walkable path from ``start``; the first node (in sorted order) that lacks the next step.

    Returns None when the path reaches a value or is not walkable step by step.
    """
    steps = steps_of(path)
    if steps is None:
        return None
    frontier: list[Node] = [start]
    for i, step in enumerate(steps):
        nxt: list[Node] = []
        first_gap: Node | None = None
        for n in frontier:
            vals = follow(graph, n, step)
            if not vals and first_gap is None:
                first_gap = n
            nxt.extend(vals)
        if not nxt:
            return Gap(i, first_gap if first_gap is not None else start)
        frontier = sorted(set(nxt), key=str)
    return None
