"""Named SPARQL queries (all steps): the ``.rq`` files of ``kbplanner/queries`` behind one typed runner.

Each file starts with comment lines ``# name:``, ``# description:``, ``# param: VAR TYPE  text`` (one per
bindable variable) and ``# columns:``. The query text is never edited: values are bound with
``initBindings`` after being converted to RDF terms of the declared type, so nothing taken from model
data (IFC names, GlobalIds) can change a query.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from datetime import date, datetime
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rdflib import XSD, Graph, Literal, URIRef
from rdflib.query import Result
from rdflib.term import Identifier, Node

from kbplanner.core.errors import QueryError
from kbplanner.core.resources import queries_dir

if TYPE_CHECKING:
    from rdflib.plugins.sparql.sparql import Query

_HEADER_RE = re.compile(r"^#\s*(name|description|param|columns):\s*(.*)$")


@dataclass(frozen=True)
class QueryParam:
    """A variable of a named query that may be bound: its name, XSD/IRI type and description."""

    name: str
    type: str
    description: str


@dataclass(frozen=True)
class NamedQuery:
    """One ``.rq`` file: constant SPARQL text plus the header that documents it."""

    name: str
    description: str
    params: tuple[QueryParam, ...]
    columns: tuple[str, ...]
    text: str
    path: Path

    def param(self, name: str) -> QueryParam | None:
        """The declared parameter called ``name``, if any."""
        return next((p for p in self.params if p.name == name), None)


@dataclass
class QueryResult:
    """Rows of a SELECT as Python values (IRIs as strings), with the column order of the query."""

    columns: list[str]
    rows: list[tuple[Any, ...]] = field(default_factory=list)

    def as_dicts(self) -> list[dict[str, Any]]:
        """The rows as one dict per row."""
        return [dict(zip(self.columns, r, strict=True)) for r in self.rows]

    def __len__(self) -> int:
        return len(self.rows)


def parse_query_file(path: Path) -> NamedQuery:
    """Read one ``.rq`` file with its header."""
    text = path.read_text(encoding="utf-8")
    meta: dict[str, str] = {}
    params: list[QueryParam] = []
    for line in text.splitlines():
        m = _HEADER_RE.match(line.strip())
        if not m:
            continue
        key, value = m.group(1), m.group(2).strip()
        if key == "param":
            parts = value.split(None, 2)
            if len(parts) < 2:
                raise QueryError(f"malformed '# param:' line {line!r}", file=path,
                                 fix="write '# param: VAR TYPE description'")
            params.append(QueryParam(parts[0].lstrip("?"), parts[1], parts[2] if len(parts) > 2 else ""))
        else:
            meta[key] = value
    name = meta.get("name", path.stem)
    return NamedQuery(
        name=name,
        description=meta.get("description", ""),
        params=tuple(params),
        columns=tuple(meta.get("columns", "").split()),
        text=text,
        path=path,
    )


@cache
def catalogue() -> dict[str, NamedQuery]:
    """Every named query of the package, by name."""
    out: dict[str, NamedQuery] = {}
    for p in sorted(queries_dir().glob("*.rq")):
        q = parse_query_file(p)
        out[q.name] = q
    return out


def get_query(name: str) -> NamedQuery:
    """The named query ``name``; a clear error lists the known names."""
    cat = catalogue()
    if name not in cat:
        raise QueryError(
            f"no named query {name!r}",
            fix="choose one of: " + ", ".join(sorted(cat)) + " (kbplanner query --list)",
        )
    return cat[name]


_IRI = re.compile(r'[A-Za-z][A-Za-z0-9+.\-]*:[^<>"{}|^`\\\x00-\x20]*')


def iri_term(value: str, *, param: str = "", query: str = "") -> URIRef:
    """An absolute IRI as SPARQL allows it (no spaces, ``<>"{}|^`\\``), else a QueryError (exit 2).

    Example:
        >>> iri_term("https://example.org/a")
        rdflib.term.URIRef('https://example.org/a')
    """
    if not _IRI.fullmatch(value):
        raise QueryError(f"{value!r} for parameter {param!r} is not an absolute IRI", element=query or None,
                         fix="give an IRI with a scheme and without spaces or any of <>\"{}|^`\\, "
                             "e.g. https://example.org/a")
    return URIRef(value)


def to_term(value: Any, type_name: str, *, param: str = "", query: str = "") -> Identifier:
    """Convert a Python value or CLI string into the RDF term a parameter expects."""
    if isinstance(value, Identifier):
        return value
    t = type_name.lower()
    try:
        if t in ("iri", "uri", "uriref"):
            return iri_term(str(value), param=param, query=query)
        if t == "xsd:datetime":
            if isinstance(value, datetime):
                return Literal(value, datatype=XSD.dateTime)
            if isinstance(value, date):
                return Literal(datetime(value.year, value.month, value.day), datatype=XSD.dateTime)
            s = str(value)
            dt = datetime.fromisoformat(s if ("T" in s or " " in s) else s + "T00:00:00")
            return Literal(dt, datatype=XSD.dateTime)
        if t == "xsd:double":
            number = float(value)
            if not math.isfinite(number):
                raise ValueError(value)
            return Literal(number, datatype=XSD.double)
        if t == "xsd:integer":
            return Literal(int(value), datatype=XSD.integer)
        if t == "xsd:boolean":
            if isinstance(value, bool):
                return Literal(value)
            return Literal(str(value).strip().lower() in ("1", "true", "yes"))
        return Literal(str(value))
    except ValueError:
        raise QueryError(
            f"value {value!r} for parameter {param!r} is not a valid {type_name}",
            element=query,
            fix=f"give {param}= a {type_name} value (e.g. 2022-05-10 for dates)",
        ) from None


def _py(node: Node | None) -> Any:
    if node is None:
        return None
    if isinstance(node, Literal):
        return node.toPython()
    return str(node)


def run_text(graph: Graph, text: str, bindings: dict[str, Identifier] | None = None) -> Result:
    """Run constant SPARQL text on ``graph`` with values bound (never formatted into the text)."""
    return graph.query(text, initBindings=bindings or {})


def evaluates_text(graph: Graph) -> bool:
    """True for stores that evaluate query text themselves (oxrdflib's Oxigraph, SPARQL endpoints:
    :mod:`kbplanner.core.stores`), where an rdflib-parsed query is of no use."""
    return "oxigraph" in type(graph.store).__name__.lower() or hasattr(graph.store, "query_endpoint")


@cache
def prepared(name: str) -> Query | None:
    """The named query parsed and translated by rdflib, once per process (parsing costs about 40 ms a
    query) and kept across processes (:func:`kbplanner.core.sparql_cache.prepare_text`); None when it
    cannot be prepared alone (a prefix only a graph declares): then it is parsed with the graph's
    prefixes at each run."""
    from kbplanner.core.sparql_cache import prepare_text

    try:
        return prepare_text(get_query(name).text)
    except Exception:  # parsed again, with the graph's prefixes, where it runs
        return None


def prepare_all() -> int:
    """Parse every named query now (a worker process, before its first task); how many were prepared."""
    return sum(prepared(name) is not None for name in catalogue())


def result_rows(result: Result) -> QueryResult:
    """Turn an rdflib SELECT result into a QueryResult of Python values."""
    columns = [str(v) for v in (result.vars or [])]
    rows = [tuple(_py(row[i]) for i in range(len(columns))) for row in result]  # type: ignore[index]
    return QueryResult(columns=columns, rows=rows)


def run_named(graph: Graph, name: str, **bindings: Any) -> QueryResult:
    """Run the named query ``name`` with keyword bindings converted to the declared types.

    Example:
        >>> from rdflib import Graph
        >>> run_named(Graph(), "storeys").rows
        []
    """
    q = get_query(name)
    bound: dict[str, Identifier] = {}
    for key, value in bindings.items():
        if value is None:
            continue
        p = q.param(key)
        if p is None:
            known = ", ".join(p.name for p in q.params) or "none"
            raise QueryError(
                f"query {name!r} has no parameter {key!r}",
                element=name,
                fix=f"bindable parameters: {known}",
            )
        bound[key] = to_term(value, p.type, param=key, query=name)
    query = None if evaluates_text(graph) else prepared(name)
    if query is None:
        return result_rows(run_text(graph, q.text, bound))
    return result_rows(graph.query(query, initBindings=bound))
