"""A small project for the executor tests (B4, B5): one room with a 0.9 m front door, panels to install.

``make_sim_project(dir)`` writes (site frame, metres):

- ``model.ifc``: the ifc_factory building with one storey and one bay (x 0..5, y 0..6, 0.3 m exterior
  walls) and its front door, 0.9 m wide, centred at x = 2.5 in the south wall (y 0..0.3); plus
  IfcMember panels 0.6 x 0.09 x 2.4 m (box centred on the panel's axis, origin at its foot, like the
  case study's frames), 9 kg each (Qto NetWeight): P1 and P2 standing 0.9 m in front of the north
  wall, and (``high_panel``) P3 mounted 1.8 m above the floor, out of any arm's reach.
- ``schedule.csv``: slabs, walls, doors built; T5 "Panels" robotized (I-W-F-#1) on the world date.
- ``site.ttl``: site extent, robot start (6.5, -5.0), one worker walking between two benches in
  front of the building (across the robot's way from the storage to the door).
- Scenarios: ``stored`` (a 2.6 x 0.8 m storage 3.5 m south of the door, its pickup location 1 m
  from the stack, panels stacked P1 on top, kbp:workSequence P1, P2, P3, grasp points at the panel
  centres) and ``walled`` (the same, plus a closed fence ring around the storage and its pickup).

The normal carry of a panel (2.4 m across the robot) does not pass the 0.9 m door; the narrow one
(on its side, 0.09 m across) does. No tests live here.
"""

from __future__ import annotations

import math
import uuid
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.guid
import numpy as np

from ifc_factory import write_test_building
from kbplanner.core.iris import element_iri
from kbplanner.model.dates import parse_date
from kbplanner.planning.manipulation import refine_plan
from kbplanner.planning.plan_model import Plan
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project
from kbplanner.world.build import build_world
from kbplanner.world.exports import storey_map
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import World

BASE = "https://w3id.org/kbplanner/data/simtest/"
PANEL_SIZE = (0.6, 0.09, 2.4)  # along the wall, thickness, height
PANEL_MASS_KG = 9.0
# name, x, y, z (foot), yaw of the panel's local x axis
PANELS = (("P1", 1.7, 5.0, 0.0, math.pi), ("P2", 2.4, 5.0, 0.0, math.pi), ("P3", 3.6, 5.0, 1.8, math.pi))
DOOR_CENTER = (2.5, 0.15)
DOOR_WIDTH_M = 0.9
STORAGE = (2.5, -3.5, 0.0, 0.0)  # x, y, z, yaw: long side along x
STORAGE_SIZE = (2.6, 0.8, 0.1)
PICKUP = (2.5, -2.5, 0.0, -math.pi / 2)
ROBOT_START = (6.5, -5.0, math.pi / 2)
EXTENT = (-3.0, -7.0, 9.0, 8.0)
BENCHES = (("west-bench", -1.5, -1.4), ("east-bench", 7.5, -1.4))
DATE = "2022-05-10T08:00:00"

SCHEDULE = """task_id,name,start,finish,predecessors,elements,robotized,task_specification
T1,Slabs,2022-03-01,2022-03-05,,class=IfcSlab,false,
T2,Walls,2022-03-06,2022-03-15,T1,class=IfcWall,false,
T3,Doors,2022-03-16,2022-03-18,T2,class=IfcDoor,false,
T5,Panels,2022-05-10,2022-05-12,T3,class=IfcMember,true,I-W-F-#1
"""


@dataclass(frozen=True)
class SimProject:
    """Paths and facts of a written test project."""

    directory: Path
    panels: dict[str, str]  # name -> GlobalId

    def iri(self, name: str) -> str:
        """The element IRI of a panel by name (P1, P2, P3)."""
        return str(element_iri(BASE, self.panels[name]))


def _guid(name: str) -> str:
    return str(ifcopenshell.guid.compress(uuid.uuid5(uuid.NAMESPACE_URL, f"simtest-{name}").hex))


