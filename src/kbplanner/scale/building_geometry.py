"""Test buildings (scale, issue 6), step 3: the geometry of the generated building, in IFC.

:class:`Builder` writes the building with :class:`kbplanner.scale.building_ifc.Ifc`: site, building,
storeys and roof; per storey the facades, the corridor and lobby, the core (lift shaft, lift door,
stair) and the units (facade, party and corridor walls, partitions, doors, spaces, slab); and the
robotized framing task's stud-frame panels on the partition axes, cut between the door openings, in
install order, each recorded as a :class:`kbplanner.scale.building_plan.Panel`.
"""

from __future__ import annotations

import math
from typing import Any

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.pset

from kbplanner.model.stud_frames import DENSITY, MATERIAL, PANEL_HEIGHT, STUD_DEPTH, stud_frame
from kbplanner.scale.building_ifc import Ifc, matrix
from kbplanner.scale.building_plan import (
    CORE_W,
    CORRIDOR_W,
    DOOR_W,
    ENTRANCE_W,
    EXT_T,
    MAX_PANEL_LENGTH,
    PARTITION_T,
    PARTY_T,
    STOREY_HEIGHT,
    UNIT_D,
    UNIT_DOOR_W,
    UNIT_W,
    Panel,
    segments,
    unit_plans,
)


class Builder:
    """Writes the building of ``storeys`` x ``units`` with ``seed`` into an IFC4 file; keeps its panels."""

    def __init__(self, storeys: int, units: int, seed: int) -> None:
        self.n, self.m, self.seed = storeys, units, seed
        self.ifc = Ifc(f"{storeys}x{units}/seed{seed}")
        self.plans = unit_plans(storeys, units, seed)
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
        ifc.place(site, matrix(0.0, 0.0, 0.0))
        building = ifc.create("IfcBuilding", f"Generated residential building {self.n}x{self.m}", "building")
        ifcopenshell.api.aggregate.assign_object(f, products=[site], relating_object=ifc.project)
        ifcopenshell.api.aggregate.assign_object(f, products=[building], relating_object=site)
        ifc.place(building, matrix(0.0, 0.0, 0.0))
        self.wood = ifcopenshell.api.material.add_material(f, name=MATERIAL)
        storeys = []
        for k in range(self.n + 1):
            name = f"Level {k + 1}" if k < self.n else "Roof"
            st = ifc.create("IfcBuildingStorey", name, f"storey/{k}")
            st.Elevation = k * STOREY_HEIGHT
            storeys.append(st)
        ifcopenshell.api.aggregate.assign_object(f, products=storeys, relating_object=building)
        for k, st in enumerate(storeys):
            ifc.place(st, matrix(0.0, 0.0, k * STOREY_HEIGHT))
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
        ifc.place(stair, matrix(mw + 0.4, 0.6, z))
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
            (p2, p2_start, math.pi, segments(p2_len, [])),
            (
                p1,
                p1_start,
                math.pi / 2,
                segments(p1_len, [(plan.door_s, plan.door_s + DOOR_W), (plan.door_n, plan.door_n + DOOR_W)]),
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
        ifc.place(m, matrix(round(x, 4), round(y, 4), z, yaw))
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
