"""B1, element order: in which order the robot works through the elements of a robotized task.

Two rules, chosen from what the model holds, then the stack (named query ``plan_element_order``):

1. **Work sequence.** When elements of the task carry ``kbp:workSequence`` (an integer, 1 = first;
   declared in ``ontology/kbplanner.ttl``), they come first in ascending sequence, ties broken by
   GlobalId. Elements without a sequence follow, ordered by rule 2.
2. **Nearest install location first.** Each element's horizontal (x, y) distance from its install
   location (``kbp:installedPose``) to where the robot fetches it: the pickup location of the storage
   it is stored in (``kbp:storedIn / kbp:pickupLocation``) if it has one, else the robot start
   (``kbp:robotStart`` of the site layout, passed in). Shorter first; ties (equal to 1 µm) broken by
   GlobalId. Elements without an install location (or with nowhere to measure from) go last, by
   GlobalId.

Then the **stack**: elements lying in one storage (``kbp:storedIn``) are picked from the top of the
stack, so an element comes after every element of the same storage with a higher ``kbp:stackIndex``
(0 = bottom; the same stacking the world builds, :mod:`kbplanner.world.build`). The order of rules
1-2 is kept wherever the stack allows it (the first element in that order whose elements above are
all taken goes next). An explicit work sequence still wins between two elements that both carry one:
when it contradicts the stack, B4 reports the pick as infeasible with the fix.

The rule that was used is returned as text and recorded in ``Plan.order_rule``.

Takes the model graph, the task IRI and the robot start; returns an :class:`ElementOrder`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

from rdflib import Graph, Literal, URIRef

from kbplanner.core.literals import literal_float as _float
from kbplanner.knowledge.knowledge_base import select

log = logging.getLogger(__name__)

RULE_SEQUENCE = "work sequence (kbp:workSequence, ascending; ties by GlobalId)"
RULE_NEAREST = ("nearest install location first: horizontal distance from the element's storage pickup "
                "location (kbp:storedIn / kbp:pickupLocation), else from the robot start; ties by GlobalId")
RULE_GLOBAL_ID = "by GlobalId (no install locations, or nowhere to measure from)"
RULE_STACK = ("top of each storage's stack first (kbp:stackIndex, highest first; an explicit "
              "kbp:workSequence wins)")


@dataclass(frozen=True)
class ElementOrder:
    """The task's elements in work order and the rule that ordered them."""

    elements: tuple[URIRef, ...]
    rule: str
    distances_m: dict[URIRef, float | None]
    sequences: dict[URIRef, int] = field(default_factory=dict)  # kbp:workSequence where given


@dataclass
class _Row:
    element: URIRef
    global_id: str
    sequence: int | None = None
    xy: tuple[float, float] | None = None
    pickup: tuple[float, float] | None = None
    storage: URIRef | None = None
    stack_index: int | None = None


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
        st, index = r["storage"], r["stackIndex"]
        if row.storage is None and isinstance(st, URIRef):
            row.storage = st  # first storage by IRI (query order), as the world places it
        if row.stack_index is None and isinstance(index, Literal) and st == row.storage:
            try:
                row.stack_index = int(index.toPython())
            except (TypeError, ValueError):
                log.warning("kbp:stackIndex %r of %s is not an integer: ignored", str(index), row.global_id)
        px, py = _float(r["pickupX"]), _float(r["pickupY"])
        if row.pickup is None and px is not None and py is not None:
            row.pickup = (px, py)  # first storage by IRI (query order), deterministic
    return list(out.values())


def _above(row: _Row, rows: list[_Row]) -> list[_Row]:
    """Elements of the same storage higher on its stack (the world stacks unindexed ones on top, by IRI)."""
    if row.storage is None:
        return []

    def level(r: _Row) -> tuple[bool, int, str]:
        return (r.stack_index is None, r.stack_index or 0, str(r.element))

    return [r for r in rows if r.storage == row.storage and r is not row and level(r) > level(row)]


def _stack_order(rows: list[_Row]) -> tuple[list[_Row], bool]:
    """``rows`` (in preference order) reordered so that an element follows every element above it.

    Greedy and stable: the first element in preference order whose elements above are all taken goes
    next. Between two elements that both carry a work sequence, the sequence is kept (it wins). Returns
    the order and whether the stack changed it.
    """
    above = {id(r): [a for a in _above(r, rows) if not (a.sequence is not None and r.sequence is not None)]
             for r in rows}
    done: set[int] = set()
    out: list[_Row] = []
    left = list(rows)
    while left:
        nxt = next((r for r in left if all(id(a) in done for a in above[id(r)])), left[0])
        out.append(nxt)
        done.add(id(nxt))
        left.remove(nxt)
    return out, [r.element for r in out] != [r.element for r in rows]


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
    ordered_rows, moved = _stack_order([*sequenced, *rest])
    if moved:
        rule = f"{rule}; then {RULE_STACK}"
    ordered = tuple(r.element for r in ordered_rows)
    log.info("element order of %s: %d elements, %s", task, len(ordered), rule)
    return ElementOrder(elements=ordered, rule=rule, distances_m=distances,
                        sequences={r.element: r.sequence for r in rows if r.sequence is not None})
