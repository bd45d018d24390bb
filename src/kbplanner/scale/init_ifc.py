"""``kbplanner init`` (issue 10), step 2: the stud-frame panels written into a copy of the IFC model.

Each :class:`kbplanner.scale.init_walls.PanelSpot` becomes an ``IfcMember`` "Stud frame panel Fnnn"
(ObjectType "Interior stud frame panel", contained in the wall's storey) written with
``ifcopenshell.api`` into the opened copy of the user's file, never into the file itself: plates,
studs and noggings of :func:`kbplanner.model.stud_frames.stud_frame` as extruded rectangles in the
file's length unit, ``Pset_MemberCommon``, ``Kbplanner_StudFramePanel`` (host wall,
studs, density, mass, grasp point) and ``BaseQuantities`` with ``NetWeight`` in the file's mass unit,
so that the import reads the same kilograms. GlobalIds are uuid5 of the host wall and panel number;
the file's own owner history and time stamp are reused, so the same input gives the same file.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass
from typing import Any

import ifcopenshell
import ifcopenshell.api.context
import ifcopenshell.api.geometry
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.guid
import numpy as np

from kbplanner.model.stud_frames import DENSITY, STUD_DEPTH, stud_frame
from kbplanner.scale.building_ifc import matrix
from kbplanner.scale.init_walls import PanelSpot

_GUID_NS = uuid.UUID("4d1f0c8e-2b7a-5e39-8c1d-6b696e697430")  # kbplanner init


@dataclass(frozen=True)
class FrameRecord:
    """One panel written into the IFC copy (metres, radians, kilograms; site frame)."""

    panel_id: str
    global_id: str
    spot: PanelSpot
    storey: str  # storey name
    sequence: int
    studs: int
    mass_kg: float
    centre_of_mass_local: tuple[float, float, float]


def guid(key: str) -> str:
    """A deterministic GlobalId without '$' (awkward in shells and IRIs)."""
    salt = 0
    while True:
        g = str(ifcopenshell.guid.compress(uuid.uuid5(_GUID_NS, f"{key}#{salt}").hex))
        if "$" not in g:
            return g
        salt += 1


def body_context(f: ifcopenshell.file) -> Any:
    """The file's Body (sub)context, else its Model context, else a new Body context."""
    subs = [c for c in f.by_type("IfcGeometricRepresentationSubContext") if c.ContextIdentifier == "Body"]
    if subs:
        return sorted(subs, key=lambda c: c.id())[0]
    models = [
        c
        for c in f.by_type("IfcGeometricRepresentationContext")
        if not c.is_a("IfcGeometricRepresentationSubContext") and c.ContextType == "Model"
    ]
    if models:
        return sorted(models, key=lambda c: c.id())[0]
    model = ifcopenshell.api.context.add_context(f, context_type="Model")
    return ifcopenshell.api.context.add_context(
        f, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model
    )


def _boxes(f: ifcopenshell.file, context: Any, spot: PanelSpot, unit: float) -> Any:
    """The panel's pieces as extruded rectangles, in file units (``unit``: metres per file unit)."""
    z_dir = f.createIfcDirection((0.0, 0.0, 1.0))
    x_dir = f.createIfcDirection((1.0, 0.0, 0.0))
    solids = []
    for p in stud_frame(spot.length, spot.height).pieces:
        centre = f.createIfcCartesianPoint((round((p.x_min + p.x_max) / 2 / unit, 6), 0.0))
        profile = f.createIfcRectangleProfileDef(
            "AREA",
            None,
            f.createIfcAxis2Placement2D(centre, None),
            round((p.x_max - p.x_min) / unit, 6),
            round(STUD_DEPTH / unit, 6),
        )
        position = f.createIfcAxis2Placement3D(
            f.createIfcCartesianPoint((0.0, 0.0, round(p.z_min / unit, 6))), z_dir, x_dir
        )
        solids.append(
            f.createIfcExtrudedAreaSolid(profile, position, z_dir, round((p.z_max - p.z_min) / unit, 6))
        )
    return f.createIfcShapeRepresentation(context, "Body", "SweptSolid", solids)


