"""Graph backends (scale, issue 6; all steps): where a project's model graph lives and where queries run.

``Project.load(path, store=...)`` builds the model in memory as always, then puts the model graph and
the merged model + knowledge-base graph (``Project.graph``, which the named queries use) on a backend
chosen by a store spec (:func:`parse_store`); the knowledge base itself stays an in-memory graph.

- ``memory`` (default): rdflib in memory, nothing changes.
- ``oxigraph``: pyoxigraph through oxrdflib (``Graph(store="Oxigraph")``) in memory;
  ``oxigraph:DIR``: the same on disk (a RocksDB directory; the graphs of one project and scenario are
  replaced at each load).
- ``sparql+http://HOST:PORT/PATH``: a SPARQL 1.1 endpoint (rdflib ``SPARQLUpdateStore``). The model and
  the knowledge base are uploaded into named graphs (``INSERT DATA`` in batches); every query, triple
  pattern and count then runs on the server, the merged graph being the dataset of both named graphs
  (two ``default-graph-uri`` parameters). The update endpoint is the same URL with a final ``/query``
  replaced by ``/update`` (Oxigraph, Fuseki), else the same URL.

Bound values and the endpoint: the SPARQL protocol has no parameters, so rdflib's ``SPARQLStore``
sends ``initBindings`` as a ``VALUES`` block rendered by rdflib's own term serialiser (``n3()``, which
refuses malformed IRIs and escapes literals). rdflib appends that block after the whole query, where
it joins after ``BIND``, ``FILTER`` and aggregation (``element_state_at`` would lose its states); this
store puts the same block at the start of the query's top-level ``WHERE`` group, as rdflib itself does
for updates, which gives the pre-binding semantics of the embedded stores. Query text stays constant.
Blank nodes are sent as skolem IRIs (rdflib's ``/.well-known/genid/``) and turned back into the same
blank nodes in results, so lists and paths of the knowledge base survive the round trip.

Example:
    >>> parse_store("sparql+http://127.0.0.1:7878/query").update_url
    'http://127.0.0.1:7878/update'
    >>> parse_store(None).kind
    'memory'
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Iterable, Iterator, Mapping, Sequence
from decimal import Decimal
from io import BytesIO
from pathlib import Path
from typing import Any

from rdflib import XSD, BNode, Graph, Literal, URIRef
from rdflib.plugins.stores.sparqlstore import SPARQLUpdateStore
from rdflib.query import Result
from rdflib.term import Identifier, Node, Variable

from kbplanner.core.errors import QueryError
from kbplanner.core.rdf_io import bind_prefixes, new_graph
from kbplanner.core.store_spec import (
    MEMORY,
    OXIGRAPH,
    SPARQL,
    STORE_FORMS,
    StoreError,
    StoreSpec,
    add_store_argument,
    parse_store,
)

__all__ = [  # the spec names live in kbplanner.core.store_spec (light); re-exported here
    "MEMORY", "OXIGRAPH", "SPARQL", "STORE_FORMS", "EndpointStore", "StoreError", "StoreSpec",
    "add_store_argument", "bind_values", "describe", "parse_store", "place_files", "place_graphs",
    "result_json",
]

log = logging.getLogger(__name__)

UPLOAD_BATCH = 20_000          # triples per INSERT DATA request
TIMEOUT_S = 120.0              # per HTTP request
_RESULTS_JSON = "application/sparql-results+json"


# ----------------------------------------------------------------------------------------------
# Oxigraph (embedded)
# ----------------------------------------------------------------------------------------------

_DISK_STORES: dict[Path, Any] = {}  # one open RocksDB store per directory and process


def _disk_store(location: Path) -> Any:
    import pyoxigraph

    key = location.resolve()
    if key not in _DISK_STORES:
        key.mkdir(parents=True, exist_ok=True)
        try:
            _DISK_STORES[key] = pyoxigraph.Store(str(key))
        except OSError as exc:
            raise StoreError(f"cannot open the Oxigraph store: {exc}", file=key,
                             fix="give a directory that no other process holds open") from None
    return _DISK_STORES[key]


def _oxigraph_graph(spec: StoreSpec, identifier: str) -> Graph:
    if spec.location is None:
        return new_graph(OXIGRAPH)
    from oxrdflib import OxigraphStore

    ox = _disk_store(spec.location)
    g = Graph(store=OxigraphStore(store=ox), identifier=URIRef(identifier))
    g.remove((None, None, None))
    bind_prefixes(g)
    return g


# ----------------------------------------------------------------------------------------------
# SPARQL endpoint
# ----------------------------------------------------------------------------------------------


_SKOLEM = "https://rdflib.github.io/.well-known/genid/rdflib/"  # rdflib's BNode.skolemize() default


def _skolem(node: Node) -> Node:
    return URIRef(_SKOLEM + str(node)) if isinstance(node, BNode) else node


def _unskolem(node: Any) -> Any:
    if isinstance(node, URIRef) and node.startswith(_SKOLEM):
        return BNode(node[len(_SKOLEM):])
    return node


def _node_to_sparql(node: Node) -> str:
    """rdflib's term serialiser, with blank nodes as skolem IRIs; malformed terms are refused."""
    try:
        return str(_skolem(node).n3())
    except Exception as exc:  # rdflib raises a bare Exception for IRIs it cannot serialise
        raise QueryError(f"a value cannot be sent to the SPARQL endpoint: {exc}", element=str(node),
                         fix="bind a well-formed IRI or literal") from None


