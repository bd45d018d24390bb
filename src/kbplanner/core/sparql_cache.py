"""Prepared SPARQL queries kept across processes (all steps): rdflib's parse and translation, pickled.

rdflib parses a query with pyparsing (20-40 ms a query); a command runs a score of named queries, so
every process paid about half a second before its first row. :func:`prepare_text` keeps the prepared
:class:`rdflib.plugins.sparql.sparql.Query` (prologue and algebra) in a small pickle per query text,
so a later process reads it back in a fraction of a millisecond. The query evaluated is the same
object rdflib would have built: the cache holds exactly what ``prepareQuery`` returned.

- Where: ``$KBPLANNER_CACHE_DIR/sparql/`` when that variable is set, else ``$XDG_CACHE_HOME/kbplanner/
  sparql/`` (``~/.cache/kbplanner/sparql/``); the cache is kbplanner's own (files it wrote).
- Off: ``KBPLANNER_NO_CACHE=1`` (``kbplanner --no-cache``): every query is parsed, nothing is written.
- Key: SHA-256 of the cache format, the Python, rdflib and pyparsing versions and the query text (and
  the namespaces given with it): any change parses the query again.
- Each file is sealed (:mod:`kbplanner.core.cache_seal`: an HMAC under this user's key, first line)
  and unpickled only if the seal matches; none is written where no key can be kept.
- A file that cannot be read (damaged, written by another version) is parsed again and replaced; a
  write that fails is ignored (the cache is an aid). Files are written atomically (temporary file
  renamed into place), so two processes at once never read half a file.

rdflib's algebra nodes (``CompValue``, an ``OrderedDict`` whose constructor needs a name, and ``Expr``,
holding a method bound to itself) do not unpickle by themselves: :class:`_Pickler` writes them as
their class, attributes and items, and :func:`_comp_value` builds them back.
"""

from __future__ import annotations

import hashlib
import io
import logging
import os
import pickle
import sys
import tempfile
from collections import OrderedDict
from collections.abc import Callable, Mapping
from functools import lru_cache
from pathlib import Path
from types import MethodType
from typing import TYPE_CHECKING, Any

from kbplanner.core.cache_seal import seal, sealed

if TYPE_CHECKING:
    from rdflib.plugins.sparql.sparql import Query

log = logging.getLogger(__name__)

FORMAT = "1"
NO_CACHE_ENV = "KBPLANNER_NO_CACHE"  # as kbplanner.model.project_cache (core cannot import model)
CACHE_DIR_ENV = "KBPLANNER_CACHE_DIR"
SUBDIR = "sparql"


def enabled() -> bool:
    """Whether prepared queries are kept (``KBPLANNER_NO_CACHE`` unset, empty or ``0``)."""
    return os.environ.get(NO_CACHE_ENV, "").strip() in ("", "0")


def cache_dir() -> Path:
    """The folder of the kept queries (see the module text)."""
    env = os.environ.get(CACHE_DIR_ENV)
    if env:
        return Path(env) / SUBDIR
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg) if xdg else Path.home() / ".cache"
    return base / "kbplanner" / SUBDIR


_versions_memo: list[str] = []


def _versions() -> str:
    if not _versions_memo:
        import pyparsing
        import rdflib

        _versions_memo.append(f"{FORMAT}|{sys.version}|{rdflib.__version__}|{pyparsing.__version__}")
    return _versions_memo[0]


def query_key(text: str, init_ns: Mapping[str, Any] | None = None) -> str:
    """The cache key of a query text (with the namespaces given with it)."""
    h = hashlib.sha256()
    h.update(_versions().encode() + b"\0" + text.encode("utf-8") + b"\0")
    for prefix, ns in sorted((init_ns or {}).items()):
        h.update(f"{prefix}={ns}".encode() + b"\0")
    return h.hexdigest()[:32]


