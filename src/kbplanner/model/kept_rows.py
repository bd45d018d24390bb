"""The project cache's kept query rows (4D model loading, A6): rows of the named queries the world tables
read, kept beside an entry's graphs with a hash of the graphs they were read from. Used by
:mod:`kbplanner.model.project_data` through :mod:`kbplanner.model.project_cache`."""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from datetime import date, datetime
from decimal import Decimal
from pathlib import Path
from typing import Any

from rdflib import Graph

from kbplanner.core.named_queries import QueryResult
from kbplanner.model.graph_pickle import umask

log = logging.getLogger(__name__)

META = "meta.json"
ROWS = "rows"


def graphs_stamp(*graphs: Graph) -> str:
    """A hash of the triples of ``graphs``, whatever their order: the rows kept for an entry are used
    only while the project's graphs are the ones loaded (an API user may have changed them since)."""
    total = 0
    for i, g in enumerate(graphs):
        for s, p, o in g:
            digest = hashlib.blake2b(f"{i} {s.n3()} {p.n3()} {o.n3()}".encode(), digest_size=16).digest()
            total = (total + int.from_bytes(digest, "big")) % (1 << 128)
    return f"{total:032x}"


def _encode(value: Any) -> Any:
    kind = type(value)
    if value is None or kind in (str, bool, int, float):
        return value
    if kind is Decimal:
        return {"decimal": str(value)}
    if kind is datetime:
        return {"datetime": value.isoformat()}
    if kind is date:
        return {"date": value.isoformat()}
    raise TypeError(f"a value of type {kind.__name__} is not kept")


_DECODERS: dict[str, Any] = {"decimal": Decimal, "datetime": datetime.fromisoformat,
                             "date": date.fromisoformat}


def _decode(value: Any) -> Any:
    if isinstance(value, dict):
        ((kind, text),) = value.items()
        return _DECODERS[kind](text)
    return value


def read_rows(entry: Path, name: str, backend: str, stamp: str) -> QueryResult | None:
    """The rows of the named query ``name`` kept in ``entry`` for graphs with ``stamp`` on ``backend``."""
    try:
        data = json.loads((entry / ROWS / f"{name}.{backend}.json").read_text(encoding="utf-8"))
        if data["stamp"] != stamp:
            return None
        return QueryResult(columns=list(data["columns"]),
                           rows=[tuple(_decode(v) for v in row) for row in data["rows"]])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def write_rows(entry: Path, name: str, backend: str, stamp: str, result: QueryResult) -> None:
    """Keep the rows of ``name`` in ``entry`` (atomic replace); values of other types are not kept."""
    try:
        text = json.dumps({"stamp": stamp, "columns": result.columns,
                           "rows": [[_encode(v) for v in row] for row in result.rows]}, allow_nan=False)
        folder = entry / ROWS
        if not (entry / META).is_file():
            return
        folder.mkdir(exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{name}.", dir=folder)
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~umask())
        os.replace(tmp, folder / f"{name}.{backend}.json")
    except (OSError, ValueError, TypeError) as exc:
        log.info("rows of %s not kept in %s: %s", name, entry, exc)