def _top_where_block(query: str) -> int | None:
    """Offset just after the ``{`` of the top-level WHERE group (strings, IRIs, comments skipped)."""
    level = 0
    first: int | None = None
    for m in SPARQLUpdateStore.BLOCK_FINDING_PATTERN.finditer(query):
        if m.group("block_start") is not None:
            if level == 0:
                before = query[: m.start()].rstrip().upper()
                if before.endswith("WHERE"):
                    return m.end()
                if first is None:
                    first = m.end()
            level += 1
        elif m.group("block_end") is not None:
            level -= 1
    head = query.lstrip().upper()
    return first if first is not None and not head.startswith(("CONSTRUCT", "DESCRIBE")) else None


def bind_values(query: str, bindings: Mapping[str, Identifier]) -> str:
    """``query`` with a VALUES block for ``bindings`` at the start of its top-level WHERE group.

    Terms are rendered by rdflib's serialiser; the query text itself is not otherwise changed.

    Example:
        >>> bind_values("SELECT ?s WHERE { ?s ?p ?o }", {"s": URIRef("http://ex.org/a")})
        'SELECT ?s WHERE {\\nVALUES ( ?s ) { ( <http://ex.org/a> ) }\\n ?s ?p ?o }'
    """
    names = list(bindings)
    block = "\nVALUES ( {} ) {{ ( {} ) }}\n".format(
        " ".join(Variable(n).n3() for n in names), " ".join(_node_to_sparql(bindings[n]) for n in names))
    at = _top_where_block(query)
    if at is None:
        raise QueryError("the query has no WHERE group to bind values in", element=query[:60],
                         fix="write the query as SELECT ... WHERE { ... }")
    return query[:at] + block + query[at:]


def bind_rows(query: str, names: Sequence[str], rows: Iterable[Sequence[Node]]) -> str:
    """``query`` with a VALUES block of several rows for the variables ``names`` (as :func:`bind_values`):
    the update text stays constant, the rows are rendered by the same term serialiser."""
    body = "\n".join("( " + " ".join(_node_to_sparql(t) for t in row) + " )" for row in rows)
    block = "\nVALUES ( {} ) {{\n{}\n}}\n".format(" ".join(Variable(n).n3() for n in names), body)
    at = _top_where_block(query)
    if at is None:
        raise QueryError("the update has no WHERE group to bind values in", element=query[:60],
                         fix="write the update as INSERT { ... } WHERE { }")
    return query[:at] + block + query[at:]


# Constant update texts of EndpointStore.upload; the graph and the triples are bound as VALUES rows.
CLEAR_GRAPH = "DELETE { GRAPH ?g { ?s ?p ?o } } WHERE { GRAPH ?g { ?s ?p ?o } }"
INSERT_TRIPLES = "INSERT { GRAPH ?g { ?s ?p ?o } } WHERE { }"
GRAPH_NOT_EMPTY = "ASK WHERE { GRAPH ?g { ?s ?p ?o } }"


