"""The project cache's pickled graphs (4D model loading): the model, knowledge-base and merged graphs of
an entry, pickled by their terms' parts and sealed (:mod:`kbplanner.core.cache_seal`), and the store that
notes edits of graphs unpickled from an entry. Used by :mod:`kbplanner.model.project_cache`."""

from __future__ import annotations

import gc
import io
import logging
import os
import pickle
import tempfile
from datetime import date, datetime
from decimal import Decimal
from pathlib import Path
from typing import Any

from rdflib import Graph, Literal, URIRef
from rdflib.plugins.stores.memory import Memory

from kbplanner.core.cache_seal import seal, sealed
from kbplanner.core.rdf_io import bind_prefixes

log = logging.getLogger(__name__)

GRAPHS = "graphs.pickle"


def umask() -> int:
    """The process's file-mode mask (files written into an entry get the modes a plain write would)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def merged_graph(model: Graph, kb: Graph) -> Graph:
    """The model and the knowledge base in one graph (the graph the named queries run on)."""
    g = Graph()
    bind_prefixes(g)
    for t in model:
        g.add(t)
    for t in kb:
        g.add(t)
    return g


def _uriref(text: str) -> URIRef:
    """An IRI as ``URIRef(text)`` makes it (without checking its characters again)."""
    return str.__new__(URIRef, text)


def _literal(lexical: str, language: str | None, datatype: URIRef | None, value: Any,
             ill_typed: bool | None) -> Literal:
    """A literal with the lexical form, language, datatype and value it was written with (not parsed
    again)."""
    lit = str.__new__(Literal, lexical)
    lit._language = language
    lit._datatype = datatype
    lit._value = value
    lit._ill_typed = ill_typed
    return lit


# the Python values of literals that pickle as themselves (others: the literal is parsed again)
_PLAIN_VALUES = (type(None), str, bool, int, float, Decimal, datetime, date)


class _TermPickler(pickle.Pickler):
    """Pickles IRIs and literals by their parts, so that unpickling neither checks IRIs nor parses
    literal values again (rdflib's own reduction does both: three quarters of the time)."""

    def reducer_override(self, obj: Any) -> Any:
        kind = type(obj)
        if kind is URIRef:
            return _uriref, (str(obj),)
        if kind is Literal and type(obj._value) in _PLAIN_VALUES:
            return _literal, (str(obj), obj._language, obj._datatype, obj._value, obj._ill_typed)
        return NotImplemented


def dump_graphs(model: Graph, kb: Graph, merged: Graph, stamp: str) -> bytes:
    """The pickle of the three graphs of an entry and the stamp of the first two."""
    buf = io.BytesIO()
    _TermPickler(buf, protocol=pickle.HIGHEST_PROTOCOL).dump((model, kb, merged, stamp))
    return buf.getvalue()


class KeptMemory(Memory):
    """The in-memory store of a graph unpickled from an entry: the same store, noting any edit (every
    change of an rdflib graph reaches its store's ``add`` or ``remove``), so that the entry's stamp of
    its graphs (:func:`kbplanner.model.kept_rows.graphs_stamp`, kept in ``graphs.pickle``) stands for
    them while none was made."""

    edited = False

    def add(self, triple: Any, context: Any, quoted: bool = False) -> None:
        self.edited = True
        super().add(triple, context, quoted)

    def remove(self, triple: Any, context: Any = None) -> None:
        self.edited = True
        super().remove(triple, context)


def unedited(*graphs: Graph) -> bool:
    """Whether every graph is one unpickled from an entry and none was changed since."""
    return all(isinstance(g.store, KeptMemory) and not g.store.edited for g in graphs)


def note_edits(*graphs: Graph) -> None:
    """Make the in-memory stores of ``graphs`` note their edits (:class:`KeptMemory`)."""
    for g in graphs:
        if type(g.store) is Memory:
            g.store.__class__ = KeptMemory


def load_graphs(path: Path) -> tuple[Graph, Graph, Graph, str]:
    """The model, knowledge-base and merged graphs and the stamp :func:`keep_graphs` wrote, if the file
    bears this user's seal (:mod:`kbplanner.core.cache_seal`; else ValueError: nothing is unpickled).
    The cyclic garbage collector is paused meanwhile: the hundred thousand containers unpickled would
    start it dozens of times, four fifths of the time, to find nothing."""
    mark, _, data = path.read_bytes().partition(b"\n")
    if not sealed(data, mark.decode("ascii", "replace")):
        raise ValueError(f"{path} is not sealed by this user's kbplanner")
    paused = gc.isenabled()
    gc.disable()
    try:
        got = pickle.loads(data)
    finally:
        if paused:
            gc.enable()
    if not (isinstance(got, tuple) and len(got) == 4 and all(isinstance(g, Graph) for g in got[:3])
            and isinstance(got[3], str)):
        raise ValueError(f"{path} holds no graphs")
    note_edits(got[0], got[1])  # the model and the knowledge base: their edits are noted
    return got[0], got[1], got[2], got[3]


def keep_graphs(entry: Path, model: Graph, kb: Graph, merged: Graph, stamp: str) -> None:
    """Write ``graphs.pickle`` into ``entry`` (sealed; atomic replace; nothing where no key can be kept;
    an error is logged, never raised)."""
    try:
        data = dump_graphs(model, kb, merged, stamp)
        mark = seal(data)
        if mark is None:
            return
        fd, tmp = tempfile.mkstemp(prefix=f".{GRAPHS}.", dir=entry)
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(mark.encode("ascii") + b"\n" + data)
            os.chmod(tmp, 0o666 & ~umask())
            os.replace(tmp, entry / GRAPHS)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except (OSError, pickle.PicklingError, TypeError, AttributeError) as exc:  # the pickle is an aid
        log.info("graphs not kept in %s: %s", entry, exc)
