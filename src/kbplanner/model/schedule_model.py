"""The 4D schedule, data objects (import step, schedule part): tasks and schedules as typed values.

Both schedule readers (:mod:`kbplanner.model.schedule_csv`, :mod:`kbplanner.model.schedule_ifc`) return a
:class:`Schedule`; :mod:`kbplanner.model.schedule` turns it into RDF. This module also holds what both
readers share: the date-only conventions, the boolean spellings and the predecessor cycle check.

Times are naive ``datetime`` values in local site time, to the second.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from datetime import date, datetime, time
from pathlib import Path

from rdflib import URIRef

from kbplanner.core.errors import ScheduleCycleError
from kbplanner.core.named_queries import get_query

logger = logging.getLogger(__name__)

END_OF_DAY = time(23, 59, 59)
"""A date-only finish means the end of that day."""

TRUE_WORDS = frozenset({"true", "yes", "1"})
FALSE_WORDS = frozenset({"false", "no", "0", ""})


@dataclass(frozen=True)
class Task:
    """One construction task: when it runs, what it waits for, which elements it builds.

    ``element_iris`` keeps the order in which the schedule lists the elements (the work sequence
    when the source gives one); ``predecessors`` are task ids of the same schedule.
    """

    task_id: str
    name: str
    start: datetime
    finish: datetime
    predecessors: tuple[str, ...] = ()
    element_iris: tuple[URIRef, ...] = ()
    robotized: bool = False
    task_specification_id: str | None = None


@dataclass(frozen=True)
class Schedule:
    """A construction schedule: its id (keys its IRI), a label, where it came from, its tasks in source order.

    Example:
        >>> t = Task("T1", "Walls", datetime(2024, 3, 4, 8), datetime(2024, 3, 4, 17))
        >>> s = Schedule("demo", "Demo", "demo.csv", (t,))
        >>> s.task("T1").name, s.start, s.finish
        ('Walls', datetime.datetime(2024, 3, 4, 8, 0), datetime.datetime(2024, 3, 4, 17, 0))
    """

    schedule_id: str
    name: str
    source: str
    tasks: tuple[Task, ...] = field(default_factory=tuple)

    def task(self, task_id: str) -> Task:
        """The task with this id; KeyError names the ids that exist."""
        for t in self.tasks:
            if t.task_id == task_id:
                return t
        raise KeyError(f"no task {task_id!r} in schedule {self.schedule_id!r}; "
                       f"tasks: {', '.join(t.task_id for t in self.tasks)}")

    def robotized_tasks(self) -> tuple[Task, ...]:
        """The tasks to be done by a robot, in schedule order (paper, A1)."""
        return tuple(t for t in self.tasks if t.robotized)

    def tasks_building(self, element: URIRef) -> tuple[Task, ...]:
        """The tasks that build ``element``, in schedule order."""
        return tuple(t for t in self.tasks if element in t.element_iris)

    @property
    def start(self) -> datetime | None:
        """Earliest task start, or None for an empty schedule."""
        return min((t.start for t in self.tasks), default=None)

    @property
    def finish(self) -> datetime | None:
        """Latest task finish, or None for an empty schedule."""
        return max((t.finish for t in self.tasks), default=None)


def start_of(value: date | datetime) -> datetime:
    """A start time: a date alone means 00:00:00 of that day; seconds precision, time zone dropped."""
    if isinstance(value, datetime):
        return value.replace(tzinfo=None, microsecond=0)
    return datetime.combine(value, time(0, 0, 0))


def finish_of(value: date | datetime) -> datetime:
    """A finish time: a date alone means 23:59:59 of that day; seconds precision, time zone dropped."""
    if isinstance(value, datetime):
        return value.replace(tzinfo=None, microsecond=0)
    return datetime.combine(value, END_OF_DAY)


def parse_bool(text: str) -> bool | None:
    """``true/false/yes/no/1/0`` (any case, empty = false) to a bool; None if it is none of these."""
    word = text.strip().lower()
    if word in TRUE_WORDS:
        return True
    if word in FALSE_WORDS:
        return False
    return None


def find_cycle(tasks: Iterable[Task]) -> list[str] | None:
    """One predecessor cycle as task ids in execution order (each waits for the one before), or None.

    The cycle is rotated to start at its smallest task id, so the answer does not depend on where
    the search began.
    """
    import networkx as nx  # a third of a second to import: not for commands that read no schedule

    g = nx.DiGraph()
    for t in tasks:
        g.add_node(t.task_id)
        for p in t.predecessors:
            g.add_edge(p, t.task_id)
    try:
        edges = nx.find_cycle(g)
    except nx.NetworkXNoCycle:
        return None
    cycle = [str(u) for u, _v, *_ in edges]
    i = cycle.index(min(cycle))
    return cycle[i:] + cycle[:i]


def check_acyclic(tasks: Iterable[Task], file: str | Path) -> None:
    """Raise :class:`ScheduleCycleError` (carrying the cycle) if predecessor links form a cycle."""
    cycle = find_cycle(tasks)
    if cycle is not None:
        raise ScheduleCycleError(cycle, file=file)



def query_text(name: str) -> str:
    """The constant text of the named query ``queries/<name>.rq`` (never formatted; values are bound)."""
    return get_query(name).text