def _add_panels(ifc_path: Path, names: tuple[str, ...]) -> dict[str, str]:
    f = ifcopenshell.open(str(ifc_path))
    storey = next(s for s in f.by_type("IfcBuildingStorey") if s.Name == "Level 1")
    body = next(c for c in f.by_type("IfcGeometricRepresentationSubContext") if c.ContextIdentifier == "Body")
    wood = ifcopenshell.api.material.add_material(f, name="Wood - Stud")
    length, thickness, height = PANEL_SIZE
    out = {}
    for name, x, y, z, yaw in PANELS:
        if name not in names:
            continue
        panel = ifcopenshell.api.root.create_entity(f, ifc_class="IfcMember", name=f"Panel {name}")
        panel.GlobalId = _guid(name)
        ifcopenshell.api.spatial.assign_container(f, products=[panel], relating_structure=storey)
        m = np.eye(4)
        c, s = math.cos(yaw), math.sin(yaw)
        m[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
        m[:3, 3] = [x, y, z]
        ifcopenshell.api.geometry.edit_object_placement(f, product=panel, matrix=m)
        hl, ht = length / 2, thickness / 2
        rep = ifcopenshell.api.geometry.add_slab_representation(
            f, context=body, depth=height, polyline=[(-hl, -ht), (hl, -ht), (hl, ht), (-hl, ht)])
        ifcopenshell.api.geometry.assign_representation(f, product=panel, representation=rep)
        ifcopenshell.api.material.assign_material(f, products=[panel], material=wood)
        qty = f.create_entity("IfcQuantityWeight", Name="NetWeight", WeightValue=PANEL_MASS_KG)
        f.create_entity("IfcRelDefinesByProperties", GlobalId=_guid(f"qto-rel-{name}"),
                        RelatedObjects=[panel], RelatingPropertyDefinition=f.create_entity(
                            "IfcElementQuantity", GlobalId=_guid(f"qto-{name}"), Name="BaseQuantities",
                            Quantities=[qty]))
        out[name] = panel.GlobalId
    f.write(str(ifc_path))
    return out


def _pose(name: str, x: float, y: float, z: float, yaw: float = 0.0) -> str:
    return (f"site:{name} a kbp:Pose ; kbp:x {x!r} ; kbp:y {y!r} ; kbp:z {z!r} ;\n"
            f"    kbp:roll 0.0 ; kbp:pitch 0.0 ; kbp:yaw {yaw!r} .\n")


_PREFIXES = ("@prefix kbp: <https://w3id.org/kbplanner/ontology#> .\n"
             "@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .\n"
             f"@prefix site: <{BASE}site/> .\n\n")


def _site_ttl() -> str:
    x0, y0, x1, y1 = EXTENT
    sx, sy, syaw = ROBOT_START
    text = (_PREFIXES
            + "site:layout a kbp:SiteLayout ; kbp:siteExtent site:extent ; kbp:robotStart site:start .\n"
            + f"site:extent a kbp:Box ; kbp:minX {x0!r} ; kbp:minY {y0!r} ; kbp:minZ -1.0 ;\n"
            + f"    kbp:maxX {x1!r} ; kbp:maxY {y1!r} ; kbp:maxZ 10.0 .\n"
            + _pose("start", sx, sy, 0.0, syaw))
    for name, bx, by in BENCHES:
        text += (f"site:{name} a kbp:Workspace ; rdfs:label \"{name}\" ; kbp:obstructs false ;\n"
                 "    kbp:sizeX 1.0 ; kbp:sizeY 1.0 ; kbp:sizeZ 1.0 ;\n"
                 f"    kbp:installedPose site:{name}-pose .\n" + _pose(f"{name}-pose", bx, by, 0.0))
    text += ("site:worker a kbp:Worker ; rdfs:label \"Carpenter\" ; kbp:role \"carpenter\" ;\n"
             "    kbp:walkingSpeed 1.0 ; kbp:routeStop site:stop-1 , site:stop-2 .\n"
             "site:stop-1 a kbp:RouteStop ; kbp:order 1 ; kbp:location site:west-bench ;\n"
             "    kbp:dwellTime 20.0 .\n"
             "site:stop-2 a kbp:RouteStop ; kbp:order 2 ; kbp:location site:east-bench ;\n"
             "    kbp:dwellTime 20.0 .\n")
    return text


def _storage_ttl(panels: dict[str, str], walled: bool) -> str:
    x, y, z, yaw = STORAGE
    sx, sy, sz = STORAGE_SIZE
    px, py, pz, pyaw = PICKUP
    text = (_PREFIXES
            + "site:storage a kbp:MaterialStorage ; rdfs:label \"Panel storage\" ; kbp:obstructs true ;\n"
            + f"    kbp:sizeX {sx!r} ; kbp:sizeY {sy!r} ; kbp:sizeZ {sz!r} ;\n"
            + "    kbp:installedPose site:storage-pose ; kbp:pickupLocation site:pickup .\n"
            + _pose("storage-pose", x, y, z, yaw) + _pose("pickup", px, py, pz, pyaw))
    order = sorted(panels)  # P1 first: top of the stack
    for n, name in enumerate(order):
        iri = element_iri(BASE, panels[name])
        text += (f"<{iri}> kbp:storedIn site:storage ; kbp:stackIndex {len(order) - 1 - n} ;\n"
                 f"    kbp:workSequence {n + 1} ; kbp:graspPoint site:grasp-{name} .\n"
                 + _pose(f"grasp-{name}", 0.0, 0.0, PANEL_SIZE[2] / 2))
    if walled:  # a closed ring of fences 0.1 m thick around storage and pickup location
        cx, cy, w, h = 2.5, -3.0, 4.6, 3.6
        for name, fx, fy, fsx, fsy in (("s", cx, cy - h / 2, w, 0.1), ("n", cx, cy + h / 2, w, 0.1),
                                       ("w", cx - w / 2, cy, 0.1, h), ("e", cx + w / 2, cy, 0.1, h)):
            text += (f"site:fence-{name} a kbp:SafetyFence ; rdfs:label \"Fence {name}\" ;\n"
                     f"    kbp:obstructs true ; kbp:sizeX {fsx!r} ; kbp:sizeY {fsy!r} ; kbp:sizeZ 1.8 ;\n"
                     f"    kbp:installedPose site:fence-{name}-pose .\n"
                     + _pose(f"fence-{name}-pose", fx, fy, 0.0))
    return text


def make_sim_project(directory: Path, *, high_panel: bool = True) -> SimProject:
    """Write the project into ``directory`` (see module docstring)."""
    directory.mkdir(parents=True, exist_ok=True)
    write_test_building(directory / "model.ifc", schema="IFC4", storeys=1, bays=1,
                        front_door_width_m=DOOR_WIDTH_M)
    names = ("P1", "P2", "P3") if high_panel else ("P1", "P2")
    panels = _add_panels(directory / "model.ifc", names)
    (directory / "schedule.csv").write_text(SCHEDULE, encoding="utf-8")
    (directory / "site.ttl").write_text(_site_ttl(), encoding="utf-8")
    (directory / "stored.ttl").write_text(_storage_ttl(panels, walled=False), encoding="utf-8")
    (directory / "walled.ttl").write_text(_storage_ttl(panels, walled=True), encoding="utf-8")
    (directory / "project.toml").write_text(
        "[project]\n"
        'name = "simtest"\n'
        f'base_iri = "{BASE}"\n'
        "seed = 3\n"
        "[model]\n"
        'ifc = "model.ifc"\n'
        'schedule = "schedule.csv"\n'
        'site = ["site.ttl"]\n'
        "[simulation]\n"
        'task = "T5"\n'
        f'date = "{DATE}"\n'
        "[scenarios.stored]\n"
        'description = "panels stacked on a storage in the yard"\n'
        'overlays = ["stored.ttl"]\n'
        "[scenarios.walled]\n"
        'description = "the same storage, fenced in all round"\n'
        'overlays = ["walled.ttl"]\n',
        encoding="utf-8",
    )
    return SimProject(directory, panels)


@dataclass
class SimCase:
    """A loaded scenario of the test project, ready to simulate: project, world, map and plans."""

    sp: SimProject
    project: Project
    world: World
    grid: OccupancyGrid
    plan: Plan  # B1-B3
    refined: Plan  # after B4


def load_sim_case(directory: Path, scenario: str = "stored", *, seed: int = 3,
                  high_panel: bool = True) -> SimCase:
    """Write the project, load a scenario, build its world and map, plan and refine (B1-B4)."""
    sp = make_sim_project(directory, high_panel=high_panel)
    project = Project.load(directory, scenario=scenario)
    world = build_world(project, parse_date(DATE))
    grid = storey_map(world).grid
    plan = plan_task(project, world=world)
    refined = refine_plan(plan, world, seed=seed, grid=grid)
    return SimCase(sp, project, world, grid, plan, refined)
