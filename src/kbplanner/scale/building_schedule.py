"""Test buildings (scale, issue 6), step 4: the schedule of the generated building (4D model).

``schedule.csv``: mobilisation, then per storey structure, facade, **framing (robotized,
I-W-F-#1)**, partitions (board and finish) and doors, and the roof, week by week from
:data:`kbplanner.scale.building_plan.START_DATE`; every building element is built by exactly one task,
through selectors.
"""

from __future__ import annotations

import csv
import io
from datetime import date, timedelta

from kbplanner.scale.building_plan import FRAMING_SPEC, START_DATE

# The columns of a schedule.csv that kbplanner writes (a generated building, `kbplanner init`).
SCHEDULE_COLUMNS = (
    "task_id",
    "name",
    "start",
    "finish",
    "predecessors",
    "elements",
    "robotized",
    "task_specification",
)


def week(w: int, day: int = 0) -> date:
    """Day ``day`` of week ``w`` of the schedule (week 0: mobilisation)."""
    return START_DATE + timedelta(days=7 * w + day)


def schedule_tasks(storeys: int) -> list[dict[str, str]]:
    """The schedule's tasks (one row per task, the columns of ``schedule.csv``), by start date."""
    rows: list[dict[str, str]] = []

    def add(
        task_id: str,
        name: str,
        start: date,
        finish: date,
        preds: list[str],
        elements: str,
        robotized: bool = False,
    ) -> None:
        rows.append(
            {
                "task_id": task_id,
                "name": name,
                "start": start.isoformat(),
                "finish": finish.isoformat(),
                "predecessors": " ".join(preds),
                "elements": elements,
                "robotized": "true" if robotized else "false",
                "task_specification": FRAMING_SPEC if robotized else "",
            }
        )

    add("T-MOB", "Site mobilisation", week(0), week(0, 4), [], "")
    for k in range(1, storeys + 1):
        lvl, st = f"L{k:02d}", f"Level {k}"
        structure = "|".join(
            f"class={c};storey={st};name={n}*"
            for c, n in (
                ("IfcSlab", "Floor slab"),
                ("IfcWall", "Party wall"),
                ("IfcWall", "Corridor wall"),
                ("IfcWall", "Lift shaft wall"),
                ("IfcStair", "Stair"),
            )
        )
        add(
            f"T-STR-{lvl}",
            f"Structure {st}: slabs, party, corridor and core walls, stair",
            week(k),
            week(k, 4),
            ["T-MOB" if k == 1 else f"T-STR-L{k - 1:02d}"],
            structure,
        )
        add(
            f"T-ENV-{lvl}",
            f"Facade {st}",
            week(k + 1),
            week(k + 1, 4),
            [f"T-STR-{lvl}"],
            f"class=IfcWall;storey={st};name=Exterior wall*",
        )
        add(
            f"T-FRAME-{lvl}",
            f"Frame interior wood partitions {st}",
            week(k + 2),
            week(k + 3, 4),
            [f"T-ENV-{lvl}"],
            f"class=IfcMember;storey={st};name=Stud frame panel*",
            robotized=True,
        )
        add(
            f"T-INT-{lvl}",
            f"Interior partitions {st} (board, tape and finish)",
            week(k + 4),
            week(k + 5, 4),
            [f"T-FRAME-{lvl}"],
            f"class=IfcWall;storey={st};name=Partition*",
        )
        add(
            f"T-DOOR-{lvl}",
            f"Doors {st}",
            week(k + 6),
            week(k + 6, 4),
            [f"T-INT-{lvl}"],
            f"class=IfcDoor;storey={st}",
        )
    add(
        "T-ROOF",
        "Roof slab",
        week(storeys + 1),
        week(storeys + 1, 4),
        [f"T-STR-L{storeys:02d}"],
        "class=IfcSlab;storey=Roof;name=Roof slab",
    )
    rows.sort(key=lambda r: (r["start"], r["task_id"]))
    return rows

def schedule_csv(storeys: int) -> str:
    """``schedule.csv`` of the generated building."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(SCHEDULE_COLUMNS), lineterminator="\n")
    w.writeheader()
    for r in schedule_tasks(storeys):
        w.writerow(r)
    return buf.getvalue()
