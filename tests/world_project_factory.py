"""A small project for the world tests (A6): the ifc_factory building plus panels to install.

Shared parts come from tests/project_parts.py.

``make_world_project(dir)`` writes: the two-storey, two-bay test building with one table per space,
three IfcMember panels (0.6 x 0.09 x 2.4 m, wood) standing in bay 1 of Level 1, a CSV schedule, a
site layout (extent, robot start, an office, a no-go zone, a workspace, a worker) and a scenario
"stored" that adds a material storage with the panels stacked on it. No tests live here.

Schedule (the world date is 2022-05-10T08:00):

- T1 slabs, T2 exterior walls, T3 Level-1 partitions, T4 doors: built;
- T7 tables: 2022-05-01 .. 2022-05-20, in progress (present);
- T5 panels: robotized, 2022-05-10 .. 2022-05-12 (the task; its elements wait at the storage);
- T6 Level-2 partitions: 2022-06-01 .. 2022-06-05, not started (absent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ifc_factory import TestBuilding, write_test_building
from kbplanner.core.iris import element_iri
from project_parts import (
    PanelSpec,
    add_panels,
    guid,
    layout_ttl,
    prefixes,
    project_toml,
    site_object_ttl,
    stacked_ttl,
    storage_head_ttl,
    worker_ttl,
    write_texts,
)

BASE = "https://w3id.org/kbplanner/data/worldtest/"
PANEL_SIZE = (0.6, 0.09, 2.4)  # along the wall, across it (thickness), height
PANEL_XS = (1.0, 1.8, 2.6)  # x of each panel's start, y = 3.0, Level 1, bay 1
STORAGE = (11.0, 3.0, 0.0, math.pi / 2)  # x, y, z, yaw
STORAGE_SIZE = (2.8, 1.2, 0.1)
NO_GO = (-3.0, 8.0, 2.0, 2.0)  # centre x, y, size x, y
WORKSPACE = (12.0, 8.0, 2.0, 2.0)
OFFICE = (-6.0, 3.0, 3.0, 2.4, 2.6)  # centre x, y, size x, y, z
EXTENT = (-8.0, -4.0, 15.0, 11.0)
DATE = "2022-05-10T08:00:00"

SCHEDULE = """task_id,name,start,finish,predecessors,elements,robotized,task_specification
T1,Slabs,2022-03-01,2022-03-05,,class=IfcSlab,false,
T2,Exterior walls,2022-03-06,2022-03-15,T1,class=IfcWall;external=true,false,
T3,Partitions Level 1,2022-03-16,2022-03-20,T2,class=IfcWall;external=false;storey=Level 1,false,
T4,Doors,2022-03-21,2022-03-22,T3,class=IfcDoor,false,
T7,Tables,2022-05-01,2022-05-20,T4,class=IfcFurniture,false,
T5,Panels,2022-05-10,2022-05-12,T4,class=IfcMember,true,I-W-F-#1
T6,Partitions Level 2,2022-06-01,2022-06-05,T5,class=IfcWall;external=false;storey=Level 2,false,
"""


@dataclass(frozen=True)
class WorldProject:
    """Paths and facts of a written test project."""

    directory: Path
    building: TestBuilding
    panels: tuple[str, ...]  # GlobalIds, install order
    stack: dict[str, int]  # GlobalId -> stack index

    def iri(self, global_id: str) -> str:
        return str(element_iri(BASE, global_id))


def _panel_guid(n: int) -> str:
    return guid(f"worldtest-panel-{n}")


def _add_panels(ifc_path: Path) -> tuple[str, ...]:
    specs = [PanelSpec(f"P{n}", _panel_guid(n), x, 3.0) for n, x in enumerate(PANEL_XS, start=1)]
    add_panels(ifc_path, specs, size=PANEL_SIZE, shape="wall")
    return tuple(s.global_id for s in specs)


def _site_ttl() -> str:
    ox, oy, osx, osy, osz = OFFICE
    return (
        prefixes(BASE) + layout_ttl(EXTENT, (-3.0, -2.0, 0.0))
        + site_object_ttl("office", "SiteOffice", "Office", (osx, osy, osz), (ox, oy), obstructs=True)
        + site_object_ttl("no-go", "NoGoZone", "No-go", (NO_GO[2], NO_GO[3], 3.0), NO_GO[:2], obstructs=False)
        + site_object_ttl("work", "Workspace", "Work area", (WORKSPACE[2], WORKSPACE[3], 2.0), WORKSPACE[:2],
                          obstructs=False)
        + worker_ttl(1.2, [("work", 30.0), ("office", 10.0)])
    )


def _storage_ttl(panels: tuple[str, ...], stack: dict[str, int]) -> str:
    x, y, _, _ = STORAGE
    text = prefixes(BASE) + storage_head_ttl(STORAGE, STORAGE_SIZE, (x - 1.4, y, 0.0, 0.0))
    for gid in panels:
        text += stacked_ttl(BASE, gid, stack[gid])
    return text


def make_world_project(directory: Path, *, storeys: int = 2, bays: int = 2) -> WorldProject:
    """Write the test project into ``directory`` (see module docstring; more storeys and bays for
    benchmarks: the site extent stays the same)."""
    directory.mkdir(parents=True, exist_ok=True)
    building = write_test_building(directory / "model.ifc", schema="IFC4", furniture_per_space=1,
                                   storeys=storeys, bays=bays)
    panels = _add_panels(directory / "model.ifc")
    stack = {gid: len(panels) - 1 - n for n, gid in enumerate(panels)}  # P1, installed first, on top
    write_texts(directory, {
        "schedule.csv": SCHEDULE, "site.ttl": _site_ttl(), "storage.ttl": _storage_ttl(panels, stack),
        "project.toml": project_toml(
            "worldtest", BASE, simulation={"task": "T5", "date": DATE},
            scenarios={"stored": ("panels on a storage in the yard", ["storage.ttl"])})})
    return WorldProject(directory, building, panels, stack)
