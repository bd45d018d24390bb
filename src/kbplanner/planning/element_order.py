"""B1, element order: in which order the robot works through the elements of a robotized task.

Two rules, chosen from what the model holds (named query ``plan_element_order``):

1. **Work sequence.** When elements of the task carry ``kbp:workSequence`` (an integer, 1 = first;
   declared in ``ontology/kbplanner.ttl``), they come first in ascending sequence, ties broken by
   GlobalId. Elements without a sequence follow, ordered by rule 2.
2. **Nearest install location first.** Each element's horizontal (x, y) distance from its install
   location (``kbp:installedPose``) to where the robot fetches it: the pickup location of the storage
   it is stored in (``kbp:storedIn / kbp:pickupLocation``) if it has one, else the robot start
   (``kbp:robotStart`` of the site layout, passed in). Shorter first; ties (equal to 1 µm) broken by
   GlobalId. Elements without an install location (or with nowhere to measure from) go last, by
   GlobalId.

The rule that was used is returned as text and recorded in ``Plan.order_rule``.

Takes the model graph, the task IRI and the robot start; returns an :class:`ElementOrder`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

from rdflib import Graph, Literal, URIRef
from rdflib.term import Node

from kbplanner.knowledge.knowledge_base import select

log = logging.getLogger(__name__)

RULE_SEQUENCE = "work sequence (kbp:workSequence, ascending; ties by GlobalId)"
RULE_NEAREST = ("nearest install location first: horizontal distance from the element's storage pickup "
                "location (kbp:storedIn / kbp:pickupLocation), else from the robot start; ties by GlobalId")
RULE_GLOBAL_ID = "by GlobalId (no install locations, or nowhere to measure from)"


@dataclass(frozen=True)
class ElementOrder:
    """The task's elements in work order and the rule that ordered them."""

    elements: tuple[URIRef, ...]
    rule: str
    distances_m: dict[URIRef, float | None]


@dataclass
class _Row:
    element: URIRef
    global_id: str
    sequence: int | None = None
    xy: tuple[float, float] | None = None
    pickup: tuple[float, float] | None = None


def _float(v: Node | None) -> float | None:
    if isinstance(v, Literal):
        try:
            return float(v.toPython())
        except (TypeError, ValueError):
            return None
    return None


def _rows(model: Graph, task: URIRef) -> list[_Row]:
    out: dict[URIRef, _Row] = {}
    for r in select(model, "plan_element_order", task=task):
        el = r["element"]
        if not isinstance(el, URIRef):
            continue
        row = out.get(el)
        if row is None:
            gid = r["globalId"]
            row = out[el] = _Row(el, str(gid) if gid is not None else str(el))
        seq = r["sequence"]
        if row.sequence is None and isinstance(seq, Literal):
            try:
                row.sequence = int(seq.toPython())
            except (TypeError, ValueError):
                log.warning("kbp:workSequence %r of %s is not an integer: ignored", str(seq), row.global_id)
        x, y = _float(r["x"]), _float(r["y"])
        if row.xy is None and x is not None and y is not None:
            row.xy = (x, y)
        px, py = _float(r["pickupX"]), _float(r["pickupY"])
        if row.pickup is None and px is not None and py is not None:
            row.pickup = (px, py)  # first storage by IRI (query order), deterministic
    return list(out.values())


def element_order(model: Graph, task: URIRef,
                  robot_start: tuple[float, float] | None = None) -> ElementOrder:
    """B1: the elements built by ``task`` in work order (see the module docstring for the rules).

    Example:
        >>> element_order(Graph(), URIRef("urn:x:task")).elements
        ()
    """
    rows = _rows(model, task)
    distances: dict[URIRef, float | None] = {}
    for row in rows:
        origin = row.pickup or robot_start
        d = None
        if row.xy is not None and origin is not None:
            d = round(math.hypot(row.xy[0] - origin[0], row.xy[1] - origin[1]), 6)
        distances[row.element] = d

    sequenced = sorted((r for r in rows if r.sequence is not None),
                       key=lambda r: (r.sequence, r.global_id, str(r.element)))
    rest = sorted((r for r in rows if r.sequence is None),
                  key=lambda r: (distances[r.element] is None, distances[r.element] or 0.0, r.global_id,
                                 str(r.element)))
    measured = any(distances[r.element] is not None for r in rest)
    if sequenced and rest:
        then = RULE_NEAREST if measured else RULE_GLOBAL_ID
        rule = f"{RULE_SEQUENCE}; then elements without one: {then}"
    elif sequenced:
        rule = RULE_SEQUENCE
    else:
        rule = RULE_NEAREST if measured else RULE_GLOBAL_ID
    ordered = tuple(r.element for r in [*sequenced, *rest])
    log.info("element order of %s: %d elements, %s", task, len(ordered), rule)
    return ElementOrder(elements=ordered, rule=rule, distances_m=distances)
