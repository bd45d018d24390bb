"""Test buildings of any size (scale, issue 6): a multi-storey residential building as a complete project.

Takes a size (storeys, units per storey) and a seed; writes a project directory shaped like
``data/case_study`` that every step of the pipeline loads, and returns a :class:`GeneratedBuilding`
saying what it holds:

- ``model/building.ifc``: a real IFC4 file written with ``ifcopenshell.api`` in metres: site, building,
  storeys ``Level 1`` .. ``Level N`` and ``Roof``; per storey a row of apartments (units) along x, a
  corridor on their north side and a core at the east end with a stair (``IfcStair``, one solid: the
  stepped profile extruded) and a lift shaft (four ``Lift shaft wall`` walls and a lift door). Per
  unit: its facade walls (``Pset_WallCommon.IsExternal`` true), a party wall and a corridor wall
  (false), two interior partitions (false) that split it into a living room and two bedrooms, a unit
  door (1.2 m, like the case study's front door: the robot's way in), two room doors (0.9 m), three
  spaces and a floor slab; every door is an ``IfcDoor`` filling an ``IfcOpeningElement`` that voids
  its host wall; the ground floor has a 1.2 m entrance door in the west facade.
- The robotized framing task: prefabricated stud-frame panels (``IfcMember`` "Stud frame panel ...",
  ObjectType "Interior stud frame panel", 38 x 89 mm SPF studs at <= 600 mm centres, plates and a row
  of noggings as extruded rectangles, 2.4 m high, at most 0.75 m long, about 9-14 kg as in the case
  study; ``Pset_MemberCommon``, ``Kbplanner_StudFramePanel`` and ``BaseQuantities`` with NetWeight)
  standing on the axes of the partitions, cut between the door openings.
- ``schedule.csv``: mobilisation, then per storey structure, facade, **framing (robotized,
  I-W-F-#1)**, partitions (board and finish) and doors, and the roof; every building element is built
  by exactly one task, through selectors.
- ``site/``: site layout (extent, robot start at the entrance, office, carpenters' lumber storage and
  entrance area), two workers with routes, jobsite parameters; ``augmentation/work_sequence.ttl``
  (always loaded); scenario ``storage-in-units``: two frame storages (bearers, at most 8 frames each)
  with a pickup location in the living room of every unit, ``kbp:storedIn``/``kbp:stackIndex`` for
  every panel (first installed on top) and ``augmentation/grasp_points.ttl`` (centre of mass, local).
  The bare model therefore has exactly the case study's two requirements, and the scenario conforms.

Output is deterministic: the same arguments give byte-identical files (GlobalIds are uuid5 of stable
names and the seed; no time stamps). The seed moves the partitions and doors of each unit a little.

Example:
    >>> import tempfile
    >>> b = generate_building(Path(tempfile.mkdtemp()) / "b", storeys=1, units_per_storey=1)
    >>> b.frames, b.counts["IfcMember"]
    (14, 14)
"""

from __future__ import annotations

import csv
import io
import logging
import math
import random
import shutil
import time
import uuid
from collections.abc import Iterable
from dataclasses import dataclass, field
from datetime import date, timedelta
from pathlib import Path
from typing import Any
from urllib.parse import quote

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.unit
import ifcopenshell.guid
import numpy as np

from kbplanner.core.errors import KbplannerError
from kbplanner.core.output_dirs import check_output_dir, output_options
from kbplanner.core.outputs import run_directory
from kbplanner.model.stud_frames import DENSITY, MATERIAL, PANEL_HEIGHT, STUD_DEPTH, stud_frame

log = logging.getLogger(__name__)

MAX_STOREYS = 60
MAX_UNITS = 40

# Plan (metres, site frame = IFC world frame): units of UNIT_W x UNIT_D in a row along x from x = 0,
# a corridor of CORRIDOR_W on their north side, a core of CORE_W at the east end.
STOREY_HEIGHT = 3.0
SLAB_T = 0.2
WALL_HEIGHT = STOREY_HEIGHT - SLAB_T  # floor to the underside of the slab above
UNIT_W = 8.0
UNIT_D = 7.0
CORRIDOR_W = 2.0
CORE_W = 6.0
EXT_T = 0.3  # facades (body inside the footprint)
PARTY_T = 0.2  # party, corridor and lift shaft walls (centred)
PARTITION_T = 0.1  # interior partitions (centred)
DOOR_W = 0.9
ENTRANCE_W = 1.2
UNIT_DOOR_W = 1.2
DOOR_H = 2.1

# Frame panels: kbplanner.model.stud_frames, as in the case study (data/case_study/tools/build_frames.py).
MAX_PANEL_LENGTH = 0.75  # keeps every panel between about 9 and 14 kg

# Frame storage in each unit's living room (bearers as in the case study) and the robot's pickup.
STORAGE_SIZE = (2.6, 0.8, 0.1)
PICKUP_STANDOFF = 1.15  # the Husky's half length + a cell of margin clear of the bearers
STORAGE_FROM_WEST = 0.9  # storage centres, metres east of the unit's west wall axis
STORAGE_YS = (2.0, 4.8)  # two stacks per unit, along the living room's west wall
MAX_STACK = 8  # frames per stack: the top frame stays within the arm's reach (case study: 11 x 89 mm)

START_DATE = date(2024, 3, 4)  # a Monday: week 0 (mobilisation)
SCENARIO = "storage-in-units"
FRAMING_SPEC = "I-W-F-#1"
_GUID_NS = uuid.UUID("0c1b5c2e-8f7a-5d43-9a6e-6b62706c6765")  # fixed namespace of this generator


class GeneratorError(KbplannerError):
    """Bad arguments for the building generator, or an output directory that cannot be used."""


@dataclass(frozen=True)
class Panel:
    """One stud-frame panel: where it stands and what it weighs (metres, radians, kilograms)."""

    panel_id: str
    global_id: str
    storey: int  # 1-based
    unit: int  # 1-based
    wall: str  # GlobalId of the host partition
    sequence: int  # install order within the storey's framing task (1 = first)
    unit_order: int  # install order within the unit (1 = first)
    x: float
    y: float
    z: float
    yaw: float
    length: float
    studs: int
    volume_m3: float
    mass_kg: float
    centre_of_mass_local: tuple[float, float, float]


@dataclass(frozen=True)
class GeneratedBuilding:
    """What :func:`generate_building` wrote."""

    directory: Path
    ifc: Path
    storeys: int
    units_per_storey: int
    seed: int
    base_iri: str
    counts: dict[str, int]  # IFC class -> number of instances (products only)
    elements: int  # building elements (IfcElement without openings)
    frames: int
    frames_per_storey: tuple[int, ...]
    frame_mass_kg: tuple[float, float]
    tasks: tuple[str, ...]
    robotized_tasks: tuple[str, ...]
    simulation_task: str
    simulation_date: str
    scenario: str
    files: tuple[str, ...]
    seconds: float = field(compare=False)


