"""The construction robot knowledge base (A1-A2 input): loading it and naming its terms in messages.

``load_kb(extra)`` reads the ontology and the knowledge base that ship with kbplanner
(``ontology/*.ttl`` and ``ontology/kb/*.ttl``) plus a project's own KB extension files, and returns one
rdflib graph. Every subject is annotated with ``kbp:sourceFile`` (the file it was written in) so that an
error about a skill, an action or a robot names the file to fix. Skills, task specifications and robots
live in the namespace ``KB`` (``https://w3id.org/kbplanner/kb#``).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from functools import cache
from pathlib import Path

from rdflib import OWL, RDF, RDFS, XSD, Graph, Literal, Namespace, URIRef
from rdflib.plugins.sparql.sparql import Query
from rdflib.term import BNode, Identifier, Node

from kbplanner.core.named_queries import evaluates_text, prepared
from kbplanner.core.rdf_io import bind_prefixes, parse_turtle
from kbplanner.core.resources import data_dir, ontology_files
from kbplanner.core.sparql_cache import prepare_text
from kbplanner.core.vocab import KBP

log = logging.getLogger(__name__)

KB = Namespace("https://w3id.org/kbplanner/kb#")
SH = Namespace("http://www.w3.org/ns/shacl#")

PROPERTY_TYPES = (RDF.Property, OWL.ObjectProperty, OWL.DatatypeProperty, OWL.AnnotationProperty,
                  OWL.FunctionalProperty)
CLASS_TYPES = (OWL.Class, RDFS.Class)


def _display_path(path: Path) -> str:
    """A stable name for a file: relative to the package data root when it ships with kbplanner."""
    root = data_dir("ontology").parent
    try:
        return str(path.resolve().relative_to(root.resolve()))
    except ValueError:
        return str(path)


def load_kb(extra: Sequence[Path] = ()) -> Graph:
    """The ontology and knowledge base of kbplanner plus ``extra`` Turtle files (project extensions).

    Each subject gets ``kbp:sourceFile`` naming the file(s) it came from (see :func:`source_of`).

    Example:
        >>> kb = load_kb()
        >>> from kbplanner.knowledge.knowledge_base import KB
        >>> str(kb.value(KB["NV-1"], KBP.skillId))
        'NV-1'
    """
    kb = Graph()
    bind_prefixes(kb)
    kb.bind("kb", KB, override=True)
    kb.bind("sh", SH, override=True)
    files = [*ontology_files(), *[Path(p) for p in extra]]
    for path in files:
        part = parse_turtle(path)
        name = Literal(_display_path(path))
        subjects = set(part.subjects())
        for t in part:
            kb.add(t)
        for prefix, ns in part.namespaces():
            kb.bind(prefix, ns, override=False)
        for s in subjects:
            kb.add((s, KBP.sourceFile, name))
    log.info("knowledge base: %d files, %d triples", len(files), len(kb))
    return kb


def source_of(kb: Graph, term: Node) -> str | None:
    """The file(s) a knowledge base term was written in, or None when unknown.

    Example:
        >>> source_of(load_kb(), KB["NV-1"])
        'ontology/kb/skills.ttl'
    """
    files = sorted(str(o) for o in kb.objects(term, KBP.sourceFile))
    return ", ".join(files) if files else None


def curie(graph: Graph, term: Node) -> str:
    """A short name of a term for messages: ``kb:NV-1``, ``kbp:storedIn``, a literal's text, or ``[]``."""
    if isinstance(term, URIRef):
        try:
            return graph.namespace_manager.normalizeUri(term)
        except Exception:  # rdflib rejects some IRIs as prefixed names
            return f"<{term}>"
    if isinstance(term, Literal):
        return str(term)
    if isinstance(term, BNode):
        return "[]"
    return str(term)


def label(graph: Graph, term: Node) -> str:
    """The rdfs:label of a term, else its local name."""
    lbl = graph.value(term, RDFS.label)
    if lbl is not None:
        return str(lbl)
    text = str(term)
    for sep in ("#", "/"):
        if sep in text:
            text = text.rsplit(sep, 1)[-1]
    return text


def is_declared_property(kb: Graph, term: URIRef) -> bool:
    """True when ``term`` is declared as a property in the knowledge base (or is an RDF/RDFS term)."""
    if str(term).startswith((str(RDF), str(RDFS))):
        return True
    return any((term, RDF.type, t) in kb for t in PROPERTY_TYPES)


def is_declared_class(kb: Graph, term: URIRef) -> bool:
    """True when ``term`` is declared as an OWL or RDFS class in the knowledge base."""
    return any((term, RDF.type, t) in kb for t in CLASS_TYPES)


def is_datatype(kb: Graph, term: URIRef) -> bool:
    """True for XSD datatypes, rdf:langString and terms typed rdfs:Datatype."""
    return str(term).startswith(str(XSD)) or term == RDF.langString or (term, RDF.type, RDFS.Datatype) in kb


@cache
def _text(name: str) -> str:
    from kbplanner.core.named_queries import get_query

    return get_query(name).text


def _prepared(name: str) -> Query:
    """The parsed query (parsing costs about 40 ms per query with rdflib; done once per process)."""
    return prepared(name) or prepare_text(_text(name))


def select(graph: Graph, name: str, **bindings: Identifier) -> list[dict[str, Node | None]]:
    """Rows of the named query ``name`` as RDF terms (IRIs stay IRIs), with values bound.

    The query text is the constant text of the ``.rq`` file; ``bindings`` are RDF terms passed as
    ``initBindings``. Unlike :func:`kbplanner.core.named_queries.run_named`, nothing is converted to Python.
    """
    query: str | Query = _prepared(name)
    if evaluates_text(graph):
        # oxrdflib and SPARQL endpoint stores (kbplanner.core.stores) evaluate query text themselves
        query = _text(name)
    result = graph.query(query, initBindings=dict(bindings))
    names = [str(v) for v in (result.vars or [])]
    return [{n: row[i] for i, n in enumerate(names)} for row in result]  # type: ignore[index]
