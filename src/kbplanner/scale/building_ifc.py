"""Test buildings (scale, issue 6), step 2: the IFC writer of the generated building.

:class:`Ifc` wraps the ``ifcopenshell.api`` calls that the geometry
(:mod:`kbplanner.scale.building_geometry`) needs: walls with their body, doors filling openings that
void their host wall, slabs, spaces, extruded boxes and the stair solid, all in metres, with
deterministic GlobalIds (uuid5 of a stable key and the seed) and, in :meth:`Ifc.finish`, no owner
histories, sorted relations and a fixed time stamp, so that the same arguments give a byte-identical
file.
"""

from __future__ import annotations

import math
import uuid
from typing import Any

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.unit
import ifcopenshell.guid
import numpy as np

from kbplanner.scale.building_plan import DOOR_H, SLAB_T, WALL_HEIGHT

_GUID_NS = uuid.UUID("0c1b5c2e-8f7a-5d43-9a6e-6b62706c6765")  # fixed namespace of this generator


def matrix(x: float, y: float, z: float, yaw: float = 0.0) -> np.ndarray:
    m = np.eye(4)
    c, s = (round(v, 12) + 0.0 for v in (math.cos(yaw), math.sin(yaw)))
    m[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    m[:3, 3] = [x, y, z]
    return m


class Ifc:
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
        self.place(w, matrix(start[0], start[1], z, yaw))
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
        base = matrix(start[0], start[1], z, yaw)
        centre_offset = -thickness / 2 if centred else 0.0
        opening = self.create("IfcOpeningElement", f"Opening {name}", f"{key}/opening", "OPENING")
        self.place(opening, base @ matrix(along, centre_offset - 0.05, 0.0))
        rep = ifcopenshell.api.geometry.add_wall_representation(
            f, context=self.body, length=width, height=DOOR_H, thickness=thickness + 0.1
        )
        ifcopenshell.api.geometry.assign_representation(f, product=opening, representation=rep)
        ifcopenshell.api.feature.add_feature(f, feature=opening, element=wall)
        door = self.create("IfcDoor", name, key, predefined_type="DOOR")
        self.contain(door, storey)
        self.place(door, base @ matrix(along, centre_offset, 0.0))
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
        self.place(s, matrix(0.0, 0.0, top_z - SLAB_T))
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
        self.place(sp, matrix(0.0, 0.0, z))
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