class EndpointStore(SPARQLUpdateStore):
    """rdflib's SPARQL update store with bounded HTTP waits, clear errors, skolemised blank nodes,
    VALUES placed inside the WHERE group, and an optional fixed dataset (several default graphs)."""

    def __init__(self, query_url: str, update_url: str, *, default_graphs: tuple[str, ...] = (),
                 timeout_s: float = TIMEOUT_S) -> None:
        super().__init__(query_endpoint=query_url, update_endpoint=update_url, node_to_sparql=_node_to_sparql,
                         returnFormat="json", autocommit=True)
        self.default_graphs = default_graphs
        self.timeout_s = timeout_s
        self.requests = 0

    # ---- HTTP ----------------------------------------------------------------------------
    def _http(self, url: str, body: bytes, content_type: str, accept: str | None) -> tuple[bytes, str]:
        headers = {"Content-Type": content_type}
        if accept:
            headers["Accept"] = accept
        self.requests += 1
        try:
            with urllib.request.urlopen(urllib.request.Request(url, data=body, headers=headers),
                                        timeout=self.timeout_s) as res:
                return res.read(), str(res.headers.get("Content-Type", "")).split(";")[0]
        except urllib.error.HTTPError as exc:
            detail = exc.read().decode("utf-8", "replace").strip().splitlines()
            raise QueryError(f"the SPARQL endpoint refused the request (HTTP {exc.code}): "
                             f"{detail[0] if detail else exc.reason}", element=url,
                             fix="check the query; see the server's log for details") from None
        except (urllib.error.URLError, TimeoutError, ConnectionError) as exc:
            raise StoreError(f"cannot reach the SPARQL endpoint: {getattr(exc, 'reason', exc)}", element=url,
                             fix="start the server (e.g. `oxigraph serve --location DIR --bind "
                                 "127.0.0.1:7878`) or correct the --store URL") from None

    def _query(self, query: str, default_graph: str | None = None, named_graph: str | None = None) -> Result:
        del named_graph
        self._queries += 1
        graphs = self.default_graphs or ((str(default_graph),) if self._is_contextual(default_graph) else ())
        params = urllib.parse.urlencode([("default-graph-uri", g) for g in graphs])
        assert self.query_endpoint is not None
        url = self.query_endpoint + (("&" if "?" in self.query_endpoint else "?") + params if params else "")
        data, ctype = self._http(url, query.encode("utf-8"), "application/sparql-query", _RESULTS_JSON)
        return Result.parse(BytesIO(data), content_type=ctype or _RESULTS_JSON)

    def _update(self, update: str) -> None:
        self._updates += 1
        assert self.update_endpoint is not None
        self._http(self.update_endpoint, update.encode("utf-8"), "application/sparql-update; charset=UTF-8",
                   None)

    # ---- reading -------------------------------------------------------------------------
    def query(self, query: Any, initNs: Mapping[str, Any] | None = None,  # type: ignore[override]
              initBindings: Mapping[str, Identifier] | None = None,
              queryGraph: str | None = None, DEBUG: bool = False) -> Result:
        del DEBUG
        if not isinstance(query, str):  # a prepared query: rdflib evaluates it over remote triple patterns
            raise NotImplementedError("a prepared query has no text to send to the endpoint")
        text = self._inject_prefixes(query, initNs) if initNs else query
        if initBindings:
            text = bind_values(text, initBindings)
        result = self._query(text, default_graph=queryGraph)
        if result.type == "SELECT" and result.bindings:
            result.bindings = [{k: _unskolem(v) for k, v in row.items()} for row in result.bindings]
        return result

    def triples(self, spo: Any, context: Any = None) -> Iterator[tuple[Any, None]]:  # type: ignore[override]
        s, p, o = spo
        for (s2, p2, o2), ctx in super().triples((_skolem(s) if s is not None else None, p,
                                                  _skolem(o) if o is not None else None), context):
            yield (_unskolem(s2), p2, _unskolem(o2)), ctx

    # ---- writing -------------------------------------------------------------------------
    def upload(self, graph_iri: str, triples: Iterable[tuple[Node, Node, Node]],
               batch: int = UPLOAD_BATCH) -> int:
        """Replace the named graph ``graph_iri`` by ``triples`` (constant updates, the graph and the triples
        bound as VALUES rows, in batches); the count."""
        g = URIRef(graph_iri)
        self._update(bind_values(CLEAR_GRAPH, {"g": g}))
        n, rows = 0, []
        for s, p, o in triples:
            rows.append((g, s, p, o))
            if len(rows) >= batch:
                self._update(bind_rows(INSERT_TRIPLES, ("g", "s", "p", "o"), rows))
                n += len(rows)
                rows = []
        if rows:
            self._update(bind_rows(INSERT_TRIPLES, ("g", "s", "p", "o"), rows))
            n += len(rows)
        return n

    def has_graph(self, graph_iri: str) -> bool:
        """Whether the endpoint holds a non-empty named graph ``graph_iri``."""
        result = self._query(bind_values(GRAPH_NOT_EMPTY, {"g": URIRef(graph_iri)}))
        return bool(result.askAnswer)


def _graph_digest(g: Graph) -> str:
    h = hashlib.sha256()
    for line in sorted(f"{_node_to_sparql(s)} {_node_to_sparql(p)} {_node_to_sparql(o)}" for s, p, o in g):
        h.update(line.encode("utf-8"))
    return h.hexdigest()[:16]