def write_frames(
    f: ifcopenshell.file,
    spots: list[tuple[PanelSpot, Any]],
    *,
    site: np.ndarray,
    length_m: float,
    mass_kg: float,
) -> list[FrameRecord]:
    """Write one ``IfcMember`` per (spot, storey entity), in the given (install) order.

    ``site``: the import's model frame in metres (site frame -> IFC world; ``model_frame``);
    ``length_m`` and ``mass_kg``: metres per file length unit and kilograms per file mass unit.
    """
    first_new = max((e.id() for e in f), default=0) + 1
    histories = sorted(f.by_type("IfcOwnerHistory"), key=lambda e: e.id())
    history = histories[0] if histories else None
    saved = {h.id(): [h[i] for i in range(len(h))] for h in histories}  # the API time-stamps them
    context = body_context(f)
    records = []
    for n, (spot, storey) in enumerate(spots, start=1):
        pid = f"F{n:03d}"
        frame = stud_frame(spot.length, spot.height)
        mass = round(frame.mass_kg(DENSITY), 2)
        com_x, _, com_z = frame.centre_of_mass_local
        m = ifcopenshell.api.root.create_entity(f, ifc_class="IfcMember", name=f"Stud frame panel {pid}")
        m.GlobalId = guid(f"{spot.wall}/{spot.index}")
        m.ObjectType = "Interior stud frame panel"
        m.Tag = pid
        m.Description = (
            f"Prefabricated wood stud frame {spot.length:.3f} x {spot.height:.2f} m, "
            f"{frame.studs} studs 38x89 mm SPF, {mass:.1f} kg"
        )
        ifcopenshell.api.spatial.assign_container(f, products=[m], relating_structure=storey)
        world = site @ matrix(spot.x, spot.y, spot.z, spot.yaw)
        ifcopenshell.api.geometry.edit_object_placement(f, product=m, matrix=world, is_si=True)
        ifcopenshell.api.geometry.assign_representation(
            f, product=m, representation=_boxes(f, context, spot, length_m)
        )
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
                "HostWallGlobalId": spot.wall,
                "StudCount": frame.studs,
                "StudSection": "38 x 89 mm",
                "AssumedDensity": DENSITY,
                "MassKg": float(mass),
                "GraspPointX": round(com_x, 6) + 0.0,
                "GraspPointY": 0.0,
                "GraspPointZ": round(com_z, 6),
            },
        )
        qto = ifcopenshell.api.pset.add_qto(f, product=m, name="BaseQuantities")
        ifcopenshell.api.pset.edit_qto(
            f,
            qto=qto,
            properties={
                "Length": round(spot.length / length_m, 6),
                "Height": round(spot.height / length_m, 6),
                "Width": round(STUD_DEPTH / length_m, 6),
                "NetVolume": round(frame.volume_m3 / length_m**3, 9),
                "NetWeight": round(mass / mass_kg, 6),
            },
        )
        records.append(
            FrameRecord(
                pid,
                str(m.GlobalId),
                spot,
                str(storey.Name or storey.GlobalId),
                n,
                frame.studs,
                mass,
                (round(com_x, 6) + 0.0, 0.0, round(com_z, 6)),
            )
        )
    _deterministic(f, first_new, history)
    for h in f.by_type("IfcOwnerHistory"):
        for i, value in enumerate(saved.get(h.id(), [])):
            h[i] = value
    return records


def _deterministic(f: ifcopenshell.file, first_new: int, history: Any) -> None:
    """The owner history of the file on every new entity (the API's new ones removed), stable GlobalIds."""
    new_histories = [e for e in f.by_type("IfcOwnerHistory") if e.id() >= first_new]
    fresh = {h.id() for h in new_histories}
    keep = history if f.schema == "IFC2X3" else None
    for e in sorted(f.by_type("IfcRoot"), key=lambda e: e.id()):
        # new entities, and old ones the API marked MODIFIED with a new, time-stamped history
        if e.id() >= first_new or (e.OwnerHistory is not None and e.OwnerHistory.id() in fresh):
            e.OwnerHistory = keep if e.id() >= first_new else history
        if e.id() >= first_new and not e.is_a("IfcMember"):
            e.GlobalId = guid(f"{e.is_a()}/{e.id()}")
    for h in new_histories:
        if not f.get_inverse(h):
            f.remove(h)
    for rel in f.by_type("IfcRelationship"):  # the API keeps related objects as sets: a stable order
        for attr in ("RelatedObjects", "RelatedElements"):
            items = getattr(rel, attr, None)
            if isinstance(items, tuple) and len(items) > 1 and max(e.id() for e in items) >= first_new:
                setattr(rel, attr, sorted(items, key=lambda e: e.id()))
