"""Small 4D models built with rdflib for the knowledge-base tests (A1-A5, B3).

``make_model()`` writes what an IFC import + schedule + site layout would give for a two-room
building: a storey, two spaces with bounds, an exterior front door and an interior door, ``n_frames``
wall frames (kbp:Member) in the east room built by one robotized task (I-W-F-#1 unless ``spec_id``),
one ordinary wall built by a manual task, and a site layout with an extent. Options add the
augmentation of A4 (a frame storage with a pickup location, grasp points) and jobsite parameters (A5).

Layout (site frame, m): building x in [0, 10], y in [0, 6]; west room x < 5, east room x > 5;
front door in the south wall at x = 2.5 (0.9 m wide); interior door at x = 5, y = 3 (0.8 m wide);
frames along y = 4.5 in the east room; storage outside at x = -6.
"""

from __future__ import annotations

from datetime import datetime

from rdflib import RDF, RDFS, XSD, Graph, Literal, URIRef

from kbplanner.core.iris import element_iri, mint, task_iri
from kbplanner.core.rdf_io import bind_prefixes
from kbplanner.core.vocab import BOT, KBP

BASE = "https://w3id.org/kbplanner/data/test-site/"


def frame_gid(i: int) -> str:
    """GlobalId of frame ``i`` (1-based); contains a ``$`` as real GlobalIds may."""
    return f"2F$rame{i:03d}xxxxxxxxxxx"


def add_pose(g: Graph, node: URIRef, x: float, y: float, z: float = 0.0, yaw: float = 0.0) -> URIRef:
    g.add((node, RDF.type, KBP.Pose))
    for p, v in ((KBP.x, x), (KBP.y, y), (KBP.z, z), (KBP.roll, 0.0), (KBP.pitch, 0.0), (KBP.yaw, yaw)):
        g.add((node, p, Literal(float(v))))
    return node


def add_box(g: Graph, node: URIRef, lo: tuple[float, float, float], hi: tuple[float, float, float]) -> URIRef:
    g.add((node, RDF.type, KBP.Box))
    for p, v in zip((KBP.minX, KBP.minY, KBP.minZ), lo, strict=True):
        g.add((node, p, Literal(float(v))))
    for p, v in zip((KBP.maxX, KBP.maxY, KBP.maxZ), hi, strict=True):
        g.add((node, p, Literal(float(v))))
    return node


def add_element(g: Graph, gid: str, cls: URIRef, name: str, pose: tuple[float, float, float],
                lo: tuple[float, float, float], hi: tuple[float, float, float], *,
                mass: float | None = None, storey: URIRef | None = None) -> URIRef:
    el = element_iri(BASE, gid)
    g.add((el, RDF.type, cls))
    g.add((el, KBP.globalId, Literal(gid)))
    g.add((el, KBP.ifcClass, Literal("Ifc" + str(cls).rsplit("#", 1)[-1])))
    g.add((el, RDFS.label, Literal(name)))
    g.add((el, KBP.installedPose, add_pose(g, mint(BASE, "pose", gid), *pose)))
    g.add((el, KBP.bounds, add_box(g, mint(BASE, "box", gid), lo, hi)))
    g.add((el, KBP.meshFile, Literal(f"meshes/{gid}.obj")))
    if mass is not None:
        g.add((el, KBP.mass, Literal(float(mass))))
    if storey is not None:
        g.add((storey, BOT.containsElement, el))
    return el


def add_task(g: Graph, task_id: str, name: str, elements: list[URIRef], *, robotized: bool,
             spec_id: str | None = None, start: datetime = datetime(2022, 5, 10, 7),
             finish: datetime = datetime(2022, 5, 23, 15, 30)) -> URIRef:
    t = task_iri(BASE, task_id)
    g.add((t, RDF.type, KBP.ConstructionTask))
    g.add((t, KBP.taskId, Literal(task_id)))
    g.add((t, RDFS.label, Literal(name)))
    g.add((t, KBP.start, Literal(start, datatype=XSD.dateTime)))
    g.add((t, KBP.finish, Literal(finish, datatype=XSD.dateTime)))
    g.add((t, KBP.robotized, Literal(robotized)))
    if spec_id is not None:
        g.add((t, KBP.taskSpecificationId, Literal(spec_id)))
    for el in elements:
        g.add((t, KBP.buildsElement, el))
    return t