def _matrix(x: float, y: float, z: float, yaw: float = 0.0) -> np.ndarray:
    m = np.eye(4)
    c, s = (round(v, 12) + 0.0 for v in (math.cos(yaw), math.sin(yaw)))
    m[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    m[:3, 3] = [x, y, z]
    return m


def _num(v: float) -> str:
    """A Turtle xsd:double literal, stable: ``1.5e0``."""
    r = repr(round(float(v), 6) + 0.0)
    return r if "e" in r else f"{r}e0"


# ----------------------------------------------------------------------------------------------
# The plan of one unit
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _UnitPlan:
    """Where the partitions and doors of one unit are (unit-local x from the unit's west axis)."""

    p1_x: float  # north-south partition (living room | bedrooms)
    p2_y: float  # east-west partition between the two bedrooms
    unit_door_x: float  # start of the unit door along the corridor wall
    door_s: float  # start of the south bedroom door along P1 (from its south end)
    door_n: float  # start of the north bedroom door along P1


def _unit_plans(storeys: int, units: int, seed: int) -> dict[tuple[int, int], _UnitPlan]:
    rng = random.Random(seed)
    out = {}
    for k in range(storeys):
        for j in range(units):
            if seed == 0:
                p1, p2, ud, ds, dn = 4.0, 3.5, 2.2, 1.2, 4.6
            else:
                p1 = 4.0 + rng.choice((-0.2, -0.1, 0.0, 0.1, 0.2))
                p2 = 3.5 + rng.choice((-0.3, -0.15, 0.0, 0.15, 0.3))
                ud = 2.2 + rng.choice((0.0, 0.2, 0.4))
                ds = 1.2 + rng.choice((-0.2, 0.0, 0.2))
                dn = 4.6 + rng.choice((-0.2, 0.0, 0.2))
            out[(k, j)] = _UnitPlan(p1, p2, ud, ds, dn)
    return out


def _segments(length: float, cuts: Iterable[tuple[float, float]]) -> list[tuple[float, float]]:
    """Free lengths of a wall axis ``[0, length]`` between door cuts."""
    out, start = [], 0.0
    for a, b in sorted(cuts):
        if a > start + 1e-9:
            out.append((start, a))
        start = max(start, b)
    if start < length - 1e-9:
        out.append((start, length))
    return out


# ----------------------------------------------------------------------------------------------
# IFC writer
# ----------------------------------------------------------------------------------------------


class _Ifc:
    """ifcopenshell.api calls with deterministic GlobalIds (uuid5 of a stable key and the seed)."""

    def __init__(self, salt: str) -> None:
        self.salt = salt
        self.f = ifcopenshell.api.project.create_file(version="IFC4")
        self.project = self.create("IfcProject", "Generated building project", "project")
        ifcopenshell.api.unit.assign_unit(
            self.f,
            length={"is_metric": True, "raw": "METERS"},
            area={"is_metric": True, "raw": "METERS"},
            volume={"is_metric": True, "raw": "METERS"},
        )
        model = ifcopenshell.api.context.add_context(self.f, context_type="Model")
        self.body = ifcopenshell.api.context.add_context(
            self.f, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model
        )
        self.z_dir = self.f.createIfcDirection((0.0, 0.0, 1.0))
        self.x_dir = self.f.createIfcDirection((1.0, 0.0, 0.0))

    def gid(self, key: str) -> str:
        salt = 0
        while True:
            name = f"{self.salt}/{key}" + (f"#{salt}" if salt else "")
            g = str(ifcopenshell.guid.compress(uuid.uuid5(_GUID_NS, name).hex))
            if "$" not in g:  # '$' is awkward in shells and IRIs
                return g
            salt += 1

    def create(self, ifc_class: str, name: str, key: str, predefined_type: str | None = None) -> Any:
        entity = ifcopenshell.api.root.create_entity(
            self.f, ifc_class=ifc_class, name=name, predefined_type=predefined_type
        )
        entity.GlobalId = self.gid(key)
        return entity

    def place(self, product: Any, matrix: np.ndarray) -> None:
        ifcopenshell.api.geometry.edit_object_placement(self.f, product=product, matrix=matrix, is_si=True)

    def contain(self, product: Any, structure: Any) -> None:
        """Contain one product (before placing it: the API re-places the products of a call in set order)."""
        ifcopenshell.api.spatial.assign_container(self.f, products=[product], relating_structure=structure)

    def wall(
        self,
        key: str,
        name: str,
        storey: Any,
        start: tuple[float, float],
        end: tuple[float, float],
        z: float,
        thickness: float,
        centred: bool,
        external: bool,
    ) -> tuple[Any, float, float, float]:
        """A straight wall from ``start`` to ``end`` (its axis); body centred or to the left (inside)."""
        f = self.f
        dx, dy = end[0] - start[0], end[1] - start[1]
        length = math.hypot(dx, dy)
        yaw = math.atan2(dy, dx)
        w = self.create("IfcWall", name, key, predefined_type="STANDARD" if external else "PARTITIONING")
        self.contain(w, storey)
        self.place(w, _matrix(start[0], start[1], z, yaw))
        rep = ifcopenshell.api.geometry.add_wall_representation(
            f,
            context=self.body,
            length=length,
            height=WALL_HEIGHT,
            thickness=thickness,
            offset=-thickness / 2 if centred else 0.0,
        )
        ifcopenshell.api.geometry.assign_representation(f, product=w, representation=rep)
        pset = ifcopenshell.api.pset.add_pset(f, product=w, name="Pset_WallCommon")
        ifcopenshell.api.pset.edit_pset(
            f, pset=pset, properties={"IsExternal": external, "LoadBearing": not centred or thickness > 0.15}
        )
        return w, length, yaw, thickness

    def door(
        self,
        key: str,
        name: str,
        storey: Any,
        host: tuple[Any, float, float, float],
        start: tuple[float, float],
        centred: bool,
        along: float,
        width: float,
        z: float,
        external: bool,
    ) -> Any:
        """A door of ``width`` filling an opening that voids ``host`` from ``along`` (m along its axis)."""
        f = self.f
        wall, _length, yaw, thickness = host
        base = _matrix(start[0], start[1], z, yaw)
        centre_offset = -thickness / 2 if centred else 0.0
        opening = self.create("IfcOpeningElement", f"Opening {name}", f"{key}/opening", "OPENING")
        self.place(opening, base @ _matrix(along, centre_offset - 0.05, 0.0))
        rep = ifcopenshell.api.geometry.add_wall_representation(
            f, context=self.body, length=width, height=DOOR_H, thickness=thickness + 0.1
        )
        ifcopenshell.api.geometry.assign_representation(f, product=opening, representation=rep)
        ifcopenshell.api.feature.add_feature(f, feature=opening, element=wall)
        door = self.create("IfcDoor", name, key, predefined_type="DOOR")
        self.contain(door, storey)
        self.place(door, base @ _matrix(along, centre_offset, 0.0))
        rep = ifcopenshell.api.geometry.add_wall_representation(
            f, context=self.body, length=width, height=DOOR_H, thickness=0.05, offset=thickness / 2 - 0.025
        )
        ifcopenshell.api.geometry.assign_representation(f, product=door, representation=rep)
        door.OverallWidth = width
        door.OverallHeight = DOOR_H
        pset = ifcopenshell.api.pset.add_pset(f, product=door, name="Pset_DoorCommon")
        ifcopenshell.api.pset.edit_pset(f, pset=pset, properties={"IsExternal": external})
        ifcopenshell.api.feature.add_filling(f, opening=opening, element=door)
        return door

    def slab(
        self,
        key: str,
        name: str,
        storey: Any,
        polygon: list[tuple[float, float]],
        top_z: float,
        predefined: str = "FLOOR",
    ) -> Any:
        s = self.create("IfcSlab", name, key, predefined_type=predefined)
        self.contain(s, storey)
        self.place(s, _matrix(0.0, 0.0, top_z - SLAB_T))
        rep = ifcopenshell.api.geometry.add_slab_representation(
            self.f, context=self.body, depth=SLAB_T, polyline=polygon
        )
        ifcopenshell.api.geometry.assign_representation(self.f, product=s, representation=rep)
        return s

    def space(
        self,
        key: str,
        name: str,
        long_name: str,
        storey: Any,
        box: tuple[float, float, float, float],
        z: float,
    ) -> Any:
        x0, y0, x1, y1 = box
        sp = self.create("IfcSpace", name, key, predefined_type="SPACE")
        sp.LongName = long_name
        ifcopenshell.api.aggregate.assign_object(self.f, products=[sp], relating_object=storey)
        self.place(sp, _matrix(0.0, 0.0, z))
        rep = ifcopenshell.api.geometry.add_slab_representation(
            self.f, context=self.body, depth=WALL_HEIGHT, polyline=[(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        )
        ifcopenshell.api.geometry.assign_representation(self.f, product=sp, representation=rep)
        return sp

    def boxes(self, items: list[tuple[float, float, float, float, float, float]]) -> Any:
        """A Body representation of axis-aligned boxes (x0, y0, z0, x1, y1, z1) as extruded rectangles."""
        f = self.f
        solids = []
        for x0, y0, z0, x1, y1, z1 in items:
            profile = f.createIfcRectangleProfileDef(
                "AREA",
                None,
                f.createIfcAxis2Placement2D(f.createIfcCartesianPoint(((x0 + x1) / 2, (y0 + y1) / 2)), None),
                x1 - x0,
                y1 - y0,
            )
            position = f.createIfcAxis2Placement3D(
                f.createIfcCartesianPoint((0.0, 0.0, z0)), self.z_dir, self.x_dir
            )
            solids.append(f.createIfcExtrudedAreaSolid(profile, position, self.z_dir, z1 - z0))
        return f.createIfcShapeRepresentation(self.body, "Body", "SweptSolid", solids)

    def stair(self, risers: int, rise: float, going: float, width: float) -> Any:
        """A Body of one straight flight: the stepped y-z profile extruded along x by ``width``."""
        f = self.f
        pts = [(0.0, 0.0)]
        for i in range(risers - 1):
            pts += [(i * going, (i + 1) * rise), ((i + 1) * going, (i + 1) * rise)]
        pts += [((risers - 1) * going, 0.0), (0.0, 0.0)]
        curve = f.createIfcPolyline([f.createIfcCartesianPoint((round(u, 6), round(v, 6))) for u, v in pts])
        profile = f.createIfcArbitraryClosedProfileDef("AREA", None, curve)
        # profile x along the stair's y, profile y up; extruded along the stair's x
        position = f.createIfcAxis2Placement3D(
            f.createIfcCartesianPoint((0.0, 0.0, 0.0)), self.x_dir, f.createIfcDirection((0.0, 1.0, 0.0))
        )
        solid = f.createIfcExtrudedAreaSolid(profile, position, self.z_dir, width)
        return f.createIfcShapeRepresentation(self.body, "Body", "SweptSolid", [solid])

    def finish(self, time_stamp: str) -> None:
        """Deterministic GlobalIds on everything the API created without one of ours."""
        for e in sorted(self.f.by_type("IfcRoot"), key=lambda e: e.id()):
            if e.OwnerHistory is not None:
                e.OwnerHistory = None
        ours = set()
        for e in self.f.by_type("IfcProduct"):
            ours.add(e.id())
        ours.add(self.project.id())
        for e in sorted(self.f.by_type("IfcRoot"), key=lambda e: e.id()):
            if e.id() not in ours:
                e.GlobalId = self.gid(f"{e.is_a()}/{e.id()}")
        for rel in self.f.by_type("IfcRelationship"):  # the API keeps related objects as sets
            for attr in ("RelatedObjects", "RelatedElements"):
                items = getattr(rel, attr, None)
                if isinstance(items, tuple) and len(items) > 1:
                    setattr(rel, attr, sorted(items, key=lambda e: e.id()))
        self.f.header.file_name.time_stamp = time_stamp
        self.f.header.file_name.originating_system = "kbplanner building_generator (ifcopenshell.api)"
        self.f.header.file_name.preprocessor_version = "kbplanner"


# ----------------------------------------------------------------------------------------------
# The building
# ----------------------------------------------------------------------------------------------


class _Builder:
    def __init__(self, storeys: int, units: int, seed: int) -> None:
        self.n, self.m, self.seed = storeys, units, seed
        self.ifc = _Ifc(f"{storeys}x{units}/seed{seed}")
        self.plans = _unit_plans(storeys, units, seed)
        self.length = units * UNIT_W + CORE_W
        self.depth = UNIT_D + CORRIDOR_W
        self.panels: list[Panel] = []
        self.storey_entities: list[Any] = []
        self.frame_products: list[Any] = []
        self.wood: Any = None

    # ---- spatial tree ------------------------------------------------------------------------
    def build(self) -> ifcopenshell.file:
        ifc, f = self.ifc, self.ifc.f
        site = ifc.create("IfcSite", "Generated site", "site")
        ifc.place(site, _matrix(0.0, 0.0, 0.0))
        building = ifc.create("IfcBuilding", f"Generated residential building {self.n}x{self.m}", "building")
        ifcopenshell.api.aggregate.assign_object(f, products=[site], relating_object=ifc.project)
        ifcopenshell.api.aggregate.assign_object(f, products=[building], relating_object=site)
        ifc.place(building, _matrix(0.0, 0.0, 0.0))
        self.wood = ifcopenshell.api.material.add_material(f, name=MATERIAL)
        storeys = []
        for k in range(self.n + 1):
            name = f"Level {k + 1}" if k < self.n else "Roof"
            st = ifc.create("IfcBuildingStorey", name, f"storey/{k}")
            st.Elevation = k * STOREY_HEIGHT
            storeys.append(st)
        ifcopenshell.api.aggregate.assign_object(f, products=storeys, relating_object=building)
        for k, st in enumerate(storeys):
            ifc.place(st, _matrix(0.0, 0.0, k * STOREY_HEIGHT))
        self.storey_entities = storeys
        for k in range(self.n):
            self.storey(k, storeys[k])
        roof = storeys[self.n]
        ifc.slab(
            "roof",
            "Roof slab",
            roof,
            [(0.0, 0.0), (self.length, 0.0), (self.length, self.depth), (0.0, self.depth)],
            self.n * STOREY_HEIGHT,
            "ROOF",
        )
        members = sorted(self.frame_products, key=lambda e: e.Name)
        if members:
            ifcopenshell.api.material.assign_material(
                f, products=members, type="IfcMaterial", material=self.wood
            )
        return f

    def storey(self, k: int, st: Any) -> None:
        ifc = self.ifc
        z = k * STOREY_HEIGHT
        lvl = f"L{k + 1:02d}"
        L, D, Dc = self.length, UNIT_D, self.depth
        mw = self.m * UNIT_W
        # Facades: west (entrance on the ground floor), east, core south, core north.
        west = ifc.wall(
            f"{lvl}/ext/west", f"Exterior wall {lvl} west", st, (0.0, Dc), (0.0, 0.0), z, EXT_T, False, True
        )
        if k == 0:
            along = Dc - (D + CORRIDOR_W / 2) - ENTRANCE_W / 2  # centred on the corridor
            ifc.door("entrance", "Entrance door", st, west, (0.0, Dc), False, along, ENTRANCE_W, z, True)
        ifc.wall(f"{lvl}/ext/east", f"Exterior wall {lvl} east", st, (L, 0.0), (L, Dc), z, EXT_T, False, True)
        ifc.wall(
            f"{lvl}/ext/core-south",
            f"Exterior wall {lvl} core south",
            st,
            (mw, 0.0),
            (L, 0.0),
            z,
            EXT_T,
            False,
            True,
        )
        ifc.wall(
            f"{lvl}/ext/core-north",
            f"Exterior wall {lvl} core north",
            st,
            (L, Dc),
            (mw, Dc),
            z,
            EXT_T,
            False,
            True,
        )
        # Slabs of the corridor and the core; the corridor and lobby spaces.
        ifc.slab(
            f"{lvl}/slab/corridor",
            f"Floor slab {lvl} corridor",
            st,
            [(0.0, D), (mw, D), (mw, Dc), (0.0, Dc)],
            z,
        )
        ifc.slab(
            f"{lvl}/slab/core", f"Floor slab {lvl} core", st, [(mw, 0.0), (L, 0.0), (L, Dc), (mw, Dc)], z
        )
        ifc.space(
            f"{lvl}/space/corridor",
            f"{k + 1}-C",
            f"Corridor {lvl}",
            st,
            (EXT_T, D + PARTY_T / 2, mw, Dc - EXT_T),
            z,
        )
        ifc.space(
            f"{lvl}/space/lobby",
            f"{k + 1}-L",
            f"Lift lobby {lvl}",
            st,
            (mw + PARTY_T / 2, EXT_T, L - EXT_T, Dc - EXT_T),
            z,
        )
        self.core(st, z, lvl)
        sequence = 0
        for j in range(self.m):
            sequence = self.unit(k, j, st, z, lvl, sequence)

    def core(self, st: Any, z: float, lvl: str) -> None:
        ifc = self.ifc
        mw, L = self.m * UNIT_W, self.length
        # Party wall between the last unit and the core (the corridor runs on into the lobby).
        ifc.wall(
            f"{lvl}/party/core",
            f"Party wall {lvl} core",
            st,
            (mw, EXT_T),
            (mw, UNIT_D),
            z,
            PARTY_T,
            True,
            False,
        )
        # Lift shaft: 2.2 m square (wall axes) near the south-east corner; the door faces the lobby (north).
        x0, x1, y0, y1 = L - 3.1, L - 0.9, 0.9, 3.1
        ifc.wall(
            f"{lvl}/lift/south",
            f"Lift shaft wall {lvl} south",
            st,
            (x0, y0),
            (x1, y0),
            z,
            PARTY_T,
            True,
            False,
        )
        ifc.wall(
            f"{lvl}/lift/east", f"Lift shaft wall {lvl} east", st, (x1, y0), (x1, y1), z, PARTY_T, True, False
        )
        north = ifc.wall(
            f"{lvl}/lift/north",
            f"Lift shaft wall {lvl} north",
            st,
            (x1, y1),
            (x0, y1),
            z,
            PARTY_T,
            True,
            False,
        )
        ifc.wall(
            f"{lvl}/lift/west", f"Lift shaft wall {lvl} west", st, (x0, y1), (x0, y0), z, PARTY_T, True, False
        )
        ifc.door(
            f"{lvl}/door/lift",
            f"Lift door {lvl}",
            st,
            north,
            (x1, y1),
            True,
            (x1 - x0 - DOOR_W) / 2,
            DOOR_W,
            z,
            False,
        )
        # Stair: 15 risers of 0.2 m, 0.28 m goings, 1.2 m wide, rising northwards along the core's west side;
        # one solid (the stepped side profile extruded across the width), so that it is watertight.
        stair = ifc.create("IfcStair", f"Stair {lvl}", f"{lvl}/stair", predefined_type="STRAIGHT_RUN_STAIR")
        ifc.contain(stair, st)
        ifc.place(stair, _matrix(mw + 0.4, 0.6, z))
        ifcopenshell.api.geometry.assign_representation(
            ifc.f,
            product=stair,
            representation=ifc.stair(risers=15, rise=STOREY_HEIGHT / 15, going=0.28, width=1.2),
        )

    def unit(self, k: int, j: int, st: Any, z: float, lvl: str, sequence: int) -> int:
        ifc = self.ifc
        plan = self.plans[(k, j)]
        x0 = j * UNIT_W
        x1 = x0 + UNIT_W
        u = f"{lvl}-U{j + 1:02d}"
        west_face = x0 + (EXT_T if j == 0 else PARTY_T / 2)
        east_face = x1 - PARTY_T / 2
        ifc.wall(
            f"{u}/ext/south", f"Exterior wall {u} south", st, (x0, 0.0), (x1, 0.0), z, EXT_T, False, True
        )
        ifc.wall(
            f"{u}/ext/north",
            f"Exterior wall {u} north",
            st,
            (x1, self.depth),
            (x0, self.depth),
            z,
            EXT_T,
            False,
            True,
        )
        if j > 0:
            ifc.wall(f"{u}/party", f"Party wall {u}", st, (x0, EXT_T), (x0, UNIT_D), z, PARTY_T, True, False)
        corridor = ifc.wall(
            f"{u}/corridor", f"Corridor wall {u}", st, (x0, UNIT_D), (x1, UNIT_D), z, PARTY_T, True, False
        )
        ifc.door(
            f"{u}/door/unit",
            f"Unit door {u}",
            st,
            corridor,
            (x0, UNIT_D),
            True,
            plan.unit_door_x,
            UNIT_DOOR_W,
            z,
            False,
        )
        # Partitions: P1 north-south at p1_x (from the facade to the corridor wall), P2 east-west.
        px = x0 + plan.p1_x
        p1_start, p1_end = (px, EXT_T), (px, UNIT_D - PARTY_T / 2)
        p1 = ifc.wall(f"{u}/p1", f"Partition {u} P1", st, p1_start, p1_end, z, PARTITION_T, True, False)
        p2_start, p2_end = (east_face, plan.p2_y), (px + PARTITION_T / 2, plan.p2_y)
        p2 = ifc.wall(f"{u}/p2", f"Partition {u} P2", st, p2_start, p2_end, z, PARTITION_T, True, False)
        ifc.door(
            f"{u}/door/south", f"Room door {u} south", st, p1, p1_start, True, plan.door_s, DOOR_W, z, False
        )
        ifc.door(
            f"{u}/door/north", f"Room door {u} north", st, p1, p1_start, True, plan.door_n, DOOR_W, z, False
        )
        ifc.slab(f"{u}/slab", f"Floor slab {u}", st, [(x0, 0.0), (x1, 0.0), (x1, UNIT_D), (x0, UNIT_D)], z)
        ifc.space(
            f"{u}/living",
            f"{k + 1}{j + 1:02d}-1",
            f"Living room {u}",
            st,
            (west_face, EXT_T, px - PARTITION_T / 2, UNIT_D - PARTY_T / 2),
            z,
        )
        ifc.space(
            f"{u}/bed-south",
            f"{k + 1}{j + 1:02d}-2",
            f"Bedroom {u} south",
            st,
            (px + PARTITION_T / 2, EXT_T, east_face, plan.p2_y - PARTITION_T / 2),
            z,
        )
        ifc.space(
            f"{u}/bed-north",
            f"{k + 1}{j + 1:02d}-3",
            f"Bedroom {u} north",
            st,
            (px + PARTITION_T / 2, plan.p2_y + PARTITION_T / 2, east_face, UNIT_D - PARTY_T / 2),
            z,
        )
        # Frames: P2 first (east end westwards, reached through P1 before it is closed), then P1 from
        # the facade northwards, so that no installed panel blocks the way to the next.
        p1_len = p1_end[1] - p1_start[1]
        p2_len = p2_start[0] - p2_end[0]
        runs = [
            (p2, p2_start, math.pi, _segments(p2_len, [])),
            (
                p1,
                p1_start,
                math.pi / 2,
                _segments(p1_len, [(plan.door_s, plan.door_s + DOOR_W), (plan.door_n, plan.door_n + DOOR_W)]),
            ),
        ]
        order = 0
        for wall, start, yaw, segs in runs:
            direction = (round(math.cos(yaw), 12) + 0.0, round(math.sin(yaw), 12) + 0.0)
            for a, b in segs:
                count = max(1, math.ceil((b - a) / MAX_PANEL_LENGTH - 1e-9))
                length = (b - a) / count
                for i in range(count):
                    order += 1
                    sequence += 1
                    s = a + (i + 0.5) * length
                    self.frame(
                        k,
                        j,
                        wall[0],
                        order,
                        sequence,
                        start[0] + direction[0] * s,
                        start[1] + direction[1] * s,
                        z,
                        yaw,
                        length,
                        st,
                    )
        return sequence

    def frame(
        self,
        k: int,
        j: int,
        wall: Any,
        order: int,
        sequence: int,
        x: float,
        y: float,
        z: float,
        yaw: float,
        length: float,
        st: Any,
    ) -> None:
        ifc, f = self.ifc, self.ifc.f
        pid = f"L{k + 1:02d}-U{j + 1:02d}-F{order:02d}"
        panel = stud_frame(length, PANEL_HEIGHT)
        pieces, vol, studs = panel.pieces, panel.volume_m3, panel.studs
        com_x, _, com_z = panel.centre_of_mass_local
        mass = round(panel.mass_kg(DENSITY), 2)
        m = ifc.create("IfcMember", f"Stud frame panel {pid}", f"frame/{pid}", predefined_type="STUD")
        m.ObjectType = "Interior stud frame panel"
        m.Tag = pid
        m.Description = (
            f"Prefabricated wood stud frame {length:.3f} x {PANEL_HEIGHT:.2f} m, {studs} studs "
            f"38x89 mm SPF, {mass:.1f} kg"
        )
        ifc.contain(m, st)
        ifc.place(m, _matrix(round(x, 4), round(y, 4), z, yaw))
        rep = ifc.boxes(
            [(p.x_min, -STUD_DEPTH / 2, p.z_min, p.x_max, STUD_DEPTH / 2, p.z_max) for p in pieces]
        )
        ifcopenshell.api.geometry.assign_representation(f, product=m, representation=rep)
        pset = ifcopenshell.api.pset.add_pset(f, product=m, name="Pset_MemberCommon")
        ifcopenshell.api.pset.edit_pset(
            f, pset=pset, properties={"Reference": pid, "IsExternal": False, "LoadBearing": False}
        )
        pset = ifcopenshell.api.pset.add_pset(f, product=m, name="Kbplanner_StudFramePanel")
        ifcopenshell.api.pset.edit_pset(
            f,
            pset=pset,
            properties={
                "PanelId": pid,
                "HostWallGlobalId": wall.GlobalId,
                "InstallOrder": sequence,
                "StudCount": studs,
                "StudSection": "38 x 89 mm",
                "AssumedDensity": DENSITY,
                "Mass": float(mass),
            },
        )
        qto = ifcopenshell.api.pset.add_qto(f, product=m, name="BaseQuantities")
        ifcopenshell.api.pset.edit_qto(
            f,
            qto=qto,
            properties={
                "Length": round(length, 4),
                "Height": PANEL_HEIGHT,
                "Width": STUD_DEPTH,
                "NetVolume": round(vol, 6),
                "NetWeight": float(mass),
            },
        )
        self.frame_products.append(m)
        self.panels.append(
            Panel(
                panel_id=pid,
                global_id=m.GlobalId,
                storey=k + 1,
                unit=j + 1,
                wall=wall.GlobalId,
                sequence=sequence,
                unit_order=order,
                x=round(x, 4),
                y=round(y, 4),
                z=z,
                yaw=yaw,
                length=round(length, 4),
                studs=studs,
                volume_m3=round(vol, 6),
                mass_kg=mass,
                centre_of_mass_local=(round(com_x, 6) + 0.0, 0.0, round(com_z, 6)),
            )
        )


# ----------------------------------------------------------------------------------------------
# Project files
# ----------------------------------------------------------------------------------------------

_PREFIXES = """@prefix kbp:  <https://w3id.org/kbplanner/ontology#> .
@prefix kb:   <https://w3id.org/kbplanner/kb#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix xsd:  <http://www.w3.org/2001/XMLSchema#> .
"""


def _pose_ttl(iri: str, x: float, y: float, z: float, yaw: float, label: str | None = None) -> list[str]:
    out = [f"<{iri}> a kbp:Pose ;"]
    if label:
        out.append(f'    rdfs:label "{label}" ;')
    out += [
        f"    kbp:x {_num(x)} ; kbp:y {_num(y)} ; kbp:z {_num(z)} ;",
        f"    kbp:roll 0.0e0 ; kbp:pitch 0.0e0 ; kbp:yaw {_num(yaw)} .",
    ]
    return out


def _site_object(
    base: str,
    key: str,
    cls: str,
    label: str,
    obstructs: bool,
    size: tuple[float, float, float],
    x: float,
    y: float,
    yaw: float = 0.0,
) -> list[str]:
    iri, pose = f"{base}site/{key}", f"{base}site/{key}-pose"
    return [
        f"<{iri}> a kbp:{cls} ;",
        f'    rdfs:label "{label}" ;',
        f"    kbp:obstructs {'true' if obstructs else 'false'} ;",
        f"    kbp:sizeX {_num(size[0])} ; kbp:sizeY {_num(size[1])} ; kbp:sizeZ {_num(size[2])} ;",
        f"    kbp:installedPose <{pose}> .",
        *_pose_ttl(pose, x, y, 0.0, yaw),
        "",
    ]


class _Files:
    def __init__(self, builder: _Builder, base: str) -> None:
        self.b = builder
        self.base = base
        self.n, self.m = builder.n, builder.m

    def element(self, gid: str) -> str:
        return f"<{self.base}element/{quote(gid, safe='')}>"

    def week(self, w: int, day: int = 0) -> date:
        return START_DATE + timedelta(days=7 * w + day)

    def tasks(self) -> list[dict[str, str]]:
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

        add("T-MOB", "Site mobilisation", self.week(0), self.week(0, 4), [], "")
        for k in range(1, self.n + 1):
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
                self.week(k),
                self.week(k, 4),
                ["T-MOB" if k == 1 else f"T-STR-L{k - 1:02d}"],
                structure,
            )
            add(
                f"T-ENV-{lvl}",
                f"Facade {st}",
                self.week(k + 1),
                self.week(k + 1, 4),
                [f"T-STR-{lvl}"],
                f"class=IfcWall;storey={st};name=Exterior wall*",
            )
            add(
                f"T-FRAME-{lvl}",
                f"Frame interior wood partitions {st}",
                self.week(k + 2),
                self.week(k + 3, 4),
                [f"T-ENV-{lvl}"],
                f"class=IfcMember;storey={st};name=Stud frame panel*",
                robotized=True,
            )
            add(
                f"T-INT-{lvl}",
                f"Interior partitions {st} (board, tape and finish)",
                self.week(k + 4),
                self.week(k + 5, 4),
                [f"T-FRAME-{lvl}"],
                f"class=IfcWall;storey={st};name=Partition*",
            )
            add(
                f"T-DOOR-{lvl}",
                f"Doors {st}",
                self.week(k + 6),
                self.week(k + 6, 4),
                [f"T-INT-{lvl}"],
                f"class=IfcDoor;storey={st}",
            )
        add(
            "T-ROOF",
            "Roof slab",
            self.week(self.n + 1),
            self.week(self.n + 1, 4),
            [f"T-STR-L{self.n:02d}"],
            "class=IfcSlab;storey=Roof;name=Roof slab",
        )
        rows.sort(key=lambda r: (r["start"], r["task_id"]))
        return rows

    def schedule_csv(self) -> str:
        buf = io.StringIO()
        cols = [
            "task_id",
            "name",
            "start",
            "finish",
            "predecessors",
            "elements",
            "robotized",
            "task_specification",
        ]
        w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
        w.writeheader()
        for r in self.tasks():
            w.writerow(r)
        return buf.getvalue()

    def project_toml(self, name: str, sim_date: str) -> str:
        return "\n".join(
            [
                f"# Generated by `kbplanner generate-building --storeys {self.n} --units-per-storey {self.m} "
                f"--seed {self.b.seed}`",
                "# (kbplanner.scale.building_generator): a test building for the scale benchmarks.",
                "# Do not edit by hand.",
                "",
                "[project]",
                f'name = "{name}"',
                f'description = "Generated residential building: {self.n} storeys x {self.m} units, '
                f"{len(self.b.panels)} prefabricated stud-frame panels installed by a robot, "
                'one framing task per storey."',
                f'base_iri = "{self.base}"',
                f"seed = {self.b.seed}",
                "",
                "[model]",
                'ifc = "model/building.ifc"',
                'schedule = "schedule.csv"',
                'site = ["site/site_layout.ttl", "site/workers.ttl"]',
                'jobsite = ["site/jobsite.ttl"]',
                'augmentation = ["augmentation/work_sequence.ttl"]',
                "",
                "[calendar]",
                'work_start = "07:00"',
                'work_end = "15:30"',
                'workdays = ["Mon", "Tue", "Wed", "Thu", "Fri"]',
                "",
                "[simulation]",
                'task = "T-FRAME-L01"',
                f'date = "{sim_date}"',
                "",
                f"[scenarios.{SCENARIO}]",
                'description = "A frame storage with a pickup location in the living room of every unit"',
                'overlays = ["scenarios/storage_in_units.ttl", "augmentation/grasp_points.ttl"]',
                "",
            ]
        )

    def site_layout(self) -> str:
        b, base = self.b, self.base
        L, Dc = b.length, b.depth
        entrance_y = UNIT_D + CORRIDOR_W / 2
        out = [
            _PREFIXES,
            "# Site layout of the generated building (site frame = IFC world frame, metres, radians).",
            "# The entrance door is in the west facade at the corridor; the robot starts 5 m west of it.",
            "# There is no frame storage here: the scenario adds one per unit (a modeling requirement).",
            "",
            f"<{base}site/layout> a kbp:SiteLayout ;",
            '    rdfs:label "Generated site layout" ;',
            f"    kbp:siteExtent <{base}site/layout-extent> ;",
            *(f"    kbp:robotArrival <{base}pose/robot-arrival-L{k + 1:02d}> ;" for k in range(1, self.n)),
            f"    kbp:robotStart <{base}pose/robot-start> .",
            f"<{base}site/layout-extent> a kbp:Box ;",
            '    rdfs:label "site boundary (building + 15 m)" ;',
            f"    kbp:minX {_num(-15.0)} ; kbp:minY {_num(-15.0)} ; kbp:minZ {_num(-2.0)} ;",
            f"    kbp:maxX {_num(L + 15.0)} ; kbp:maxY {_num(Dc + 15.0)} ; "
            f"kbp:maxZ {_num((self.n + 1) * STOREY_HEIGHT + 2.0)} .",
            *_pose_ttl(
                f"{base}pose/robot-start",
                -5.0,
                entrance_y,
                0.0,
                0.0,
                "robot start: 5 m west of the entrance, facing it",
            ),
        ]
        # Upper floors: the robot comes up in the lift and is set down in the lobby in front of the lift
        # door, facing west along the corridor.
        for k in range(1, self.n):
            out += _pose_ttl(f"{base}pose/robot-arrival-L{k + 1:02d}", L - 2.0, 4.5, k * STOREY_HEIGHT,
                             math.pi, f"robot arrival on Level {k + 1}: the lift lobby, facing the corridor")
        out.append("")
        out += _site_object(
            base, "office", "SiteOffice", "Site office", True, (6.0, 2.5, 2.7), -9.0, Dc + 9.0
        )
        out += _site_object(
            base,
            "lumber-storage",
            "MaterialStorage",
            "Lumber storage (carpenters)",
            True,
            (3.6, 1.4, 1.0),
            -9.0,
            -6.0,
        )
        out += _site_object(
            base, "entrance-area", "Workspace", "Entrance area", False, (2.0, 3.0, 2.0), -2.0, entrance_y
        )
        out += _site_object(base, "generator", "Equipment", "Generator", True, (2.2, 1.0, 1.3), L + 6.0, -6.0)
        return "\n".join(out)

    def workers(self) -> str:
        base = self.base
        out = [
            _PREFIXES,
            "# Workers of the generated site: a carpenter carrying lumber to the entrance (across the",
            "# robot's way in) and the site supervisor's round. Speeds m/s, dwell times s.",
            "",
        ]
        routes = [
            (
                "carpenter-1",
                "Carpenter 1",
                "carpenter",
                1.2,
                [("lumber-storage", 30.0), ("entrance-area", 60.0)],
            ),
            (
                "supervisor",
                "Site supervisor",
                "supervisor",
                1.0,
                [("office", 120.0), ("generator", 20.0), ("lumber-storage", 20.0)],
            ),
        ]
        for key, label, role, speed, stops in routes:
            iri = f"{base}worker/{key}"
            stop_iris = [f"<{iri}-stop-{i + 1}>" for i in range(len(stops))]
            out += [
                f"<{iri}> a kbp:Worker ;",
                f'    rdfs:label "{label}" ;',
                f'    kbp:role "{role}" ;',
                f"    kbp:walkingSpeed {_num(speed)} ;",
                f"    kbp:routeStop {' , '.join(stop_iris)} .",
            ]
            for i, (loc, dwell) in enumerate(stops):
                out += [
                    f"{stop_iris[i]} a kbp:RouteStop ;",
                    f"    kbp:order {i + 1} ; kbp:location <{base}site/{loc}> ; "
                    f"kbp:dwellTime {_num(dwell)} .",
                ]
            out.append("")
        return "\n".join(out)

    def jobsite(self) -> str:
        base = self.base
        return "\n".join(
            [
                _PREFIXES,
                "# Jobsite parameters (A5) of the generated site, as in the case study: a robot passes 0.9 m",
                "# doors with 0.1 m free on each side; speeds m/s, distances m, mass kg.",
                "",
                f"<{base}jobsite/params> a kbp:JobsiteParameters ;",
                '    rdfs:label "Generated jobsite parameters" ;',
                "    kbp:maxRobotWidth 0.9e0 ; kbp:maxRobotLength 1.4e0 ; kbp:maxRobotHeight 1.9e0 ;",
                "    kbp:maxRobotMass 150.0e0 ; kbp:maxSpeed 1.0e0 ; kbp:safetyStopDistance 0.5e0 ;",
                "    kbp:doorClearance 0.1e0 ;",
                f"    kbp:hasActionLimit <{base}jobsite/nv-1> , <{base}jobsite/nv-2> .",
                f'<{base}jobsite/nv-1> a kbp:ActionLimit ; rdfs:label "unloaded navigation" ;',
                "    kbp:appliesTo kb:NV-1 ; kbp:minSpeed 0.1e0 ; kbp:maxSpeed 0.8e0 .",
                f'<{base}jobsite/nv-2> a kbp:ActionLimit ; rdfs:label "navigation carrying a frame" ;',
                "    kbp:appliesTo kb:NV-2 ; kbp:minSpeed 0.05e0 ; kbp:maxSpeed 0.3e0 ;",
                "    kbp:safetyStopDistance 1.0e0 .",
                "",
            ]
        )

    def work_sequence(self) -> str:
        out = [
            _PREFIXES,
            "# Work sequence of each storey's framing task (T-FRAME-Lnn): unit by unit; in a unit the",
            "# bedroom partition P2 (east end first), then P1 from the facade northwards.",
            "",
        ]
        for p in sorted(self.b.panels, key=lambda p: (p.storey, p.sequence)):
            out.append(f"{self.element(p.global_id)} kbp:workSequence {p.sequence} .  # {p.panel_id}")
        return "\n".join(out) + "\n"

    def storage_key(self, storey: int, unit: int, stack: int) -> str:
        return f"frame-storage-L{storey:02d}-U{unit:02d}-S{stack}"

    def storages(self) -> str:
        base = self.base
        out = [
            _PREFIXES,
            f"# Scenario '{SCENARIO}': two frame storages (bearers {STORAGE_SIZE[0]} x {STORAGE_SIZE[1]} m)",
            "# in the living room of every unit, long sides north-south, each with the robot's pickup",
            f"# location {PICKUP_STANDOFF} m east of the stack's centre line facing west; the panels of a",
            f"# unit in install order, at most {MAX_STACK} per stack, kbp:storedIn a storage with",
            "# kbp:stackIndex (0 = bottom; the first installed lies on top).",
            "",
            f"<{base}scenario/{SCENARIO}> a kbp:Scenario ;",
            f'    kbp:scenarioName "{SCENARIO}" ;',
            '    rdfs:label "Frame storage in every unit" .',
            "",
        ]
        by_unit: dict[tuple[int, int], list[Panel]] = {}
        for p in self.b.panels:
            by_unit.setdefault((p.storey, p.unit), []).append(p)
        for (k, j), unit_panels in sorted(by_unit.items()):
            ordered = sorted(unit_panels, key=lambda p: p.unit_order)
            stacks = [ordered[i : i + MAX_STACK] for i in range(0, len(ordered), MAX_STACK)]
            if len(stacks) > len(STORAGE_YS):
                raise GeneratorError(
                    f"unit {j} of Level {k} has {len(ordered)} frames, more than "
                    f"{len(STORAGE_YS)} stacks of {MAX_STACK}",
                    element=f"L{k}-U{j}",
                    fix="use another seed",
                )
            for s_no, panels in enumerate(stacks, start=1):
                out += self._storage(k, j, s_no, panels)
        return "\n".join(out)

    def _storage(self, k: int, j: int, s_no: int, panels: list[Panel]) -> list[str]:
        base = self.base
        yaw = -math.pi / 2  # storage local x along -y; local +y (the pickup side) along +x
        key = self.storage_key(k, j, s_no)
        z = (k - 1) * STOREY_HEIGHT
        sx, sy = (j - 1) * UNIT_W + STORAGE_FROM_WEST, STORAGE_YS[s_no - 1]
        iri, pose, pickup = f"{base}site/{key}", f"{base}site/{key}-pose", f"{base}pose/{key}-pickup"
        out = [
            f"<{iri}> a kbp:MaterialStorage ;",
            f'    rdfs:label "Frame storage {s_no} Level {k} unit {j}" ;',
            "    kbp:obstructs true ;",
            f"    kbp:sizeX {_num(STORAGE_SIZE[0])} ; kbp:sizeY {_num(STORAGE_SIZE[1])} ; "
            f"kbp:sizeZ {_num(STORAGE_SIZE[2])} ;",
            f"    kbp:installedPose <{pose}> ;",
            f"    kbp:pickupLocation <{pickup}> .",
            *_pose_ttl(pose, sx, sy, z, yaw),
            *_pose_ttl(
                pickup,
                sx + PICKUP_STANDOFF,
                sy,
                z,
                -math.pi,
                f"robot pickup location: {PICKUP_STANDOFF} m from the middle of the stack, facing it",
            ),
        ]
        for i, p in enumerate(panels):
            out.append(
                f"{self.element(p.global_id)} kbp:storedIn <{iri}> ; "
                f"kbp:stackIndex {len(panels) - 1 - i} .  # {p.panel_id}"
            )
        out.append("")
        return out

    def grasp_points(self) -> str:
        base = self.base
        out = [
            _PREFIXES,
            "# Augmentation (MM-G-1 'pick frame'): a grasp point per panel, its centre of mass in the",
            "# panel's own frame (origin at the middle of the bottom plate on the wall axis, x along it).",
            "",
        ]
        for p in sorted(self.b.panels, key=lambda p: p.panel_id):
            x, y, z = p.centre_of_mass_local
            pose = f"{base}pose/{p.panel_id}-grasp"
            out += [
                f"{self.element(p.global_id)} kbp:graspPoint <{pose}> .",
                *_pose_ttl(pose, x, y, z, 0.0, f"grasp point of {p.panel_id} (local, centre of mass)"),
                "",
            ]
        return "\n".join(out)


def _check_args(storeys: int, units: int, seed: int) -> None:
    for name, value, top in (("--storeys", storeys, MAX_STOREYS), ("--units-per-storey", units, MAX_UNITS)):
        if not isinstance(value, int) or isinstance(value, bool) or not 1 <= value <= top:
            raise GeneratorError(
                f"{name} must be an integer from 1 to {top}, not {value!r}",
                element=name,
                fix=f"give e.g. {name} 2",
            )
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise GeneratorError(
            f"--seed must be a non-negative integer, not {seed!r}", element="--seed", fix="give e.g. --seed 7"
        )


def _check_out(out: Path, force: bool) -> None:
    """The output rule (:mod:`kbplanner.core.output_dirs`); ``force`` writes among files, keeping them."""
    with output_options(force=force):
        check_output_dir(out)


def generate_building(
    out_dir: Path, *, storeys: int, units_per_storey: int, seed: int = 0, force: bool = False
) -> GeneratedBuilding:
    """Write a generated building project into ``out_dir`` (see the module docstring).

    A directory written earlier by kbplanner is replaced; any other non-empty directory only with
    ``force``, which keeps the files in it (the output rule). The directory is assembled in
    ``OUT.partial`` and installed when complete.

    Raises:
        GeneratorError: sizes out of range, a negative seed, an unusable output directory.
    """
    t0 = time.perf_counter()
    _check_args(storeys, units_per_storey, seed)
    out = Path(out_dir)
    _check_out(out, force)
    builder = _Builder(storeys, units_per_storey, seed)
    f = builder.build()
    builder.ifc.finish("2024-03-01T00:00:00")
    name = f"Generated building {storeys}x{units_per_storey} seed {seed}"
    base = f"https://w3id.org/kbplanner/data/generated-{storeys}x{units_per_storey}-s{seed}/"
    files = _Files(builder, base)
    tasks = files.tasks()
    frame1 = next(t for t in tasks if t["task_id"] == "T-FRAME-L01")
    sim_date = f"{frame1['start']}T07:00:00"
    texts = {
        "project.toml": files.project_toml(name, sim_date),
        "schedule.csv": files.schedule_csv(),
        "site/site_layout.ttl": files.site_layout(),
        "site/workers.ttl": files.workers(),
        "site/jobsite.ttl": files.jobsite(),
        "augmentation/work_sequence.ttl": files.work_sequence(),
        "augmentation/grasp_points.ttl": files.grasp_points(),
        "scenarios/storage_in_units.ttl": files.storages(),
        ".gitignore": ".kbplanner-cache/\n",
    }
    with output_options(force=force), run_directory(out) as stage:
        (stage / "model").mkdir()
        f.write(str(stage / "model" / "building.ifc"))
        for rel, text in texts.items():
            path = stage / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
    counts: dict[str, int] = {}
    for p in f.by_type("IfcProduct"):
        counts[p.is_a()] = counts.get(p.is_a(), 0) + 1
    elements = sum(1 for p in f.by_type("IfcElement") if not p.is_a("IfcOpeningElement"))
    masses = [p.mass_kg for p in builder.panels]
    result = GeneratedBuilding(
        directory=out,
        ifc=out / "model" / "building.ifc",
        storeys=storeys,
        units_per_storey=units_per_storey,
        seed=seed,
        base_iri=base,
        counts=dict(sorted(counts.items())),
        elements=elements,
        frames=len(builder.panels),
        frames_per_storey=tuple(
            sum(1 for p in builder.panels if p.storey == k) for k in range(1, storeys + 1)
        ),
        frame_mass_kg=(min(masses), max(masses)),
        tasks=tuple(t["task_id"] for t in tasks),
        robotized_tasks=tuple(t["task_id"] for t in tasks if t["robotized"] == "true"),
        simulation_task="T-FRAME-L01",
        simulation_date=sim_date,
        scenario=SCENARIO,
        files=tuple(sorted(["model/building.ifc", *texts])),
        seconds=round(time.perf_counter() - t0, 3),
    )
    log.info("generated %s: %d elements, %d frames in %.1f s", out, elements, result.frames, result.seconds)
    return result


def remove_cache(project_dir: Path) -> None:
    """Delete a generated project's import cache (benchmarks time the import from scratch)."""
    shutil.rmtree(Path(project_dir) / ".kbplanner-cache", ignore_errors=True)
