"""Schedules against a model made by the real IFC import (ifc_factory building -> ifc_import -> schedule)."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.sequence as seq
import pytest
from rdflib import Graph, URIRef

from ifc_factory import TestBuilding, write_test_building
from kbplanner.core.iris import base_iri, element_iri
from kbplanner.core.vocab import KBP
from kbplanner.model.ifc_import import import_ifc_graph
from kbplanner.model.schedule import element_states, read_csv_schedule, read_ifc_schedule, schedule_to_graph

BASE = base_iri("schedule import test")
HEADER = "task_id,name,start,finish,predecessors,elements,robotized,task_specification"


@pytest.fixture(scope="module")
def imported(tmp_path_factory: pytest.TempPathFactory) -> tuple[TestBuilding, Graph]:
    b = write_test_building(tmp_path_factory.mktemp("ifc") / "building.ifc", schema="IFC4")
    return b, import_ifc_graph(b.path, base=BASE).graph


def walls(b: TestBuilding, storey: str, external: bool | None = None) -> set[URIRef]:
    level = next(g for g, (name, _) in b.storeys.items() if name == storey)
    return {element_iri(BASE, g) for g, w in b.walls.items()
            if w.storey == level and (external is None or w.is_external is external)}


def test_csv_selectors_pick_the_imported_walls_doors_by_storey_and_exterior(
    imported: tuple[TestBuilding, Graph], tmp_path: Path
) -> None:
    b, model = imported
    p = tmp_path / "plan.csv"
    p.write_text("\n".join([
        HEADER,
        "T1,Exterior walls L1,2024-03-04,2024-03-05,,class=IfcWall;storey=Level 1;external=true,,",
        "T2,Partitions L1,2024-03-06,2024-03-06,T1,class=IfcWall;storey=Level 1;external=false,yes,I-W-F-#1",
        "T3,Doors,2024-03-07,2024-03-07,T2,class=IfcDoor,,",
        "T4,Walls L2,2024-03-08,2024-03-09,T1,class=IfcWall;name=*L2*,,",
    ]) + "\n", encoding="utf-8")
    s = read_csv_schedule(p, model)
    assert set(s.task("T1").element_iris) == walls(b, "Level 1", external=True)
    assert set(s.task("T2").element_iris) == walls(b, "Level 1", external=False)
    assert set(s.task("T3").element_iris) == {element_iri(BASE, g) for g in b.doors}
    assert set(s.task("T4").element_iris) == walls(b, "Level 2")
    assert len(s.task("T1").element_iris) == 4 and len(s.task("T2").element_iris) == 1

    states = element_states(model + schedule_to_graph(s, BASE), datetime(2024, 3, 6, 12))
    assert {states[e] for e in walls(b, "Level 1", external=True)} == {KBP.Built}
    assert {states[e] for e in walls(b, "Level 1", external=False)} == {KBP.InProgress}
    assert {states[e] for e in walls(b, "Level 2")} == {KBP.NotStarted}
    assert {states[element_iri(BASE, g)] for g in b.slabs} == {KBP.Built}  # in no task: existing
    assert not any(element_iri(BASE, g) in states for g in [*b.spaces, *b.storeys])
    assert not any(element_iri(BASE, d.opening) in states for d in b.doors.values())


def test_ifc_schedule_elements_are_the_imported_element_iris(
    imported: tuple[TestBuilding, Graph], tmp_path: Path
) -> None:
    b, model = imported
    f = ifcopenshell.open(str(b.path))
    ws = seq.add_work_schedule(f, name="Construction")
    task = seq.add_task(f, work_schedule=ws, name="Partitions", identification="P1")
    tt = seq.add_task_time(f, task=task)
    tt.ScheduleStart, tt.ScheduleFinish = "2024-03-06T08:00:00", "2024-03-06T16:00:00"
    partitions = [f.by_guid(g) for g, w in sorted(b.walls.items()) if not w.is_external]
    for wall in partitions:
        seq.assign_product(f, relating_product=wall, related_object=task)
    path = tmp_path / "with_schedule.ifc"
    f.write(str(path))

    s = read_ifc_schedule(path, BASE)
    assert s is not None
    assert set(s.task("P1").element_iris) == {element_iri(BASE, w.GlobalId) for w in partitions}
    imported_elements = set(model.subjects(KBP.globalId, None))
    assert set(s.task("P1").element_iris) <= imported_elements