def _endpoint_graphs(spec: StoreSpec, model: Graph, kb: Graph, graph_base: str) -> tuple[Graph, Graph]:
    assert spec.query_url is not None and spec.update_url is not None
    model_iri = graph_base + "model"
    kb_iri = graph_base.rsplit("/graph/", 1)[0] + "/graph/kb/" + _graph_digest(kb)
    loader = EndpointStore(spec.query_url, spec.update_url)
    t0 = time.perf_counter()
    n = loader.upload(model_iri, model)
    if not loader.has_graph(kb_iri):
        loader.upload(kb_iri, kb)
    log.info("uploaded %d model triples to %s in %.2f s", n, spec.query_url, time.perf_counter() - t0)
    remote_model = Graph(store=EndpointStore(spec.query_url, spec.update_url, default_graphs=(model_iri,)),
                         identifier=URIRef(model_iri))
    merged = Graph(store=EndpointStore(spec.query_url, spec.update_url, default_graphs=(model_iri, kb_iri)),
                   identifier=URIRef(graph_base + "all"))
    for g in (remote_model, merged):
        bind_prefixes(g)
    return remote_model, merged


# ----------------------------------------------------------------------------------------------
# Placing a project's graphs
# ----------------------------------------------------------------------------------------------


def place_graphs(spec: str | StoreSpec | None, model: Graph, kb: Graph, *,
                 graph_base: str) -> tuple[Graph, Graph | None]:
    """The model graph and the merged model + knowledge-base graph on the backend ``spec``.

    ``graph_base`` (ending in ``/``) names the backend's graphs (``graph_base + "model"``, ...). For
    memory, returns ``model`` itself and ``None`` (the project merges lazily, as before).

    Raises:
        StoreError: an unknown spec, an endpoint that cannot be reached or refuses the upload.
    """
    s = parse_store(spec)
    if s.is_memory:
        return model, None
    t0 = time.perf_counter()
    if s.kind == OXIGRAPH:
        placed = _oxigraph_graph(s, graph_base + "model")
        placed.addN((t[0], t[1], t[2], placed) for t in model)
        merged = _oxigraph_graph(s, graph_base + "all")
        merged.addN((t[0], t[1], t[2], merged) for t in model)
        merged.addN((t[0], t[1], t[2], merged) for t in kb)
        out = (placed, merged)
    else:
        out = _endpoint_graphs(s, model, kb, graph_base)
    log.info("model on %s in %.2f s", s.text, time.perf_counter() - t0)
    return out


def place_files(spec: str | StoreSpec | None, model_nt: Path, kb_nt: Path) -> tuple[Graph, Graph] | None:
    """The model graph and the merged model + knowledge-base graph read straight from N-Triples files
    (the project cache) into an in-memory Oxigraph store; ``None`` for any other backend (the caller
    parses the files and places the graphs). Blank nodes keep the files' labels, as rdflib's
    :func:`kbplanner.model.project_cache` reading does, so both sides name the same nodes."""
    s = parse_store(spec)
    if s.kind != OXIGRAPH or s.location is not None:
        return None
    import pyoxigraph as ox

    t0 = time.perf_counter()
    placed, merged = new_graph(OXIGRAPH), new_graph(OXIGRAPH)
    for g, files in ((placed, (model_nt,)), (merged, (model_nt, kb_nt))):
        ident = g.identifier
        name = ox.BlankNode(str(ident)) if isinstance(ident, BNode) else ox.NamedNode(str(ident))
        inner = getattr(g.store, "_inner")  # noqa: B009 (oxrdflib's pyoxigraph store)
        for path in files:
            inner.extend(ox.Quad(q.subject, q.predicate, q.object, name)
                         for q in ox.parse(path=str(path), format=ox.RdfFormat.N_TRIPLES))
    log.info("model on %s from %s in %.2f s", s.text, model_nt.parent, time.perf_counter() - t0)
    return placed, merged


def describe(graph: Graph) -> str:
    """A short name of a graph's backend (for reports): memory, oxigraph or the endpoint URL."""
    store = graph.store
    if isinstance(store, EndpointStore):
        return f"sparql {store.query_endpoint}"
    return OXIGRAPH if "oxigraph" in type(store).__name__.lower() else MEMORY


def result_json(result: Result) -> str:
    """A SELECT result as canonical JSON rows (blank nodes as ``_:b``), for comparisons across backends."""
    def term(v: Any) -> Any:
        if v is None:
            return None
        if isinstance(v, BNode):
            return "_:b"
        if isinstance(v, Literal):  # a plain literal is an xsd:string (RDF 1.1), whatever the store says
            datatype = "" if v.datatype in (None, XSD.string) else str(v.datatype)
            value = v.toPython()
            if isinstance(value, Decimal):  # 1.0 and 1 are the same xsd:decimal (Oxigraph writes 1)
                value = value.normalize()
            return [datatype, v.language or "", repr(value)]
        return str(v)

    cols = [str(v) for v in (result.vars or [])]
    rows = sorted(json.dumps([term(row[i]) for i in range(len(cols))]) for row in result)  # type: ignore[index]
    return json.dumps({"columns": cols, "rows": rows}, indent=0)
