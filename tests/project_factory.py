"""Small test projects: an IFC building from ifc_factory plus project.toml, a CSV schedule and Turtle.

``make_project(dir)`` writes a complete project directory that every step can load quickly.
"""

from __future__ import annotations

from pathlib import Path

from ifc_factory import TestBuilding, write_test_building
from project_parts import layout_ttl, prefixes, project_toml, site_object_ttl, write_texts

BASE = "https://w3id.org/kbplanner/data/testproj/"
SITE_TTL = (prefixes(BASE)
            + layout_ttl((-10.0, -10.0, 20.0, 16.0), (-3.0, -3.0, 0.0), start_name="robot-start")
            + site_object_ttl("office", "SiteOffice", "Site office", (3.0, 2.4, 2.6), (-6.0, 10.0),
                              obstructs=None))

SCHEDULE_CSV = """task_id,name,start,finish,predecessors,elements,robotized,task_specification
T1,Slabs,2022-03-01,2022-03-10,,class=IfcSlab,false,
T2,Exterior walls,2022-03-11,2022-03-20,T1,class=IfcWall;external=true,false,
T3,Partitions,2022-05-10,2022-05-20,T2,class=IfcWall;external=false,false,
T4,Doors,2022-05-21,2022-05-25,T3,class=IfcDoor,false,
"""


def make_project(directory: Path, *, name: str = "testproj", schema: str = "IFC4",
                 unit_mm: bool = False) -> TestBuilding:
    """Write a project (IFC, project.toml, schedule.csv, site layout) into ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    building = write_test_building(directory / "model.ifc", schema=schema, unit_mm=unit_mm)  # type: ignore[arg-type]
    write_texts(directory, {"site.ttl": SITE_TTL, "schedule.csv": SCHEDULE_CSV,
                            "project.toml": project_toml(name, BASE)})
    return building
