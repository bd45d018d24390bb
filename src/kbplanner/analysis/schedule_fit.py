"""Durations against the schedule (analysis): does the simulated robot work fit the task's window?

The robot works only in the project's working hours (``[calendar]`` of project.toml: daily start and
end, working weekdays). Given a task window (start, finish) and the simulated working time, this gives
the working time the window offers, the date and time the work would end if started at the window's
start, and whether it fits. The result is written back to the 4D model as RDF (PROV-O: the simulation
run is a prov:Activity that generated the figures), as a copy of the CSV schedule with two extra
columns, and, for projects whose schedule is the IFC's own, as a copy of the IFC file whose task times
carry the simulated duration and finish, so 4D tools can play the simulated task.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from datetime import datetime, time, timedelta
from pathlib import Path
from typing import Any

from rdflib import RDF, XSD, Graph, Literal, Namespace, URIRef

from kbplanner.core.errors import ProjectError
from kbplanner.core.vocab import KBP
from kbplanner.model.project_manifest import Calendar

PROV = Namespace("http://www.w3.org/ns/prov#")
_DAYS = ("Mon", "Tue", "Wed", "Thu", "Fri", "Sat", "Sun")


@dataclass(frozen=True)
class WorkCalendar:
    """Working hours: daily start and end, working weekdays (0 = Monday)."""

    start: time
    end: time
    weekdays: frozenset[int]

    @classmethod
    def from_calendar(cls, cal: Calendar) -> WorkCalendar:
        """From the manifest's ``[calendar]``; bad values are a ProjectError."""
        try:
            start, end = time.fromisoformat(cal.work_start), time.fromisoformat(cal.work_end)
        except ValueError:
            raise ProjectError(f"working hours {cal.work_start!r}-{cal.work_end!r} are not HH:MM",
                               element="calendar",
                               fix='write work_start = "07:00", work_end = "15:30"') from None
        if end <= start:
            raise ProjectError("work_end is not after work_start", element="calendar",
                               fix="give the daily working hours in order")
        days = set()
        for d in cal.workdays:
            if d not in _DAYS:
                raise ProjectError(f"unknown weekday {d!r}", element="calendar.workdays",
                                   fix="use Mon, Tue, Wed, Thu, Fri, Sat, Sun")
            days.add(_DAYS.index(d))
        return cls(start=start, end=end, weekdays=frozenset(days))

    def working_seconds(self, a: datetime, b: datetime) -> float:
        """Working seconds between two date-times."""
        total = 0.0
        day = a.date()
        while day <= b.date():
            if day.weekday() in self.weekdays:
                lo = max(a, datetime.combine(day, self.start))
                hi = min(b, datetime.combine(day, self.end))
                if hi > lo:
                    total += (hi - lo).total_seconds()
            day += timedelta(days=1)
        return total

    def add_working_time(self, start: datetime, seconds: float) -> datetime:
        """The date-time at which ``seconds`` of work started at ``start`` end (working hours only).

        Example:
            >>> c = WorkCalendar(time(7), time(15), frozenset(range(5)))
            >>> c.add_working_time(datetime(2022, 5, 13, 14), 2 * 3600)  # Friday 14:00 + 2 h
            datetime.datetime(2022, 5, 16, 8, 0)
        """
        if not self.weekdays:
            raise ProjectError("the calendar has no working day", element="calendar.workdays",
                               fix="list the working weekdays")
        left = float(seconds)
        t = start
        while True:
            day_start = datetime.combine(t.date(), self.start)
            day_end = datetime.combine(t.date(), self.end)
            if t.weekday() in self.weekdays and t < day_end:
                t = max(t, day_start)
                avail = (day_end - t).total_seconds()
                if left <= avail:
                    return t + timedelta(seconds=left)
                left -= avail
            t = datetime.combine(t.date() + timedelta(days=1), self.start)


@dataclass(frozen=True)
class ScheduleFit:
    """How the simulated robot work sits in the task's window."""

    task_id: str
    window_start: datetime
    window_finish: datetime
    available_s: float
    simulated_s: float
    simulated_finish: datetime
    fits: bool

    @property
    def utilisation(self) -> float:
        """Simulated work as a share of the window's working time."""
        return self.simulated_s / self.available_s if self.available_s > 0 else float("inf")


