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
from dataclasses import dataclass
from pathlib import Path

from ifc_factory import write_test_building
from kbplanner.core.iris import element_iri
from kbplanner.model.dates import parse_date
from kbplanner.planning.manipulation import refine_plan
from kbplanner.planning.plan_model import Plan
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project
from kbplanner.world.build import build_world
from kbplanner.world.maps import storey_map
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import World
from project_parts import (
    PanelSpec,
    add_panels,
    guid,
    layout_ttl,
    pose_ttl,
    prefixes,
    project_toml,
    site_object_ttl,
    stacked_ttl,
    storage_head_ttl,
    worker_ttl,
    write_texts,
)

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
    return guid(f"simtest-{name}")


def _add_panels(ifc_path: Path, names: tuple[str, ...]) -> dict[str, str]:
    specs = [PanelSpec(name, _guid(name), x, y, z, yaw) for name, x, y, z, yaw in PANELS if name in names]
    add_panels(ifc_path, specs, size=PANEL_SIZE, shape="slab", mass_kg=PANEL_MASS_KG, guid_key="simtest-")
    return {s.name: s.global_id for s in specs}


def _site_ttl() -> str:
    text = prefixes(BASE) + layout_ttl(EXTENT, ROBOT_START)
    for name, bx, by in BENCHES:
        text += site_object_ttl(name, "Workspace", name, (1.0, 1.0, 1.0), (bx, by), obstructs=False)
    return text + worker_ttl(1.0, [("west-bench", 20.0), ("east-bench", 20.0)])


def _storage_ttl(panels: dict[str, str], walled: bool) -> str:
    text = prefixes(BASE) + storage_head_ttl(STORAGE, STORAGE_SIZE, PICKUP)
    order = sorted(panels)  # P1 first: top of the stack
    for n, name in enumerate(order):
        text += (stacked_ttl(BASE, panels[name], len(order) - 1 - n,
                             f"kbp:workSequence {n + 1} ; kbp:graspPoint site:grasp-{name}")
                 + pose_ttl(f"grasp-{name}", 0.0, 0.0, PANEL_SIZE[2] / 2))
    if walled:  # a closed ring of fences 0.1 m thick around storage and pickup location
        cx, cy, w, h = 2.5, -3.0, 4.6, 3.6
        for name, fx, fy, fsx, fsy in (("s", cx, cy - h / 2, w, 0.1), ("n", cx, cy + h / 2, w, 0.1),
                                       ("w", cx - w / 2, cy, 0.1, h), ("e", cx + w / 2, cy, 0.1, h)):
            text += site_object_ttl(f"fence-{name}", "SafetyFence", f"Fence {name}", (fsx, fsy, 1.8),
                                    (fx, fy), obstructs=True)
    return text


def make_sim_project(directory: Path, *, high_panel: bool = True) -> SimProject:
    """Write the project into ``directory`` (see module docstring)."""
    directory.mkdir(parents=True, exist_ok=True)
    write_test_building(directory / "model.ifc", schema="IFC4", storeys=1, bays=1,
                        front_door_width_m=DOOR_WIDTH_M)
    names = ("P1", "P2", "P3") if high_panel else ("P1", "P2")
    panels = _add_panels(directory / "model.ifc", names)
    write_texts(directory, {
        "schedule.csv": SCHEDULE, "site.ttl": _site_ttl(),
        "stored.ttl": _storage_ttl(panels, walled=False), "walled.ttl": _storage_ttl(panels, walled=True),
        "project.toml": project_toml(
            "simtest", BASE, seed=3, simulation={"task": "T5", "date": DATE}, scenarios={
            "stored": ("panels stacked on a storage in the yard", ["stored.ttl"]),
            "walled": ("the same storage, fenced in all round", ["walled.ttl"])})})
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
