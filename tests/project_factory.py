"""Small test projects: an IFC building from ifc_factory plus project.toml, a CSV schedule and Turtle.

``make_project(dir)`` writes a complete project directory that every step can load quickly.
"""

from __future__ import annotations

from pathlib import Path

from ifc_factory import TestBuilding, write_test_building
from project_parts import project_toml

SITE_TTL = """@prefix kbp: <https://w3id.org/kbplanner/ontology#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix site: <https://w3id.org/kbplanner/data/testproj/site/> .

site:layout a kbp:SiteLayout ;
    kbp:siteExtent site:extent ;
    kbp:robotStart site:robot-start .
site:extent a kbp:Box ; kbp:minX -10.0 ; kbp:minY -10.0 ; kbp:minZ -1.0 ;
    kbp:maxX 20.0 ; kbp:maxY 16.0 ; kbp:maxZ 10.0 .
site:robot-start a kbp:Pose ; kbp:x -3.0 ; kbp:y -3.0 ; kbp:z 0.0 ;
    kbp:roll 0.0 ; kbp:pitch 0.0 ; kbp:yaw 0.0 .
site:office a kbp:SiteOffice ; rdfs:label "Site office" ;
    kbp:installedPose site:office-pose ; kbp:sizeX 3.0 ; kbp:sizeY 2.4 ; kbp:sizeZ 2.6 .
site:office-pose a kbp:Pose ; kbp:x -6.0 ; kbp:y 10.0 ; kbp:z 0.0 ;
    kbp:roll 0.0 ; kbp:pitch 0.0 ; kbp:yaw 0.0 .
"""

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
    (directory / "site.ttl").write_text(SITE_TTL)
    (directory / "schedule.csv").write_text(SCHEDULE_CSV)
    (directory / "project.toml").write_text(project_toml(name, "https://w3id.org/kbplanner/data/testproj/"))
    return building