def make_model(n_frames: int = 11, *, storage: bool = False, grasp_points: bool = False,
               spec_id: str | None = "I-W-F-#1", frame_mass: float = 4.5,
               front_door_width: float = 0.9, inner_door_width: float = 0.8,
               jobsite: bool = False) -> Graph:
    """The test model; see the module docstring."""
    g = Graph()
    bind_prefixes(g)
    storey = mint(BASE, "storey", "L1")
    g.add((storey, RDF.type, BOT.Storey))
    g.add((storey, RDFS.label, Literal("Level 1")))
    for sid, name, lo, hi in (("SPACE-W", "Living", (0.3, 0.3, 0.0), (4.95, 5.7, 2.7)),
                              ("SPACE-E", "Bedroom", (5.05, 0.3, 0.0), (9.7, 5.7, 2.7))):
        sp = element_iri(BASE, sid)
        g.add((sp, RDF.type, BOT.Space))
        g.add((sp, KBP.globalId, Literal(sid)))
        g.add((sp, RDFS.label, Literal(name)))
        g.add((sp, KBP.bounds, add_box(g, mint(BASE, "box", sid), lo, hi)))
        g.add((storey, BOT.hasSpace, sp))
    wall = add_element(g, "WALL-S", KBP.Wall, "South wall", (5.0, 0.15, 0.0), (0.0, 0.0, 0.0),
                       (10.0, 0.3, 2.7), storey=storey)
    g.add((wall, KBP.isExternal, Literal(True)))
    front = add_element(g, "DOOR-FRONT", KBP.Door, "Front door", (2.5, 0.15, 0.0), (2.05, 0.0, 0.0),
                        (2.95, 0.3, 2.1), storey=storey)
    g.add((front, KBP.overallWidth, Literal(front_door_width)))
    g.add((front, KBP.overallHeight, Literal(2.1)))
    g.add((front, KBP.isExternal, Literal(True)))
    g.add((front, KBP.hostWall, wall))
    inner = add_element(g, "DOOR-INNER", KBP.Door, "Bedroom door", (5.0, 3.0, 0.0, 1.5708), (4.95, 2.6, 0.0),
                        (5.05, 3.4, 2.1), storey=storey)
    g.add((inner, KBP.overallWidth, Literal(inner_door_width)))
    g.add((inner, KBP.overallHeight, Literal(2.1)))
    g.add((inner, KBP.isExternal, Literal(False)))
    frames = []
    for i in range(1, n_frames + 1):
        x = 5.5 + (i - 1) * (4.0 / max(n_frames, 1))
        frames.append(add_element(g, frame_gid(i), KBP.Member, f"Frame {i}", (x, 4.5, 0.0),
                                  (x - 0.3, 4.45, 0.0), (x + 0.3, 4.55, 2.4), mass=frame_mass, storey=storey))
    add_task(g, "T0", "Exterior walls", [wall], robotized=False,
             start=datetime(2022, 5, 2, 7), finish=datetime(2022, 5, 9, 15, 30))
    add_task(g, "T1", "Frame interior wood partition", frames, robotized=True, spec_id=spec_id)
    layout = mint(BASE, "site", "layout")
    g.add((layout, RDF.type, KBP.SiteLayout))
    g.add((layout, KBP.siteExtent, add_box(g, mint(BASE, "box", "site"), (-20.0, -20.0, 0.0),
                                          (40.0, 30.0, 10.0))))
    if storage:
        add_storage(g, frames)
    if grasp_points:
        for i, f in enumerate(frames, start=1):
            g.add((f, KBP.graspPoint, add_pose(g, mint(BASE, "pose", f"grasp-{i}"), 0.0, 0.0, 1.2)))
    if jobsite:
        add_jobsite(g)
    return g


def add_storage(g: Graph, frames: list[URIRef]) -> URIRef:
    """A frame storage outside the building with a pickup location; every frame stored in it."""
    st = mint(BASE, "site", "frame-storage")
    g.add((st, RDF.type, KBP.MaterialStorage))
    g.add((st, RDFS.label, Literal("Frame storage")))
    g.add((st, KBP.installedPose, add_pose(g, mint(BASE, "pose", "frame-storage"), -6.0, 3.0)))
    for p, v in ((KBP.sizeX, 2.6), (KBP.sizeY, 1.4), (KBP.sizeZ, 0.8)):
        g.add((st, p, Literal(v)))
    g.add((st, KBP.pickupLocation, add_pose(g, mint(BASE, "pose", "frame-pickup"), -4.2, 3.0, yaw=3.1416)))
    for i, f in enumerate(frames):
        g.add((f, KBP.storedIn, st))
        g.add((f, KBP.stackIndex, Literal(i)))
    return st


def add_jobsite(g: Graph, *, max_width: float = 0.8, min_speed: float = 0.1, max_speed: float = 0.4,
                scenario: str | None = None, zone_at: tuple[float, float] = (-10.0, -10.0)) -> URIRef:
    """Jobsite parameters (A5) with an NV-2 speed limit and a no-go zone."""
    key = f"jobsite-{scenario}" if scenario else "jobsite"
    js = mint(BASE, "site", key)
    g.add((js, RDF.type, KBP.JobsiteParameters))
    if scenario:
        g.add((js, KBP.forScenario, Literal(scenario)))
    g.add((js, KBP.maxRobotWidth, Literal(max_width)))
    g.add((js, KBP.maxRobotLength, Literal(1.2)))
    g.add((js, KBP.maxRobotHeight, Literal(2.0)))
    g.add((js, KBP.maxRobotMass, Literal(150.0)))
    g.add((js, KBP.safetyStopDistance, Literal(0.8)))
    limit = mint(BASE, "site", f"{key}-nv2-limit")
    g.add((limit, RDF.type, KBP.ActionLimit))
    g.add((limit, KBP.appliesTo, URIRef("https://w3id.org/kbplanner/kb#NV-2")))
    g.add((limit, KBP.minSpeed, Literal(min_speed)))
    g.add((limit, KBP.maxSpeed, Literal(max_speed)))
    g.add((js, KBP.hasActionLimit, limit))
    zone = mint(BASE, "site", f"{key}-zone")
    g.add((zone, RDF.type, KBP.NoGoZone))
    g.add((zone, RDFS.label, Literal("Crane swing area")))
    g.add((zone, KBP.installedPose, add_pose(g, mint(BASE, "pose", f"{key}-zone"), *zone_at)))
    for p, v in ((KBP.sizeX, 4.0), (KBP.sizeY, 4.0), (KBP.sizeZ, 3.0)):
        g.add((zone, p, Literal(v)))
    g.add((js, KBP.hasNoGoZone, zone))
    return js
