"""Tabular output (CLI): rows rendered as a terminal table, CSV or JSON.

Used by the commands that print query results, requirements and comparisons; a library function
returns the text, the CLI decides where it goes.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Callable, Sequence
from datetime import date, datetime
from decimal import Decimal
from typing import Any

FORMATS = ("table", "csv", "json")


def _plain(value: Any) -> Any:
    if isinstance(value, datetime | date):
        return value.isoformat()
    if isinstance(value, Decimal):  # xsd:decimal: a JSON number
        value = float(value)
    if isinstance(value, float):
        return round(value, 6)
    if value is None or isinstance(value, str | int | bool):
        return value
    return str(value)  # durations, times, other literal values: their text


def decimal_text(value: Decimal) -> str:
    """The canonical text of an xsd:decimal (``1.0``, ``0.2``, ``-3.25``): stores differ in the text they
    keep (rdflib the one read, Oxigraph its own), so tables print this one.

    Example:
        >>> [decimal_text(Decimal(t)) for t in ("1", "1.0", "0.20", "-3.250", "1E+1")]
        ['1.0', '1.0', '0.2', '-3.25', '10.0']
    """
    text = format(value.normalize(), "f")
    return text if "." in text or not value.is_finite() else text + ".0"


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, Decimal):
        return decimal_text(value)
    if isinstance(value, float):
        return f"{value:.3f}"
    if isinstance(value, datetime | date):
        return value.isoformat()
    return str(value)


def render(columns: Sequence[str], rows: Sequence[Sequence[Any]], fmt: str = "table",
           title: str | None = None, shorten: Callable[[str], str] | None = None) -> str:
    """Render rows as ``table`` (aligned text), ``csv`` or ``json`` (a list of objects).

    ``shorten`` rewrites long strings (IRIs) in the ``table`` format only.

    Example:
        >>> print(render(["a", "b"], [(1, "x")], "csv").strip())
        a,b
        1,x
    """
    if fmt == "csv":
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(columns)
        for r in rows:
            w.writerow([_cell(v) for v in r])
        return buf.getvalue()
    if fmt == "json":
        return json.dumps([{c: _plain(v) for c, v in zip(columns, r, strict=True)} for r in rows],
                          indent=2, ensure_ascii=False, allow_nan=False) + "\n"
    if fmt != "table":
        raise ValueError(f"unknown format {fmt!r}; use one of {FORMATS}")
    cut = shorten or (lambda s: s)
    cells = [[cut(_cell(v)) for v in r] for r in rows]
    widths = [len(c) for c in columns]
    for r in cells:
        for i, v in enumerate(r):
            widths[i] = min(max(widths[i], len(v)), 80)
    lines = []
    if title:
        lines.append(title)
    lines.append("  ".join(c.ljust(widths[i]) for i, c in enumerate(columns)).rstrip())
    lines.append("  ".join("-" * w for w in widths))
    for r in cells:
        lines.append("  ".join(v[:80].ljust(widths[i]) for i, v in enumerate(r)).rstrip())
    lines.append(f"({len(rows)} row{'s' if len(rows) != 1 else ''})")
    return "\n".join(lines) + "\n"


def iri_shortener(base: str) -> Callable[[str], str]:
    """Shorten IRIs for display: the project's data IRIs to ``element/<GlobalId>``, kbp/bot to prefixes."""
    from urllib.parse import unquote

    prefixes = {
        "https://w3id.org/kbplanner/ontology#": "kbp:",
        "https://w3id.org/bot#": "bot:",
    }

    def cut(s: str) -> str:
        if s.startswith(base):
            return unquote(s[len(base):])
        for ns, pre in prefixes.items():
            if s.startswith(ns):
                return pre + s[len(ns):]
        return s

    return cut
