"""Project load (the import step, before A1): this process's last import graph and schedule graph.

``kbplanner run`` loads the project twice in one process (the scenario, then the bare project), and
both loads read the same import (``model.ttl``) and resolve the same schedule against it. The first
load keeps here the graph it imported or parsed and the schedule graph it built; the second takes them
instead of parsing ``model.ttl`` again and running the schedule's element query again.

Exact: an import graph is kept under its ``model.ttl`` path, size and modification time (a file written
again is read again), and is the same set of triples as parsing that file gives (the import writes
sorted Turtle without blank nodes; tests/test_load_memo.py checks the set). A schedule graph is kept
under the import graph it was resolved against (the same object), the schedule file's bytes and the
project's base IRI. Callers only read the graphs they get (the load copies them into its model graph).
One entry each: the memo holds at most one import and one schedule.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

from rdflib import Graph

from kbplanner.core.rdf_io import note_read


@dataclass(frozen=True)
class _Import:
    key: tuple[str, int, int]
    graph: Graph


@dataclass(frozen=True)
class _Schedule:
    import_graph: Graph
    key: tuple[str, str, str]
    graph: Graph


_import: list[_Import] = []
_schedule: list[_Schedule] = []


def _import_key(ttl: Path) -> tuple[str, int, int] | None:
    try:
        st = ttl.stat()
    except OSError:
        return None
    return str(ttl.resolve()), st.st_size, st.st_mtime_ns


def kept_import(ttl: Path) -> Graph | None:
    """The graph of ``ttl`` kept by this process (noted as read, as parsing it would), or None."""
    key = _import_key(ttl)
    if key is None or not _import or _import[0].key != key:
        return None
    note_read(ttl)
    return _import[0].graph


def keep_import(ttl: Path, graph: Graph) -> None:
    """Keep ``graph`` as the content of ``ttl`` (as written or parsed just now); never edit it after."""
    key = _import_key(ttl)
    _import.clear()
    _schedule.clear()
    if key is not None:
        _import.append(_Import(key, graph))


def _schedule_key(schedule: Path, base: str) -> tuple[str, str, str]:
    digest = hashlib.sha256(schedule.read_bytes()).hexdigest()
    return str(schedule.resolve()), digest, base


def kept_schedule(import_graph: Graph, schedule: Path, base: str) -> Graph | None:
    """The schedule graph built from ``schedule`` against ``import_graph`` by this process, or None."""
    if not _schedule or _schedule[0].import_graph is not import_graph or not schedule.is_file():
        return None
    return _schedule[0].graph if _schedule[0].key == _schedule_key(schedule, base) else None


def keep_schedule(import_graph: Graph, schedule: Path, base: str, graph: Graph) -> None:
    """Keep the schedule graph built from ``schedule`` against ``import_graph``; never edit it after."""
    _schedule.clear()
    if _import and _import[0].graph is import_graph:
        _schedule.append(_Schedule(import_graph, _schedule_key(schedule, base), graph))
