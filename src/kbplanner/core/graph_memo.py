"""Query results kept per unedited graph (all steps): one query for every element instead of one each.

A whole-building run simulates many tasks in one process from the same loaded model; each task asked the
model again, one element at a time, for the same facts (the robotized tasks and their elements, where each
element's material waits, each skill input's value and each pose's numbers). :func:`memo` gives a dict
kept with a graph while the graph is *known unedited*: its store notes every change (the project cache's
``KeptMemory``, the store of every model and knowledge base loaded by :mod:`kbplanner.model.project_data`
with the cache on, has an ``edited`` flag that its ``add`` and ``remove`` set). For any other graph, or
once the graph is edited, :func:`memo` returns None and the callers query as before. So a caller may run
its query once without the focus bound, over every focus, and look each focus up in the kept rows: the
same rows its bound query gives (the callers only do so where that holds, e.g. no zero-length path).

Keys are the caller's constant query text (or a name) and its bindings; values are the caller's own
immutable results. Nothing here is written to disk; it lives as long as the graph.

Example:
    >>> from rdflib import Graph
    >>> memo(Graph()) is None  # a plain store does not note edits
    True
"""

from __future__ import annotations

import weakref
from collections.abc import Hashable
from typing import Any

from rdflib import Graph

_MEMOS: dict[int, tuple[weakref.ref[Graph], dict[Hashable, Any]]] = {}


def memo(graph: Graph) -> dict[Hashable, Any] | None:
    """The dict kept with ``graph`` while its store is known unedited, else None (query as usual)."""
    if getattr(graph.store, "edited", None) is not False:
        return None
    key = id(graph)
    entry = _MEMOS.get(key)
    if entry is None or entry[0]() is not graph:
        entry = (weakref.ref(graph), {})
        _MEMOS[key] = entry
        weakref.finalize(graph, _forget, key, entry[1])
    return entry[1]


def _forget(key: int, kept: dict[Hashable, Any]) -> None:
    entry = _MEMOS.get(key)
    if entry is not None and entry[1] is kept:
        del _MEMOS[key]
