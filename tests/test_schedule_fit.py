"""Simulated durations against the task window and the working calendar."""

from __future__ import annotations

from datetime import datetime, time
from pathlib import Path

import pytest
from rdflib import URIRef

from kbplanner.analysis.schedule_fit import (
    WorkCalendar,
    fit_schedule,
    results_graph,
    schedule_csv_with_results,
)
from kbplanner.core.errors import ProjectError
from kbplanner.core.vocab import KBP
from kbplanner.project import Calendar

CAL = WorkCalendar.from_calendar(Calendar("07:00", "15:30", ("Mon", "Tue", "Wed", "Thu", "Fri")))


def test_working_seconds_count_only_working_hours_of_working_days() -> None:
    # Tue 2022-05-10 00:00 to Mon 2022-05-23 23:59:59: 10 working days of 8.5 h.
    s = CAL.working_seconds(datetime(2022, 5, 10), datetime(2022, 5, 23, 23, 59, 59))
    assert s == pytest.approx(10 * 8.5 * 3600)


def test_work_that_overflows_a_day_continues_next_working_morning() -> None:
    end = CAL.add_working_time(datetime(2022, 5, 13, 15, 0), 3600.0)  # Friday 15:00 + 1 h
    assert end == datetime(2022, 5, 16, 7, 30)


def test_an_hour_of_robot_work_fits_the_paper_window() -> None:
    fit = fit_schedule("T", datetime(2022, 5, 10), datetime(2022, 5, 23, 23, 59, 59), 3600.0, CAL)
    assert fit.fits and fit.simulated_finish == datetime(2022, 5, 10, 8, 0)
    assert fit.utilisation == pytest.approx(1 / 85)
    late = fit_schedule("T", datetime(2022, 5, 10), datetime(2022, 5, 10, 23, 0), 10 * 3600.0, CAL)
    assert not late.fits


def test_bad_calendar_is_a_project_error() -> None:
    with pytest.raises(ProjectError, match="not HH:MM"):
        WorkCalendar.from_calendar(Calendar("7am", "15:30"))
    with pytest.raises(ProjectError, match="unknown weekday"):
        WorkCalendar.from_calendar(Calendar("07:00", "15:30", ("Monday",)))


def test_results_go_back_to_the_graph_and_the_csv(tmp_path: Path) -> None:
    fit = fit_schedule("T-FRAME", datetime(2022, 5, 10), datetime(2022, 5, 23, 23, 59, 59), 5400.0, CAL)
    g = results_graph(URIRef("urn:task"), URIRef("urn:run"), fit, scenario="s")
    assert float(g.value(URIRef("urn:task"), KBP.simulatedDuration)) == 5400.0
    csv_in = tmp_path / "s.csv"
    csv_in.write_text("task_id,name\nT-FRAME,Frame\nT-X,Other\n")
    text = schedule_csv_with_results(csv_in, {"T-FRAME": fit})
    lines = text.splitlines()
    assert lines[0] == "task_id,name,simulated_duration_h,simulated_finish"
    assert lines[1] == "T-FRAME,Frame,1.500,2022-05-10T08:30:00"
    assert lines[2] == "T-X,Other,,"
    assert time(7) == CAL.start


def test_an_ifc_schedule_gets_the_simulated_figures_in_a_copy(tmp_path: Path) -> None:
    import ifcopenshell
    import ifcopenshell.util.element

    from kbplanner.analysis.schedule_fit import ifc_with_results
    from test_schedule_ifc import write_schedule_model

    path, _, _ = write_schedule_model(tmp_path)
    before = path.read_bytes()
    # ifcopenshell renumbers child task identifications: T2 is stored as "S.2".
    fit = fit_schedule("S.2", datetime(2024, 3, 6), datetime(2024, 3, 8, 23, 59), 5400.0, CAL)
    out = tmp_path / "with_results.ifc"
    assert ifc_with_results(path, {"S.2": fit}, out, scenario="s") == 1
    assert path.read_bytes() == before  # the input is untouched
    f = ifcopenshell.open(str(out))
    (task,) = [t for t in f.by_type("IfcTask") if t.Identification == "S.2"]
    assert task.TaskTime.ScheduleDuration == "PT1H30M"
    assert task.TaskTime.ScheduleFinish.startswith("2024-03-06T08:30")
    props = ifcopenshell.util.element.get_psets(task)["Pset_KbplannerSimulation"]
    assert props["FitsWindow"] is True and props["Scenario"] == "s"
