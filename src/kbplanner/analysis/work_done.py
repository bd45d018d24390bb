"""Analysis: what a run did, in words, from the step details the skill kinds record (metrics.json).

One phrase per kind of work found among the succeeded steps: ``placed N elements`` (place steps:
a placement error), ``marked X m of Y m of lines`` (tool path steps: ``marked_m`` and
``line_length_m``), ``fastened N`` (fasten steps: ``force_n``), ``inspected N views`` (inspect
steps: ``distance_m`` with ``dwell_s``). Used by the every-task table (``tasks.csv``, the report).

Example:
    >>> work_done({"per_element": [{"steps": [{"outcome": "succeeded", "details": {
    ...     "marked_m": 2.5, "line_length_m": 2.92}}]}]})
    'marked 2.50 m of 2.92 m of lines'
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


def work_done(metrics: Mapping[str, Any]) -> str:
    """The work of a run in words (see module docstring); "" when none of the kinds above ran."""
    placed = fastened = viewed = 0
    marked = line = 0.0
    tool_steps = 0
    for e in metrics.get("per_element", []):
        for s in e.get("steps", []):
            d = s.get("details") or {}
            if "line_length_m" in d:
                tool_steps += 1
                line += float(d["line_length_m"])
                marked += float(d.get("marked_m") or 0.0)
            if s.get("outcome") != "succeeded":
                continue
            if "placement_error_m" in d:
                placed += 1
            if "force_n" in d:
                fastened += 1
            if "distance_m" in d and "dwell_s" in d:
                viewed += 1
    parts = []
    if placed:
        parts.append(f"placed {placed} element{'s' if placed != 1 else ''}")
    if tool_steps:
        parts.append(f"marked {marked:.2f} m of {line:.2f} m of lines")
    if fastened:
        parts.append(f"fastened {fastened}")
    if viewed:
        parts.append(f"inspected {viewed} view{'s' if viewed != 1 else ''}")
    return "; ".join(parts)
