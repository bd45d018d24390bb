"""The 4D schedule from an IFC work schedule (import step, schedule part).

Takes an IFC file and the project's base IRI; returns a
:class:`~kbplanner.model.schedule_model.Schedule` read from its ``IfcWorkSchedule``, or None when the
file has none. What is read (see ``docs/schedule.md``):

- tasks: every ``IfcTask`` of the schedule, nested ones included, depth first;
  task id = ``Identification`` (IFC2X3: ``TaskId``), or the task's GlobalId when it is empty or
  not unique;
- times: ``IfcTaskTime.ScheduleStart`` / ``ScheduleFinish`` (IFC2X3: the ``IfcScheduleTimeControl``
  of ``IfcRelAssignsTasks``); a summary task without times spans its nested tasks;
- predecessors: ``IfcRelSequence`` (``RelatingProcess`` precedes ``RelatedProcess``);
- elements: ``IfcRelAssignsToProduct`` (the task's outputs), as ``element_iri(base, GlobalId)``;
- robot use: property set ``Pset_KbplannerTask`` with ``Robotized`` (boolean) and
  ``TaskSpecificationId`` (text).
"""

from __future__ import annotations

import logging
from collections import Counter
from datetime import date, datetime
from pathlib import Path
from typing import Any

import ifcopenshell
import ifcopenshell.util.date
import ifcopenshell.util.element
import ifcopenshell.util.sequence

from kbplanner.core.errors import IfcError, InputFileError, ScheduleError
from kbplanner.core.iris import element_iri
from kbplanner.model.schedule_model import Schedule, Task, check_acyclic, finish_of, parse_bool, start_of

logger = logging.getLogger(__name__)

PSET_NAME = "Pset_KbplannerTask"
PROP_ROBOTIZED = "Robotized"
PROP_SPECIFICATION = "TaskSpecificationId"


def _open(path: Path) -> Any:
    if not path.is_file():
        raise InputFileError("IFC file not found", file=path, fix="check the path in project.toml")
    try:
        return ifcopenshell.open(str(path))
    except Exception as exc:  # ifcopenshell raises several error types for unreadable files
        raise IfcError(f"cannot open the IFC file ({type(exc).__name__}: {exc})", file=path,
                       fix="export the model again as IFC2X3 or IFC4 (STEP, .ifc)") from None


def _label(task: Any) -> str:
    return f"IfcTask #{task.id()} '{task.Name or ''}' ({task.GlobalId})"


def _to_datetime(value: Any, *, is_finish: bool) -> datetime | None:
    """An IfcDateTime string (or IFC2X3 date entity) to a naive datetime; None if absent."""
    if value is None or value == "":
        return None
    parsed = ifcopenshell.util.date.ifc2datetime(value)
    if isinstance(parsed, datetime | date):
        return finish_of(parsed) if is_finish else start_of(parsed)
    return None


def _own_times(task: Any, path: Path) -> tuple[datetime | None, datetime | None]:
    """The task's own scheduled start and finish (either may be missing)."""
    try:
        time_entity = getattr(task, "TaskTime", None)
        if time_entity is not None:  # IFC4 and later
            return (_to_datetime(time_entity.ScheduleStart, is_finish=False),
                    _to_datetime(time_entity.ScheduleFinish, is_finish=True))
        for rel in task.HasAssignments or ():  # IFC2X3: IfcRelAssignsTasks.TimeForTask
            if rel.is_a("IfcRelAssignsTasks") and rel.TimeForTask is not None:
                control = rel.TimeForTask
                return (_to_datetime(control.ScheduleStart, is_finish=False),
                        _to_datetime(control.ScheduleFinish, is_finish=True))
    except (ValueError, TypeError) as exc:
        raise ScheduleError(f"{_label(task)} has an unreadable schedule date ({exc})", file=path,
                            element=task.GlobalId,
                            fix="write ScheduleStart/ScheduleFinish as ISO date-times, "
                                "e.g. 2024-03-04T08:00:00") from None
    return None, None


def _times(task: Any, path: Path, cache: dict[int, tuple[datetime, datetime]]) -> tuple[datetime, datetime]:
    """Start and finish of a task; a summary task without its own times spans its nested tasks."""
    if task.id() in cache:
        return cache[task.id()]
    start, finish = _own_times(task, path)
    if start is None or finish is None:
        nested = ifcopenshell.util.sequence.get_nested_tasks(task)
        spans = [_times(n, path, cache) for n in nested]
        if spans:
            start = start if start is not None else min(s for s, _ in spans)
            finish = finish if finish is not None else max(f for _, f in spans)
    if start is None or finish is None:
        raise ScheduleError(
            f"{_label(task)} has no scheduled {'start' if start is None else 'finish'}",
            file=path, element=task.GlobalId,
            fix="give the task an IfcTaskTime with ScheduleStart and ScheduleFinish (or nest timed "
                "tasks under it), or use a CSV schedule",
        )
    if finish < start:
        raise ScheduleError(
            f"{_label(task)} finishes ({finish.isoformat()}) before it starts ({start.isoformat()})",
            file=path, element=task.GlobalId, fix="correct ScheduleStart/ScheduleFinish of the task",
        )
    cache[task.id()] = (start, finish)
    return start, finish