def fit_schedule(task_id: str, window_start: datetime, window_finish: datetime, simulated_s: float,
                 calendar: WorkCalendar) -> ScheduleFit:
    """Place ``simulated_s`` of robot work at the start of the task's window."""
    available = calendar.working_seconds(window_start, window_finish)
    finish = calendar.add_working_time(window_start, simulated_s)
    return ScheduleFit(task_id=task_id, window_start=window_start, window_finish=window_finish,
                       available_s=available, simulated_s=simulated_s, simulated_finish=finish,
                       fits=finish <= window_finish)


def results_graph(task: URIRef, run: URIRef, fit: ScheduleFit, *, scenario: str | None) -> Graph:
    """The simulated figures as RDF on the task, generated by the run (a prov:Activity)."""
    g = Graph()
    g.bind("kbp", KBP)
    g.bind("prov", PROV)
    g.add((run, RDF.type, PROV.Activity))
    g.add((run, PROV.used, task))
    if scenario:
        g.add((run, KBP.scenarioName, Literal(scenario)))
    g.add((task, KBP.simulatedDuration, Literal(round(fit.simulated_s, 3), datatype=XSD.double)))
    g.add((task, KBP.simulatedFinish, Literal(fit.simulated_finish, datatype=XSD.dateTime)))
    g.add((task, KBP.fitsWindow, Literal(fit.fits)))
    g.add((task, PROV.wasGeneratedBy, run))
    return g


def schedule_csv_with_results(csv_path: Path, fits: dict[str, ScheduleFit]) -> str:
    """The CSV schedule with ``simulated_duration_h`` and ``simulated_finish`` columns added."""
    rows = list(csv.reader(io.StringIO(csv_path.read_text(encoding="utf-8"))))
    if not rows:
        return ""
    header = rows[0]
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow([*header, "simulated_duration_h", "simulated_finish"])
    key = header.index("task_id") if "task_id" in header else 0
    for r in rows[1:]:
        f = fits.get(r[key]) if len(r) > key else None
        extra = [f"{f.simulated_s / 3600:.3f}", f.simulated_finish.isoformat()] if f else ["", ""]
        w.writerow([*r, *extra])
    return out.getvalue()


def _iso_duration(seconds: float) -> str:
    """ISO 8601 duration of working time, e.g. ``PT1H30M5S``."""
    s = round(seconds)
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return "PT" + (f"{h}H" if h else "") + (f"{m}M" if m else "") + (f"{sec}S" if sec or not (h or m) else "")


def ifc_with_results(ifc_path: Path, fits: dict[str, ScheduleFit], out_path: Path, *,
                     scenario: str | None = None) -> int:
    """A copy of an IFC file whose robotized tasks carry the simulated figures; returns tasks updated.

    For each task (matched by Identification, TaskId or GlobalId, as the schedule reader does), the
    planned values are kept in a property set ``Pset_KbplannerSimulation`` (PlannedFinish, with
    SimulatedDuration, SimulatedFinish, FitsWindow and Scenario), and in IFC4 and later the task time's
    ``ScheduleDuration`` and ``ScheduleFinish`` are set to the simulated ones so that a 4D tool plays
    the simulated task. The input file is never modified.
    """
    import ifcopenshell
    import ifcopenshell.api.pset

    f = ifcopenshell.open(str(ifc_path))
    updated = 0
    task: Any
    for task in f.by_type("IfcTask"):
        keys = {getattr(task, "Identification", None), getattr(task, "TaskId", None), task.GlobalId}
        fit = next((fits[k] for k in keys if k and k in fits), None)
        if fit is None:
            continue
        tt = getattr(task, "TaskTime", None)
        planned = str(getattr(tt, "ScheduleFinish", "") or "") if tt is not None else ""
        if tt is not None:
            tt.ScheduleDuration = _iso_duration(fit.simulated_s)
            tt.ScheduleFinish = fit.simulated_finish.isoformat()
        pset = ifcopenshell.api.pset.add_pset(f, product=task, name="Pset_KbplannerSimulation")
        ifcopenshell.api.pset.edit_pset(f, pset=pset, properties={
            "SimulatedDuration": _iso_duration(fit.simulated_s),
            "SimulatedFinish": fit.simulated_finish.isoformat(),
            "FitsWindow": fit.fits,
            "PlannedFinish": planned or fit.window_finish.isoformat(),
            "Scenario": scenario or "",
        })
        updated += 1
    from kbplanner.core.outputs import atomic_write_text

    atomic_write_text(out_path, f.to_string())
    return updated
