"""The 4D schedule (import step, schedule part; feeds A1 and A6).

Reads a construction schedule from CSV (:func:`read_csv_schedule`, elements resolved against the
model graph) or from the IFC work schedule (:func:`read_ifc_schedule`), both giving a typed
:class:`Schedule`; writes it as RDF (:func:`schedule_to_graph`: ``kbp:ConstructionSchedule``,
``kbp:ConstructionTask`` with start, finish, predecessors, built elements, robot use); and answers
which elements are built, in progress or not started at a date (:func:`element_states`, the named
query ``element_state_at``), which the world at a date (A6) is made from.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from rdflib import RDF, RDFS, XSD, Graph, Literal, URIRef

from kbplanner.core.errors import QueryError
from kbplanner.core.iris import mint, task_iri
from kbplanner.core.rdf_io import new_graph
from kbplanner.core.vocab import KBP
from kbplanner.model.schedule_csv import read_csv_schedule
from kbplanner.model.schedule_model import Schedule, Task, query_text

__all__ = [
    "ElementState",
    "Schedule",
    "Task",
    "element_state_rows",
    "element_states",
    "read_csv_schedule",
    "read_ifc_schedule",
    "schedule_iri",
    "schedule_to_graph",
]

logger = logging.getLogger(__name__)

STATES: tuple[URIRef, ...] = (KBP.Built, KBP.InProgress, KBP.NotStarted)


def _dt(value: datetime) -> Literal:
    return Literal(value.replace(microsecond=0), datatype=XSD.dateTime)


def read_ifc_schedule(ifc_path: Path, base: str, *, schedule_name: str | None = None) -> Schedule | None:
    """:func:`kbplanner.model.schedule_ifc.read_ifc_schedule` (ifcopenshell loaded only when asked)."""
    from kbplanner.model import schedule_ifc

    return schedule_ifc.read_ifc_schedule(ifc_path, base, schedule_name=schedule_name)


def schedule_iri(base: str, schedule_id: str) -> URIRef:
    """IRI of a construction schedule keyed by its id."""
    return mint(base, "schedule", schedule_id)


def schedule_to_graph(schedule: Schedule, base: str) -> Graph:
    """The schedule as RDF: one ``kbp:ConstructionSchedule`` with its ``kbp:ConstructionTask`` s.

    Every node is an IRI minted from ``base`` (no blank nodes), so serialising the graph gives the
    same bytes for the same schedule.

    Example:
        >>> t = Task("T1", "Walls", datetime(2024, 3, 4, 8), datetime(2024, 3, 4, 17), robotized=True,
        ...          task_specification_id="I-W-F-#1")
        >>> g = schedule_to_graph(Schedule("demo", "Demo", "demo.csv", (t,)), "https://example.org/p/")
        >>> g.value(task_iri("https://example.org/p/", "T1"), KBP.taskSpecificationId)
        rdflib.term.Literal('I-W-F-#1')
    """
    g = new_graph()
    s = schedule_iri(base, schedule.schedule_id)
    g.add((s, RDF.type, KBP.ConstructionSchedule))
    g.add((s, RDFS.label, Literal(schedule.name)))
    g.add((s, KBP.sourceFile, Literal(schedule.source.replace("\\", "/").rsplit("/", 1)[-1])))
    for task in schedule.tasks:
        t = task_iri(base, task.task_id)
        g.add((s, KBP.hasTask, t))
        g.add((t, RDF.type, KBP.ConstructionTask))
        g.add((t, KBP.taskId, Literal(task.task_id)))
        g.add((t, RDFS.label, Literal(task.name)))
        g.add((t, KBP.start, _dt(task.start)))
        g.add((t, KBP.finish, _dt(task.finish)))
        g.add((t, KBP.robotized, Literal(task.robotized, datatype=XSD.boolean)))
        if task.task_specification_id is not None:
            g.add((t, KBP.taskSpecificationId, Literal(task.task_specification_id)))
        for p in task.predecessors:
            g.add((t, KBP.predecessor, task_iri(base, p)))
        for el in task.element_iris:
            g.add((t, KBP.buildsElement, el))
    logger.debug("schedule %s: %d triples", schedule.schedule_id, len(g))
    return g


@dataclass(frozen=True)
class ElementState:
    """One row of ``element_state_at``: an element, its GlobalId and label (if any), its state."""

    element: URIRef
    global_id: str | None
    label: str | None
    state: URIRef


def element_state_rows(graph: Graph, at: datetime) -> list[ElementState]:
    """Every element's state at ``at`` (naive local site time), sorted by element IRI.

    Scheduled elements are ``kbp:Built`` (finish < at), ``kbp:InProgress`` (start <= at <= finish)
    or ``kbp:NotStarted`` (start > at), judged by the task with the latest finish; elements with a
    GlobalId that no task builds exist already and are ``kbp:Built``. ``graph`` holds the model and
    the schedule (e.g. ``model + schedule_to_graph(...)``); it may be an rdflib or Oxigraph graph.
    """
    if at.tzinfo is not None:
        raise QueryError(
            f"element_state_at: 'at' = {at.isoformat()} has a time zone; schedule times are local "
            "site times without one",
            element="at",
            fix="pass a naive datetime in local site time, e.g. at.replace(tzinfo=None)",
        )
    rows: dict[URIRef, ElementState] = {}
    result = graph.query(query_text("element_state_at"), initBindings={"at": _dt(at)})
    for row in result:
        element, gid, label, state, _at = row  # type: ignore[misc]
        if not isinstance(element, URIRef) or not isinstance(state, URIRef):
            continue
        if element in rows:  # several GlobalIds or labels: one state all the same
            continue
        rows[element] = ElementState(
            element=element,
            global_id=str(gid) if gid is not None else None,
            label=str(label) if label is not None else None,
            state=state,
        )
    return [rows[k] for k in sorted(rows, key=str)]


def element_states(graph: Graph, at: datetime) -> dict[URIRef, URIRef]:
    """Map each element to ``kbp:Built``, ``kbp:InProgress`` or ``kbp:NotStarted`` at ``at``.

    Example:
        >>> from kbplanner.core.iris import element_iri
        >>> base = "https://example.org/p/"
        >>> wall = element_iri(base, "2O2Fr$t4X7Zf8NOew3FLOH")
        >>> t = Task("T1", "Walls", datetime(2024, 3, 4, 8), datetime(2024, 3, 4, 17), element_iris=(wall,))
        >>> g = schedule_to_graph(Schedule("demo", "Demo", "demo.csv", (t,)), base)
        >>> element_states(g, datetime(2024, 3, 4, 12))[wall] == KBP.InProgress
        True
    """
    return {r.element: r.state for r in element_state_rows(graph, at)}
