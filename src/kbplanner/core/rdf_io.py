"""Reading RDF (all steps): Turtle files into graphs, with errors that name the file and line.

``owl:imports`` of a remote IRI is refused, never fetched; local imports are the caller's business
(the ontology files are loaded as a set). Graphs are plain rdflib graphs in memory by default, or
backed by Oxigraph (``store="oxigraph"``) for large models.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

from rdflib import OWL, Graph, URIRef

from kbplanner.core.errors import InputFileError, RdfSyntaxError, RemoteImportError

_LINE_RE = re.compile(r"line (\d+)", re.IGNORECASE)


def new_graph(store: str = "memory") -> Graph:
    """An empty graph on the chosen store: ``"memory"`` (rdflib) or ``"oxigraph"`` (oxrdflib)."""
    if store == "memory":
        g = Graph()
    elif store == "oxigraph":
        g = Graph(store="Oxigraph")
    else:
        raise ValueError(f"unknown store {store!r}; use 'memory' or 'oxigraph'")
    bind_prefixes(g)
    return g


def bind_prefixes(g: Graph) -> None:
    """Bind the prefixes kbplanner writes with (kbp, bot, xsd, ...)."""
    from kbplanner.core.vocab import BOT, KBP

    g.bind("kbp", KBP, override=True)
    g.bind("bot", BOT, override=True)


def parse_turtle(path: Path, into: Graph | None = None) -> Graph:
    """Parse one Turtle file; a syntax error names the file and line, a remote import is refused.

    Example:
        >>> from kbplanner.core.resources import data_dir
        >>> len(parse_turtle(data_dir("ontology") / "bot.ttl")) > 10
        True
    """
    path = Path(path)
    if not path.is_file():
        raise InputFileError("file not found", file=path, fix="check the path (relative paths are "
                             "resolved against the project directory)")
    g = Graph() if into is None else into
    part = Graph()
    try:
        part.parse(path, format="turtle")
    except Exception as exc:  # rdflib raises several parser exception types
        text = str(exc)
        m = _LINE_RE.search(text)
        line = int(m.group(1)) if m else None
        first = text.strip().splitlines()[0] if text.strip() else type(exc).__name__
        raise RdfSyntaxError(
            f"Turtle syntax error: {first}",
            file=path,
            line=line,
            fix="correct the Turtle at that line (check prefixes, '.' and ';' terminators)",
        ) from None
    check_imports(part, path)
    for t in part:
        g.add(t)
    for prefix, ns in part.namespaces():
        g.bind(prefix, ns, override=False)
    return g


def check_imports(g: Graph, path: Path) -> None:
    """Refuse ``owl:imports`` of anything but a local ``file:`` IRI (nothing is fetched)."""
    for _, _, target in g.triples((None, OWL.imports, None)):
        iri = str(target)
        if isinstance(target, URIRef) and iri.startswith("file:"):
            continue
        raise RemoteImportError(
            f"owl:imports of a remote IRI <{iri}> (kbplanner never fetches from the network)",
            file=path,
            element=iri,
            fix="download the ontology once, add it to the project as a local Turtle file listed "
                "in project.toml, and remove the owl:imports line",
        )


def parse_many(paths: Iterable[Path], into: Graph | None = None) -> Graph:
    """Parse several Turtle files into one graph (``into`` if given)."""
    g = Graph() if into is None else into
    for p in paths:
        parse_turtle(p, into=g)
    return g
