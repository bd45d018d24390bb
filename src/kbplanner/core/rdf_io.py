"""Reading RDF (all steps): Turtle files into graphs, with errors that name the file and line.

``owl:imports`` of a remote IRI is refused, never fetched; local imports are the caller's business
(the ontology files are loaded as a set). Graphs are plain rdflib graphs in memory by default, or
backed by Oxigraph (``store="oxigraph"``) for large models.
"""

from __future__ import annotations

import contextvars
import re
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from urllib.parse import urlparse
from urllib.request import url2pathname

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


_READS: contextvars.ContextVar[list[Path] | None] = contextvars.ContextVar("kbplanner_reads", default=None)


@contextmanager
def recording_reads() -> Iterator[list[Path]]:
    """Collect every Turtle file :func:`parse_turtle` reads in the block (``owl:imports`` too), in order;
    the project cache keys its entries by them."""
    reads: list[Path] = []
    token = _READS.set(reads)
    try:
        yield reads
    finally:
        _READS.reset(token)


def note_read(path: Path) -> None:
    """Record ``path`` as read in the current :func:`recording_reads` block (a graph of it reused)."""
    reads = _READS.get()
    if reads is not None:
        reads.append(Path(path))


def parse_turtle(path: Path, into: Graph | None = None, *,
                 _importing: frozenset[Path] = frozenset()) -> Graph:
    """Parse one Turtle file; a syntax error names the file, line and column; a remote import is
    refused; ``owl:imports`` of a local ``file:`` IRI is read too (a missing file is an error).

    Example:
        >>> from kbplanner.core.resources import data_dir
        >>> len(parse_turtle(data_dir("ontology") / "bot.ttl")) > 10
        True
    """
    path = Path(path)
    if not path.is_file():
        raise InputFileError("file not found", file=path, fix="check the path (relative paths are "
                             "resolved against the project directory)")
    reads = _READS.get()
    if reads is not None:
        reads.append(path)
    g = Graph() if into is None else into
    part = Graph()
    try:
        part.parse(path, format="turtle")
    except Exception as exc:  # rdflib raises several parser exception types
        line, column, why = _syntax_position(exc)
        raise RdfSyntaxError(
            f"Turtle syntax error{f' at column {column}' if column is not None else ''}: {why}",
            file=path,
            line=line,
            fix="correct the Turtle at that line (check prefixes, '.' and ';' terminators)",
        ) from None
    check_imports(part, path)
    here = _importing | {path.resolve()}
    for target in sorted(str(o) for o in part.objects(None, OWL.imports)):
        local = Path(url2pathname(urlparse(target).path))
        if local.resolve() in here:
            continue  # an import circle: each file is read once
        if not local.is_file():
            raise InputFileError(f"owl:imports <{target}>: no such file", file=path, element=target,
                                 fix="correct the file: IRI (absolute, or relative to this file) or "
                                     "remove the owl:imports line")
        parse_turtle(local, into=part, _importing=here)
    for t in part:
        g.add(t)
    for prefix, ns in part.namespaces():
        g.bind(prefix, ns, override=False)
    return g


def _syntax_position(exc: Exception) -> tuple[int | None, int | None, str]:
    """Line, column (1-based) and reason of a parser error (rdflib's ``BadSyntax`` keeps the text
    and the offset; other errors give what their message says)."""
    why = str(getattr(exc, "_why", "") or "")
    text = getattr(exc, "_str", None)
    offset = getattr(exc, "_i", None)
    lines = getattr(exc, "lines", None)
    if isinstance(text, bytes | str) and isinstance(offset, int):
        raw = text.decode("utf-8", "replace") if isinstance(text, bytes) else text
        before = raw[:offset]
        line = before.count("\n") + 1 if not isinstance(lines, int) else lines + 1
        column = offset - (before.rfind("\n") + 1) + 1
        return line, column, why or type(exc).__name__
    message = str(exc)
    m = _LINE_RE.search(message)
    rest = [s.strip() for s in message.strip().splitlines() if s.strip()]
    reason = next((s for s in rest if not s.startswith("at line")), rest[0] if rest else type(exc).__name__)
    return (int(m.group(1)) if m else None), None, why or reason


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
