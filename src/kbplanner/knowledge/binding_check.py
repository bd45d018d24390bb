"""Binding check (A2, when the knowledge base is loaded): every input binding is well formed.

A malformed binding must never reach the SHACL engine: pyshacl would stop with a raw ``ShapeLoadError``
(two ``sh:path`` values on a generated shape) or silently check the wrong thing. :func:`check_binding`
looks at one binding's own triples (exactly one ``kbp:bindsInput``, exactly one ``kbp:bindingPath``, at
most one ``kbp:pathStart`` of a known kind) and reads its path strictly (every property declared, lists
well formed, one path form per node); :func:`check_bindings` does it for every binding of the knowledge
base and is called by the project loader right after :func:`kbplanner.knowledge.knowledge_base.load_kb`.
Each failure is a :class:`~kbplanner.core.errors.KnowledgeBaseError` naming the file, the binding IRI
and the fix.
"""

from __future__ import annotations

from rdflib import RDF, Graph, URIRef
from rdflib.term import Node

from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.binding_paths import ShaclPath, read_path
from kbplanner.knowledge.knowledge_base import SH, curie, source_of

_PATH_FORMS = (SH.inversePath, SH.alternativePath, SH.zeroOrMorePath, SH.oneOrMorePath, SH.zeroOrOnePath)
_STARTS = (KBP.StartAtElement, KBP.StartAtTask)


def _terms(kb: Graph, values: list[Node]) -> str:
    return ", ".join(sorted(curie(kb, v) if isinstance(v, URIRef) else str(v) for v in values))


def _check_path_node(kb: Graph, node: Node, *, file: str | None, where: str, seen: set[Node]) -> None:
    """The RDF structure of a SHACL path: well-formed lists, one path form with one value per node."""
    if node in seen or node == RDF.nil:
        return
    seen.add(node)
    if (node, RDF.first, None) in kb or (node, RDF.rest, None) in kb:
        cell: Node = node
        cells: set[Node] = set()
        while cell != RDF.nil:
            firsts, rests = list(kb.objects(cell, RDF.first)), list(kb.objects(cell, RDF.rest))
            if len(firsts) != 1 or len(rests) != 1 or cell in cells:
                raise KnowledgeBaseError(
                    "binding path is a broken RDF list (a list cell without exactly one rdf:first and "
                    "one rdf:rest, or a cycle)", file=file, element=where,
                    fix="write the sequence in Turtle list syntax: kbp:bindingPath ( p1 p2 )")
            cells.add(cell)
            _check_path_node(kb, firsts[0], file=file, where=where, seen=seen)
            cell = rests[0]
        return
    if isinstance(node, URIRef):
        return
    forms = [(p, list(kb.objects(node, p))) for p in _PATH_FORMS if (node, p, None) in kb]
    if len(forms) > 1 or any(len(vals) > 1 for _, vals in forms):
        given = "; ".join(f"{curie(kb, p)} {_terms(kb, vals)}" for p, vals in forms)
        raise KnowledgeBaseError(
            f"binding path node mixes SHACL path forms or repeats one ({given})",
            file=file, element=where,
            fix="give each path node exactly one of sh:inversePath, sh:alternativePath, sh:zeroOrMorePath, "
                "sh:oneOrMorePath, sh:zeroOrOnePath with one value; nest nodes for combinations")
    for _, vals in forms:
        _check_path_node(kb, vals[0], file=file, where=where, seen=seen)


def check_binding(kb: Graph, binding: Node, *, action: Node | None = None) -> ShaclPath:
    """Check one input binding of ``kb``; its path, read. ``action`` (the action that has it) is
    used in messages and to find a file when the binding is a blank node."""
    file = source_of(kb, binding) or (source_of(kb, action) if action is not None else None)
    where = curie(kb, binding) if isinstance(binding, URIRef) else (
        f"a binding of {curie(kb, action)}" if action is not None else "a blank-node binding")
    inputs = list(kb.objects(binding, KBP.bindsInput))
    if len(inputs) != 1:
        raise KnowledgeBaseError(
            f"input binding has {len(inputs)} kbp:bindsInput values"
            + (f" ({_terms(kb, inputs)})" if inputs else ""), file=file, element=where,
            fix="give each kbp:InputBinding exactly one kbp:bindsInput (one binding per skill input)")
    paths = list(kb.objects(binding, KBP.bindingPath))
    if not paths:
        raise KnowledgeBaseError(
            f"binding of {curie(kb, inputs[0])} has no kbp:bindingPath", file=file, element=where,
            fix="add kbp:bindingPath with a SHACL path, e.g. ( kbp:storedIn kbp:pickupLocation )")
    if len(paths) > 1:
        raise KnowledgeBaseError(
            f"binding of {curie(kb, inputs[0])} has {len(paths)} kbp:bindingPath values "
            f"({_terms(kb, paths) if all(isinstance(p, URIRef) for p in paths) else 'lists or path nodes'}); "
            "a binding is one SHACL path", file=file, element=where,
            fix="keep one kbp:bindingPath: a sequence is one list ( p1 p2 ), a choice is "
                "[ sh:alternativePath ( p1 p2 ) ]")
    starts = list(kb.objects(binding, KBP.pathStart))
    if len(starts) > 1 or any(s not in _STARTS for s in starts):
        raise KnowledgeBaseError(
            f"binding has kbp:pathStart {_terms(kb, starts)}", file=file, element=where,
            fix="give at most one kbp:pathStart: kbp:StartAtElement (the default) or kbp:StartAtTask")
    _check_path_node(kb, paths[0], file=file, where=where, seen=set())
    return read_path(kb, paths[0], owner=binding)


def check_bindings(kb: Graph) -> int:
    """Check every input binding of ``kb`` (those of actions and every ``kbp:InputBinding``); how many.

    Example:
        >>> from kbplanner.knowledge.knowledge_base import load_kb
        >>> check_bindings(load_kb()) > 0
        True
    """
    owners: dict[Node, Node | None] = {b: a for a, b in kb.subject_objects(KBP.hasBinding)}
    for b in kb.subjects(RDF.type, KBP.InputBinding):
        owners.setdefault(b, None)
    for b, action in sorted(owners.items(), key=lambda kv: str(kv[0])):
        check_binding(kb, b, action=action)
    return len(owners)