def _robot_use(task: Any, path: Path) -> tuple[bool, str | None]:
    pset = ifcopenshell.util.element.get_pset(task, PSET_NAME) or {}
    raw = pset.get(PROP_ROBOTIZED)
    robotized = raw if isinstance(raw, bool) else parse_bool("" if raw is None else str(raw))
    if robotized is None:
        raise ScheduleError(f"{_label(task)}: {PSET_NAME}.{PROP_ROBOTIZED} = {raw!r} is not a boolean",
                            file=path, element=task.GlobalId,
                            fix=f"set {PSET_NAME}.{PROP_ROBOTIZED} to an IfcBoolean TRUE or FALSE")
    spec_raw = pset.get(PROP_SPECIFICATION)
    spec = str(spec_raw).strip() if spec_raw is not None and str(spec_raw).strip() else None
    if robotized and spec is None:
        raise ScheduleError(
            f"{_label(task)} is robotized but has no {PSET_NAME}.{PROP_SPECIFICATION}",
            file=path, element=task.GlobalId,
            fix=f"add {PSET_NAME}.{PROP_SPECIFICATION} naming the knowledge-base task specification "
                "(e.g. I-W-F-#1), or set Robotized to FALSE",
        )
    return robotized, spec


def _pick_schedule(f: Any, path: Path, schedule_name: str | None) -> Any | None:
    schedules = sorted(f.by_type("IfcWorkSchedule"), key=lambda s: (s.Name or "", s.GlobalId))
    if schedule_name is not None:
        schedules = [s for s in schedules if s.Name == schedule_name]
        if not schedules:
            names = ", ".join(repr(s.Name) for s in f.by_type("IfcWorkSchedule")) or "(none)"
            raise ScheduleError(f"no IfcWorkSchedule named '{schedule_name}'", file=path,
                                element=schedule_name, fix=f"use one of the schedule names: {names}")
    if not schedules:
        return None
    if len(schedules) > 1:
        names = ", ".join(repr(s.Name) for s in schedules)
        raise ScheduleError(f"the file has {len(schedules)} work schedules ({names})", file=path,
                            fix="name the one to use (schedule_name / the project's schedule setting)")
    return schedules[0]


def read_ifc_schedule(ifc_path: Path, base: str, *, schedule_name: str | None = None) -> Schedule | None:
    """Read the IFC work schedule of a file; None when the file has no ``IfcWorkSchedule``.

    ``schedule_name`` picks one schedule by ``Name`` when the file has several.

    Example:
        >>> import ifcopenshell.api.root, ifcopenshell.api.sequence, tempfile
        >>> f = ifcopenshell.file(schema="IFC4")
        >>> _ = ifcopenshell.api.root.create_entity(f, ifc_class="IfcProject")
        >>> ws = ifcopenshell.api.sequence.add_work_schedule(f, name="Plan")
        >>> task = ifcopenshell.api.sequence.add_task(f, work_schedule=ws, name="Walls", identification="T1")
        >>> tt = ifcopenshell.api.sequence.add_task_time(f, task=task)
        >>> tt.ScheduleStart, tt.ScheduleFinish = "2024-03-04T08:00:00", "2024-03-05T16:00:00"
        >>> p = Path(tempfile.mkdtemp()) / "m.ifc"; f.write(str(p))
        >>> s = read_ifc_schedule(p, "https://w3id.org/kbplanner/data/demo/")
        >>> s.tasks[0].task_id, s.tasks[0].finish.isoformat()
        ('T1', '2024-03-05T16:00:00')
    """
    path = Path(ifc_path)
    f = _open(path)
    ws = _pick_schedule(f, path, schedule_name)
    if ws is None:
        logger.info("%s: no IfcWorkSchedule", path)
        return None
    ifc_tasks = list(dict.fromkeys(ifcopenshell.util.sequence.get_work_schedule_tasks(ws)))

    idents = {t.id(): (getattr(t, "Identification", None) or getattr(t, "TaskId", None) or "").strip()
              for t in ifc_tasks}
    counts = Counter(i for i in idents.values() if i)
    ids: dict[int, str] = {}
    for t in ifc_tasks:
        ident = idents[t.id()]
        if ident and counts[ident] == 1:
            ids[t.id()] = ident
        else:
            if ident:
                logger.warning("%s: task Identification %r is not unique; using GlobalId %s",
                               path, ident, t.GlobalId)
            ids[t.id()] = t.GlobalId
    if len(set(ids.values())) != len(ids):
        clash = next(i for i, n in Counter(ids.values()).items() if n > 1)
        raise ScheduleError(f"two tasks get the id '{clash}'", file=path, element=clash,
                            fix="give each IfcTask a unique Identification")

    cache: dict[int, tuple[datetime, datetime]] = {}
    tasks: list[Task] = []
    for t in ifc_tasks:
        start, finish = _times(t, path, cache)
        preds: list[str] = []
        for rel in t.IsSuccessorFrom or ():
            pred = rel.RelatingProcess
            if pred.id() in ids:
                preds.append(ids[pred.id()])
            else:
                logger.warning("%s: predecessor %s of %s is not in work schedule %r; ignored",
                               path, pred.GlobalId, ids[t.id()], ws.Name)
        products = sorted(ifcopenshell.util.sequence.get_task_outputs(t), key=lambda p: p.GlobalId)
        robotized, spec = _robot_use(t, path)
        tasks.append(Task(
            task_id=ids[t.id()],
            name=t.Name or ids[t.id()],
            start=start,
            finish=finish,
            predecessors=tuple(sorted(set(preds))),
            element_iris=tuple(element_iri(base, p.GlobalId) for p in products),
            robotized=robotized,
            task_specification_id=spec,
        ))
    check_acyclic(tasks, path)
    logger.info("%s: work schedule %r, %d tasks, %d robotized", path, ws.Name, len(tasks),
                sum(t.robotized for t in tasks))
    return Schedule(schedule_id=ws.GlobalId, name=ws.Name or ws.GlobalId, source=str(path),
                    tasks=tuple(tasks))