def _comp_value(cls: type[Any], attrs: dict[str, Any], evalfn: Callable[..., Any] | None,
                items: list[tuple[Any, Any]]) -> Any:
    """An algebra node built back from :meth:`_Pickler.reducer_override`'s parts."""
    obj: Any = OrderedDict.__new__(cls)
    OrderedDict.__init__(obj)
    obj.__dict__.update(attrs)
    if "_evalfn" in attrs or evalfn is not None:
        obj.__dict__["_evalfn"] = MethodType(evalfn, obj) if evalfn is not None else None
    for key, value in items:
        OrderedDict.__setitem__(obj, key, value)
    return obj


def _shared_node(name: str) -> Any:
    """One of rdflib's module-level algebra nodes (``operators.TrueFilter``), the same object."""
    from rdflib.plugins.sparql import operators

    return getattr(operators, name)


_SHARED = ("TrueFilter",)  # module-level nodes of rdflib.plugins.sparql.operators (functions: lambdas)


class _Pickler(pickle.Pickler):
    """Pickles rdflib's algebra nodes as class, attributes (a bound evaluation function as its
    function) and items; rdflib's module-level nodes by name."""

    def reducer_override(self, obj: Any) -> Any:
        from rdflib.plugins.sparql import operators
        from rdflib.plugins.sparql.parserutils import CompValue

        if not isinstance(obj, CompValue):
            return NotImplemented
        for name in _SHARED:
            if obj is getattr(operators, name):
                return _shared_node, (name,)
        attrs = dict(obj.__dict__)
        bound = attrs.pop("_evalfn", None)
        evalfn = bound.__func__ if isinstance(bound, MethodType) else None
        if bound is not None and evalfn is None:
            raise pickle.PicklingError(f"evaluation function {bound!r} is not a bound method")
        if evalfn is None and "_evalfn" in obj.__dict__:
            attrs["_evalfn"] = None
        items = [(k, OrderedDict.__getitem__(obj, k)) for k in OrderedDict.keys(obj)]
        return _comp_value, (type(obj), attrs, evalfn, items)


def dumps(query: Query) -> bytes:
    """The pickle of a prepared query (algebra nodes as :class:`_Pickler` writes them)."""
    buf = io.BytesIO()
    _Pickler(buf, protocol=pickle.HIGHEST_PROTOCOL).dump(query)
    return buf.getvalue()


def _read(path: Path) -> Query | None:
    from rdflib.plugins.sparql.sparql import Query

    try:
        mark, _, data = path.read_bytes().partition(b"\n")
        if not sealed(data, mark.decode("ascii", "replace")):
            log.info("prepared query %s not used: not sealed by this user's kbplanner", path)
            return None
        obj = pickle.loads(data)
    except FileNotFoundError:
        return None
    except Exception as exc:  # damaged or written by other code: parsed again, replaced
        log.info("prepared query %s not used: %s", path, exc)
        return None
    return obj if isinstance(obj, Query) else None


def _write(path: Path, data: bytes) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except OSError as exc:  # read-only home, full disk: the cache is an aid
        log.info("prepared query not kept in %s: %s", path, exc)


def prepare_text(text: str, init_ns: Mapping[str, Any] | None = None) -> Query:
    """``rdflib.plugins.sparql.prepareQuery(text, initNs=init_ns)``, read from the cache when kept
    (written there otherwise). Raises what ``prepareQuery`` raises for a query that does not parse."""
    from rdflib.plugins.sparql.processor import prepareQuery

    if not enabled():
        return prepareQuery(text, initNs=init_ns)
    path = cache_dir() / f"{query_key(text, init_ns)}.pickle"
    kept = _read(path)
    if kept is not None:
        return kept
    query = prepareQuery(text, initNs=init_ns)
    try:
        data = dumps(query)
    except Exception as exc:  # a node this module does not know how to write: not kept
        log.info("prepared query not kept: %s", exc)
        return query
    mark = seal(data)
    if mark is not None:  # else no key can be kept: nothing is
        _write(path, mark.encode("ascii") + b"\n" + data)
    return query


@lru_cache(maxsize=1024)
def prepared_text(text: str) -> Query | None:
    """:func:`prepare_text` of a query text without namespaces, once per process; ``None`` when it does
    not parse alone (a prefix only the graph declares): the caller runs the text on the graph."""
    try:
        return prepare_text(text)
    except Exception:  # parsed again with the graph's prefixes where it runs
        return None
