"""The IFC work schedule reader, on IFC files written with ifcopenshell.api in the test."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path
from typing import Any

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.sequence
import ifcopenshell.api.spatial
import ifcopenshell.api.unit
import ifcopenshell.guid
import pytest
from rdflib import XSD, Literal

from kbplanner.core.errors import IfcError, ScheduleCycleError, ScheduleError
from kbplanner.core.iris import element_iri, task_iri
from kbplanner.core.vocab import KBP
from kbplanner.model.schedule import read_ifc_schedule, schedule_iri, schedule_to_graph

BASE = "https://w3id.org/kbplanner/data/test/"
seq = ifcopenshell.api.sequence


def stored(value: str) -> datetime:
    """A stored IfcDateTime read back the way ifcopenshell keeps it (ISO text)."""
    return datetime.fromisoformat(value)


def new_model() -> tuple[Any, list[Any]]:
    """An IFC4 project with one storey and four walls."""
    f = ifcopenshell.file(schema="IFC4")
    project = ifcopenshell.api.root.create_entity(f, ifc_class="IfcProject", name="Test")
    ifcopenshell.api.unit.assign_unit(f)
    site = ifcopenshell.api.root.create_entity(f, ifc_class="IfcSite", name="Site")
    building = ifcopenshell.api.root.create_entity(f, ifc_class="IfcBuilding", name="Building")
    storey = ifcopenshell.api.root.create_entity(f, ifc_class="IfcBuildingStorey", name="Level 1")
    ifcopenshell.api.aggregate.assign_object(f, products=[site], relating_object=project)
    ifcopenshell.api.aggregate.assign_object(f, products=[building], relating_object=site)
    ifcopenshell.api.aggregate.assign_object(f, products=[storey], relating_object=building)
    walls = [ifcopenshell.api.root.create_entity(f, ifc_class="IfcWall", name=f"Frame {i}") for i in range(4)]
    ifcopenshell.api.spatial.assign_container(f, products=walls, relating_structure=storey)
    return f, walls


def set_pset(f: Any, task: Any, props: dict[str, Any]) -> None:
    pset = ifcopenshell.api.pset.add_pset(f, product=task, name="Pset_KbplannerTask")
    ifcopenshell.api.pset.edit_pset(f, pset=pset, properties=props)


def write_schedule_model(tmp_path: Path) -> tuple[Path, dict[str, Any], list[Any]]:
    """Summary task S with T1 (walls 0, 1) and T2 (wall 2, robotized, after T1); T3 with raw times."""
    f, walls = new_model()
    ws = seq.add_work_schedule(f, name="Construction")
    summary = seq.add_task(f, work_schedule=ws, name="Frames", identification="S")
    t1 = seq.add_task(f, parent_task=summary, name="Exterior frames", identification="T1")
    t2 = seq.add_task(f, parent_task=summary, name="Interior frames", identification="T2")
    t3 = seq.add_task(f, work_schedule=ws, name="Finishes", identification="T3")
    tt1 = seq.add_task_time(f, task=t1)
    seq.edit_task_time(f, task_time=tt1,
                       attributes={"ScheduleStart": "2024-03-04", "ScheduleFinish": "2024-03-05"})
    tt2 = seq.add_task_time(f, task=t2)
    seq.edit_task_time(f, task_time=tt2,
                       attributes={"ScheduleStart": "2024-03-06", "ScheduleFinish": "2024-03-08"})
    seq.assign_sequence(f, relating_process=t1, related_process=t2)
    tt3 = seq.add_task_time(f, task=t3)
    seq.assign_sequence(f, relating_process=t2, related_process=t3)
    # Written directly after the sequences (assign_sequence re-shifts dates, edit_task_time snaps them):
    # one exact date-time and one date-only finish.
    tt3.ScheduleStart = "2024-03-11T07:30:00"
    tt3.ScheduleFinish = "2024-03-12"
    seq.assign_product(f, relating_product=walls[0], related_object=t1)
    seq.assign_product(f, relating_product=walls[1], related_object=t1)
    seq.assign_product(f, relating_product=walls[2], related_object=t2)
    set_pset(f, t2, {"Robotized": True, "TaskSpecificationId": "I-W-F-#1"})
    set_pset(f, t3, {"Robotized": False})
    path = tmp_path / "model.ifc"
    f.write(str(path))
    return path, {"S": summary, "T1": t1, "T2": t2, "T3": t3, "ws": ws}, walls


def test_ifc_work_schedule_round_trips_tasks_times_sequences_products_and_pset(tmp_path: Path) -> None:
    path, ents, walls = write_schedule_model(tmp_path)
    back = ifcopenshell.open(str(path))  # what ifcopenshell stored, after its snapping and renumbering
    t1, t2, t3, summary = (back.by_guid(ents[k].GlobalId) for k in ("T1", "T2", "T3", "S"))

    s = read_ifc_schedule(path, BASE)
    assert s is not None
    assert s.schedule_id == ents["ws"].GlobalId and s.name == "Construction"
    # Task ids are the Identifications as stored (nested ones are renumbered by the api, e.g. S.1).
    r1, r2, r3, rs = (s.task(t.Identification) for t in (t1, t2, t3, summary))

    assert (r1.start, r1.finish) == (stored(t1.TaskTime.ScheduleStart), stored(t1.TaskTime.ScheduleFinish))
    assert (r2.start, r2.finish) == (stored(t2.TaskTime.ScheduleStart), stored(t2.TaskTime.ScheduleFinish))
    assert r3.start == datetime(2024, 3, 11, 7, 30)
    assert r3.finish == datetime(2024, 3, 12, 23, 59, 59)  # date-only finish = end of that day
    assert rs.start == r1.start and rs.finish == r2.finish  # summary spans its nested tasks
    assert r2.predecessors == (r1.task_id,) and r3.predecessors == (r2.task_id,) and r1.predecessors == ()
    assert set(r1.element_iris) == {element_iri(BASE, w.GlobalId) for w in walls[:2]}
    assert r2.element_iris == (element_iri(BASE, walls[2].GlobalId),)
    assert rs.element_iris == () and r3.element_iris == ()
    assert (r2.robotized, r2.task_specification_id) == (True, "I-W-F-#1")
    assert (r1.robotized, r3.robotized) == (False, False)
    assert [t.task_id for t in s.tasks] == [summary.Identification, t1.Identification, t2.Identification,
                                            t3.Identification]  # depth first from the roots


def test_ifc_schedule_becomes_the_same_rdf_as_any_schedule(tmp_path: Path) -> None:
    path, ents, walls = write_schedule_model(tmp_path)
    s = read_ifc_schedule(path, BASE)
    assert s is not None
    g = schedule_to_graph(s, BASE)
    robot = next(t for t in s.tasks if t.robotized)
    t = task_iri(BASE, robot.task_id)
    assert (schedule_iri(BASE, ents["ws"].GlobalId), KBP.hasTask, t) in g
    assert (t, KBP.buildsElement, element_iri(BASE, walls[2].GlobalId)) in g
    assert g.value(t, KBP.robotized) == Literal(True, datatype=XSD.boolean)
    assert g.value(t, KBP.start) == Literal(robot.start, datatype=XSD.dateTime)
    assert g.value(t, KBP.predecessor) == task_iri(BASE, robot.predecessors[0])


def test_a_file_without_work_schedule_gives_none(tmp_path: Path) -> None:
    f, _ = new_model()
    path = tmp_path / "plain.ifc"
    f.write(str(path))
    assert read_ifc_schedule(path, BASE) is None


def test_several_work_schedules_need_a_name_and_the_name_picks_one(tmp_path: Path) -> None:
    f, _ = new_model()
    for name in ("Planned", "Actual"):
        ws = seq.add_work_schedule(f, name=name)
        task = seq.add_task(f, work_schedule=ws, name=f"{name} task", identification=name[0])
        tt = seq.add_task_time(f, task=task)
        tt.ScheduleStart, tt.ScheduleFinish = "2024-03-04T08:00:00", "2024-03-04T12:00:00"
    path = tmp_path / "two.ifc"
    f.write(str(path))
    with pytest.raises(ScheduleError, match=r"two.ifc: the file has 2 work schedules.*\n  fix: name the one"):
        read_ifc_schedule(path, BASE)
    s = read_ifc_schedule(path, BASE, schedule_name="Actual")
    assert s is not None and [t.task_id for t in s.tasks] == ["A"]
    with pytest.raises(ScheduleError, match="no IfcWorkSchedule named 'Baseline'"):
        read_ifc_schedule(path, BASE, schedule_name="Baseline")


def test_duplicate_identifications_fall_back_to_global_ids(tmp_path: Path) -> None:
    f, _ = new_model()
    ws = seq.add_work_schedule(f, name="S")
    tasks = [seq.add_task(f, work_schedule=ws, name=f"t{i}", identification="X") for i in range(2)]
    for t in tasks:
        tt = seq.add_task_time(f, task=t)
        tt.ScheduleStart, tt.ScheduleFinish = "2024-03-04T08:00:00", "2024-03-04T12:00:00"
    path = tmp_path / "dup.ifc"
    f.write(str(path))
    s = read_ifc_schedule(path, BASE)
    assert s is not None and sorted(t.task_id for t in s.tasks) == sorted(t.GlobalId for t in tasks)


def test_robotized_ifc_task_without_specification_is_an_error_naming_the_task(tmp_path: Path) -> None:
    f, _ = new_model()
    ws = seq.add_work_schedule(f, name="S")
    t = seq.add_task(f, work_schedule=ws, name="Frames", identification="T1")
    tt = seq.add_task_time(f, task=t)
    tt.ScheduleStart, tt.ScheduleFinish = "2024-03-04T08:00:00", "2024-03-04T12:00:00"
    set_pset(f, t, {"Robotized": True})
    path = tmp_path / "nospec.ifc"
    f.write(str(path))
    with pytest.raises(ScheduleError) as info:
        read_ifc_schedule(path, BASE)
    msg = str(info.value)
    assert "nospec.ifc" in msg and "'Frames'" in msg and t.GlobalId in msg
    assert "Pset_KbplannerTask.TaskSpecificationId" in msg and "fix:" in msg


def test_ifc_task_without_times_is_an_error_with_a_fix(tmp_path: Path) -> None:
    f, _ = new_model()
    ws = seq.add_work_schedule(f, name="S")
    seq.add_task(f, work_schedule=ws, name="Untimed", identification="T1")
    path = tmp_path / "untimed.ifc"
    f.write(str(path))
    with pytest.raises(ScheduleError, match=r"untimed\.ifc: .*'Untimed'.*no scheduled start.*\n  fix: give"):
        read_ifc_schedule(path, BASE)


def test_ifc_sequence_cycle_raises_cycle_error_with_the_cycle(tmp_path: Path) -> None:
    f, _ = new_model()
    ws = seq.add_work_schedule(f, name="S")
    tasks = []
    for ident in ("A", "B", "C"):
        t = seq.add_task(f, work_schedule=ws, name=ident, identification=ident)
        tt = seq.add_task_time(f, task=t)
        tt.ScheduleStart, tt.ScheduleFinish = "2024-03-04T08:00:00", "2024-03-04T12:00:00"
        tasks.append(t)
    for a, b in ((0, 1), (1, 2), (2, 0)):  # written directly: the api would reschedule
        f.create_entity("IfcRelSequence", GlobalId=ifcopenshell.guid.new(), RelatingProcess=tasks[a],
                        RelatedProcess=tasks[b], SequenceType="FINISH_START")
    path = tmp_path / "cycle.ifc"
    f.write(str(path))
    with pytest.raises(ScheduleCycleError) as info:
        read_ifc_schedule(path, BASE)
    assert info.value.cycle == ["A", "B", "C"]
    assert "cycle.ifc" in str(info.value)


def test_ifc2x3_schedule_time_controls_and_date_entities_are_read(tmp_path: Path) -> None:
    f = ifcopenshell.file(schema="IFC2X3")
    new = ifcopenshell.guid.new

    def when(y: int, m: int, d: int, h: int | None = None, mi: int = 0) -> Any:
        day = f.create_entity("IfcCalendarDate", d, m, y)
        return day if h is None else f.create_entity(
            "IfcDateAndTime", day, f.create_entity("IfcLocalTime", h, mi, 0.0))

    wall = f.create_entity("IfcWall", GlobalId=new(), Name="Frame")
    ws = f.create_entity("IfcWorkSchedule", GlobalId=new(), Name="S", Identifier="S1",
                         CreationDate=when(2024, 1, 1, 0), StartTime=when(2024, 3, 4, 0))
    a = f.create_entity("IfcTask", GlobalId=new(), Name="A", TaskId="A1", IsMilestone=False)
    b = f.create_entity("IfcTask", GlobalId=new(), Name="B", TaskId="B1", IsMilestone=False)
    for task, start, finish in ((a, when(2024, 3, 4, 8), when(2024, 3, 5, 16, 30)),
                                (b, when(2024, 3, 6), when(2024, 3, 7))):
        control = f.create_entity("IfcScheduleTimeControl", GlobalId=new(), ScheduleStart=start,
                                  ScheduleFinish=finish)
        f.create_entity("IfcRelAssignsTasks", GlobalId=new(), RelatedObjects=[task], RelatingControl=ws,
                        TimeForTask=control)
    f.create_entity("IfcRelSequence", GlobalId=new(), RelatingProcess=a, RelatedProcess=b, TimeLag=0.0,
                    SequenceType="FINISH_START")
    f.create_entity("IfcRelAssignsToProduct", GlobalId=new(), RelatedObjects=[a], RelatingProduct=wall)
    path = tmp_path / "old.ifc"
    f.write(str(path))
    s = read_ifc_schedule(path, BASE)
    assert s is not None
    ra, rb = s.task("A1"), s.task("B1")
    assert (ra.start, ra.finish) == (datetime(2024, 3, 4, 8), datetime(2024, 3, 5, 16, 30))
    assert (rb.start, rb.finish) == (datetime(2024, 3, 6), datetime(2024, 3, 7, 23, 59, 59))
    assert rb.predecessors == ("A1",) and ra.element_iris == (element_iri(BASE, wall.GlobalId),)


def test_unreadable_ifc_file_raises_ifc_error(tmp_path: Path) -> None:
    path = tmp_path / "broken.ifc"
    path.write_text("this is not STEP\n", encoding="utf-8")
    with pytest.raises(IfcError, match=r"broken.ifc: cannot open the IFC file.*\n  fix: export"):
        read_ifc_schedule(path, BASE)
