"""A small project for the world tests (A6): the ifc_factory building plus panels to install.

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

import ifcopenshell
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.guid
import numpy as np

from ifc_factory import TestBuilding, write_test_building
from kbplanner.core.iris import element_iri

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
    import uuid

    return str(ifcopenshell.guid.compress(uuid.uuid5(uuid.NAMESPACE_URL, f"worldtest-panel-{n}").hex))


def _add_panels(ifc_path: Path) -> tuple[str, ...]:
    f = ifcopenshell.open(str(ifc_path))
    storey = next(s for s in f.by_type("IfcBuildingStorey") if s.Name == "Level 1")
    body = next(c for c in f.by_type("IfcGeometricRepresentationSubContext") if c.ContextIdentifier == "Body")
    wood = ifcopenshell.api.material.add_material(f, name="Wood - Stud")
    guids = []
    for n, x in enumerate(PANEL_XS, start=1):
        panel = ifcopenshell.api.root.create_entity(f, ifc_class="IfcMember", name=f"Panel P{n}")
        panel.GlobalId = _panel_guid(n)
        ifcopenshell.api.spatial.assign_container(f, products=[panel], relating_structure=storey)
        m = np.eye(4)
        m[:3, 3] = [x, 3.0, 0.0]
        ifcopenshell.api.geometry.edit_object_placement(f, product=panel, matrix=m)
        length, thickness, height = PANEL_SIZE
        rep = ifcopenshell.api.geometry.add_wall_representation(
            f, context=body, length=length, height=height, thickness=thickness)
        ifcopenshell.api.geometry.assign_representation(f, product=panel, representation=rep)
        ifcopenshell.api.material.assign_material(f, products=[panel], material=wood)
        guids.append(panel.GlobalId)
    f.write(str(ifc_path))
    return tuple(guids)


def _pose(name: str, x: float, y: float, z: float, yaw: float = 0.0) -> str:
    return (f"site:{name} a kbp:Pose ; kbp:x {x!r} ; kbp:y {y!r} ; kbp:z {z!r} ;\n"
            f"    kbp:roll 0.0 ; kbp:pitch 0.0 ; kbp:yaw {yaw!r} .\n")


def _site_ttl() -> str:
    x0, y0, x1, y1 = EXTENT
    ox, oy, osx, osy, osz = OFFICE
    return (
        "@prefix kbp: <https://w3id.org/kbplanner/ontology#> .\n"
        "@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .\n"
        f"@prefix site: <{BASE}site/> .\n\n"
        "site:layout a kbp:SiteLayout ; kbp:siteExtent site:extent ; kbp:robotStart site:start .\n"
        f"site:extent a kbp:Box ; kbp:minX {x0!r} ; kbp:minY {y0!r} ; kbp:minZ -1.0 ;\n"
        f"    kbp:maxX {x1!r} ; kbp:maxY {y1!r} ; kbp:maxZ 10.0 .\n"
        + _pose("start", -3.0, -2.0, 0.0)
        + "site:office a kbp:SiteOffice ; rdfs:label \"Office\" ; kbp:obstructs true ;\n"
        f"    kbp:sizeX {osx!r} ; kbp:sizeY {osy!r} ; kbp:sizeZ {osz!r} ;\n"
        "    kbp:installedPose site:office-pose .\n"
        + _pose("office-pose", ox, oy, 0.0)
        + "site:no-go a kbp:NoGoZone ; rdfs:label \"No-go\" ; kbp:obstructs false ;\n"
        f"    kbp:sizeX {NO_GO[2]!r} ; kbp:sizeY {NO_GO[3]!r} ; kbp:sizeZ 3.0 ;\n"
        "    kbp:installedPose site:no-go-pose .\n"
        + _pose("no-go-pose", NO_GO[0], NO_GO[1], 0.0)
        + "site:work a kbp:Workspace ; rdfs:label \"Work area\" ; kbp:obstructs false ;\n"
        f"    kbp:sizeX {WORKSPACE[2]!r} ; kbp:sizeY {WORKSPACE[3]!r} ; kbp:sizeZ 2.0 ;\n"
        "    kbp:installedPose site:work-pose .\n"
        + _pose("work-pose", WORKSPACE[0], WORKSPACE[1], 0.0)
        + "site:worker a kbp:Worker ; rdfs:label \"Carpenter\" ; kbp:role \"carpenter\" ;\n"
        "    kbp:walkingSpeed 1.2 ; kbp:routeStop site:stop-1 , site:stop-2 .\n"
        "site:stop-1 a kbp:RouteStop ; kbp:order 1 ; kbp:location site:work ; kbp:dwellTime 30.0 .\n"
        "site:stop-2 a kbp:RouteStop ; kbp:order 2 ; kbp:location site:office ; kbp:dwellTime 10.0 .\n"
    )


def _storage_ttl(panels: tuple[str, ...], stack: dict[str, int]) -> str:
    x, y, z, yaw = STORAGE
    sx, sy, sz = STORAGE_SIZE
    text = (
        "@prefix kbp: <https://w3id.org/kbplanner/ontology#> .\n"
        "@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .\n"
        f"@prefix site: <{BASE}site/> .\n\n"
        "site:storage a kbp:MaterialStorage ; rdfs:label \"Panel storage\" ; kbp:obstructs true ;\n"
        f"    kbp:sizeX {sx!r} ; kbp:sizeY {sy!r} ; kbp:sizeZ {sz!r} ;\n"
        "    kbp:installedPose site:storage-pose ; kbp:pickupLocation site:pickup .\n"
        + _pose("storage-pose", x, y, z, yaw)
        + _pose("pickup", x - 1.4, y, 0.0)
    )
    for gid in panels:
        text += f"<{element_iri(BASE, gid)}> kbp:storedIn site:storage ; kbp:stackIndex {stack[gid]} .\n"
    return text


def make_world_project(directory: Path, *, storeys: int = 2, bays: int = 2) -> WorldProject:
    """Write the test project into ``directory`` (see module docstring; more storeys and bays for
    benchmarks: the site extent stays the same)."""
    directory.mkdir(parents=True, exist_ok=True)
    building = write_test_building(directory / "model.ifc", schema="IFC4", furniture_per_space=1,
                                   storeys=storeys, bays=bays)
    panels = _add_panels(directory / "model.ifc")
    stack = {gid: len(panels) - 1 - n for n, gid in enumerate(panels)}  # P1, installed first, on top
    (directory / "schedule.csv").write_text(SCHEDULE, encoding="utf-8")
    (directory / "site.ttl").write_text(_site_ttl(), encoding="utf-8")
    (directory / "storage.ttl").write_text(_storage_ttl(panels, stack), encoding="utf-8")
    (directory / "project.toml").write_text(
        "[project]\n"
        'name = "worldtest"\n'
        f'base_iri = "{BASE}"\n'
        "[model]\n"
        'ifc = "model.ifc"\n'
        'schedule = "schedule.csv"\n'
        'site = ["site.ttl"]\n'
        "[simulation]\n"
        'task = "T5"\n'
        f'date = "{DATE}"\n'
        "[scenarios.stored]\n"
        'description = "panels on a storage in the yard"\n'
        'overlays = ["storage.ttl"]\n',
        encoding="utf-8",
    )
    return WorldProject(directory, building, panels, stack)
