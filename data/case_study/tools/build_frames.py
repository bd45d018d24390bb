"""Case study data (4D model, issue 2): add the 11 prefabricated stud-frame panels to the Duplex.

Takes ``model/Duplex_A_20110907.ifc`` (buildingSMART Duplex, IFC2X3, metres) and writes

- ``model/Duplex_A_frames.ifc``: the Duplex plus 11 ``IfcMember`` panels "Stud frame panel F01".."F11"
  (ObjectType "Interior stud frame panel", material "Wood - SPF", contained in Level 1), each with
  real geometry: 38 x 89 mm studs at <= 600 mm centres, bottom and top plates and one row of
  mid-height noggings, all as extruded rectangles (``kbplanner.model.stud_frames``, the same panels as the
  building generator's);
- ``augmentation/grasp_points.ttl``: a local grasp point for every panel (its centre of mass);
- ``model/frames.json``: the panel table (id, GlobalId, host wall, pose, size, studs, volume, mass).

Which walls: the Level-1 "Interior - Partition (92mm Stud)" walls of unit A (the southern unit, spaces
A101-A105) that stand on the floor (Pset_WallCommon.IsExternal = false). Their free lengths (axis
minus door openings) are cut into panels; the segment whose panels are longest is split again until
there are 11 panels (the paper installed 11 frames), which keeps every panel as short as possible.

Run once from the repository root; the output is deterministic (GlobalIds are uuid5 of stable names,
the header time stamp is fixed) and checked in::

    .venv/bin/python data/case_study/tools/build_frames.py
"""

from __future__ import annotations

import json
import math
import uuid
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import ifcopenshell
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.geom
import ifcopenshell.guid
import ifcopenshell.util.element
import ifcopenshell.util.placement
import numpy as np

from kbplanner.model.stud_frames import (
    DENSITY,
    MATERIAL,
    MAX_STUD_SPACING,
    PANEL_HEIGHT,
    STUD_DEPTH,
    STUD_WIDTH,
    Piece,
    stud_frame,
)

HERE = Path(__file__).resolve().parent
PROJECT = HERE.parent
SOURCE_IFC = PROJECT / "model" / "Duplex_A_20110907.ifc"
OUT_IFC = Path("model") / "Duplex_A_frames.ifc"          # outputs, relative to the output directory
OUT_JSON = Path("model") / "frames.json"
OUT_GRASP = Path("augmentation") / "grasp_points.ttl"
BASE_IRI = "https://w3id.org/kbplanner/data/duplex/"

N_PANELS = 11
# Panel height, stud section and spacing, density, material: kbplanner.model.stud_frames
UNIT_SPACE_PREFIX = "A1"    # Level-1 spaces of unit A
WALL_NAME = "Interior - Partition (92mm Stud)"
STOREY = "Level 1"
TIME_STAMP = "2022-05-01T00:00:00"
GUID_NAMESPACE = uuid.UUID("6f6c2a52-4a35-5b0e-9d3c-6b62706c616e")  # fixed namespace of this tool


@dataclass
class Panel:
    """A frame panel and where it goes."""

    panel_id: str
    global_id: str
    host_wall: str
    install_order: int
    x: float
    y: float
    z: float
    yaw: float
    length: float
    height: float
    thickness: float
    studs: int
    stud_spacing: float
    volume_m3: float
    mass_kg: float
    centre_of_mass_local: tuple[float, float, float]


def deterministic_guid(name: str) -> str:
    """An IFC GlobalId from a stable name; avoids '$' (awkward in IRIs and shells) by re-salting."""
    salt = 0
    while True:
        gid = ifcopenshell.guid.compress(uuid.uuid5(GUID_NAMESPACE, f"{name}#{salt}" if salt else name).hex)
        if "$" not in gid:
            return gid
        salt += 1


def world_shape_vertices(settings: Any, product: Any) -> np.ndarray:
    shape = ifcopenshell.geom.create_shape(settings, product)
    return np.array(shape.geometry.verts, dtype=float).reshape(-1, 3)


def unit_a_partitions(f: Any, settings: Any) -> list[dict[str, Any]]:
    """The unit-A Level-1 floor-standing 92 mm stud partitions with their axis and free segments."""
    storey = next(s for s in f.by_type("IfcBuildingStorey") if s.Name == STOREY)
    spaces = []
    for s in f.by_type("IfcSpace"):
        if s.Name.startswith(UNIT_SPACE_PREFIX):
            v = world_shape_vertices(settings, s)
            spaces.append((v.min(axis=0), v.max(axis=0)))
    walls = []
    for w in sorted(f.by_type("IfcWall"), key=lambda e: e.GlobalId):
        if ifcopenshell.util.element.get_container(w) != storey or WALL_NAME not in (w.Name or ""):
            continue
        if ifcopenshell.util.element.get_psets(w).get("Pset_WallCommon", {}).get("IsExternal") is not False:
            continue
        v = world_shape_vertices(settings, w)
        lo, hi = v.min(axis=0), v.max(axis=0)
        if lo[2] > storey.Elevation + 0.01 or hi[2] - lo[2] < PANEL_HEIGHT:
            continue  # bulkheads above the ceiling, not floor-standing partitions
        near = [np.all(lo[:2] - 0.2 <= b[:2]) and np.all(a[:2] <= hi[:2] + 0.2) for a, b in spaces]
        if not any(near):
            continue  # unit B
        m = ifcopenshell.util.placement.get_local_placement(w.ObjectPlacement)
        axis_rep = next(r for r in w.Representation.Representations if r.RepresentationIdentifier == "Axis")
        pts = [np.array(p.Coordinates[:2], dtype=float) for p in axis_rep.Items[0].Points]
        origin = m[:3, 3] + m[:3, 0] * pts[0][0] + m[:3, 1] * pts[0][1]
        direction = m[:3, 0] / np.linalg.norm(m[:3, 0])
        length = float(np.linalg.norm(pts[-1] - pts[0]))
        # The axis lies on the wall's centre line: check against the body geometry.
        across = np.cross([0.0, 0.0, 1.0], direction)
        offsets = (v - origin) @ across
        assert abs((offsets.min() + offsets.max()) / 2) < 0.005, w.GlobalId
        cuts = []
        for rel in w.HasOpenings:
            ov = world_shape_vertices(settings, rel.RelatedOpeningElement)
            s = (ov - origin) @ direction
            if ov[:, 2].min() < PANEL_HEIGHT:
                cuts.append((max(0.0, float(s.min())), min(length, float(s.max()))))
        segments, start = [], 0.0
        for a, b in sorted(cuts):
            if a > start:
                segments.append((start, a))
            start = max(start, b)
        if start < length:
            segments.append((start, length))
        walls.append({"wall": w, "origin": origin, "direction": direction, "length": length,
                      "segments": segments})
    return walls


def split_segments(walls: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Segments with a panel count each: split the segment with the longest panels until N_PANELS."""
    segs = [{"wall": w, "start": a, "end": b, "count": 1} for w in walls for a, b in w["segments"]]
    while sum(s["count"] for s in segs) < N_PANELS:
        longest = max(segs, key=lambda s: ((s["end"] - s["start"]) / s["count"], -segs.index(s)))
        longest["count"] += 1
    return segs


# Install order (F01 first): the bathroom-side segments of the foyer wall before the wall that closes
# the bathroom off from the kitchen, then the living-room wall from the kitchen end to the facade, so
# no panel already installed blocks the way to the next one. Keys: (wall GlobalId, segment index).
INSTALL_ORDER: list[tuple[str, int, bool]] = [
    # (wall, segment index along the wall axis, panels in reverse axis order)
    ("2O2Fr$t4X7Zf8NOew3FKST", 1, True),   # foyer/bathroom wall, north of the bathroom door
    ("2O2Fr$t4X7Zf8NOew3FKST", 0, True),   # foyer/bathroom+kitchen wall, south of the door
    ("2O2Fr$t4X7Zf8NOew3FKIu", 0, True),   # bathroom/kitchen wall, from the foyer wall westwards
    ("2O2Fr$t4X7Zf8NOew3FKGS", 0, False),  # living room/foyer wall, from the kitchen to the facade
]


def build_panels(walls: list[dict[str, Any]]) -> list[tuple[Panel, list[Piece]]]:
    segs = split_segments(walls)
    by_key = {}
    for w in walls:
        gid = w["wall"].GlobalId
        for i, _ in enumerate(w["segments"]):
            by_key[(gid, i)] = next(s for s in segs if s["wall"] is w and s["start"] == w["segments"][i][0])
    assert sorted(by_key) == sorted((g, i) for g, i, _ in INSTALL_ORDER), sorted(by_key)
    out: list[tuple[Panel, list[Piece]]] = []
    for gid, i, reverse in INSTALL_ORDER:
        seg = by_key[(gid, i)]
        w = seg["wall"]
        n = seg["count"]
        length = (seg["end"] - seg["start"]) / n
        order = range(n - 1, -1, -1) if reverse else range(n)
        for k in order:
            number = len(out) + 1
            pid = f"F{number:02d}"
            centre_s = seg["start"] + (k + 0.5) * length
            c = w["origin"] + w["direction"] * centre_s
            frame = stud_frame(length, PANEL_HEIGHT)
            vol, studs = frame.volume_m3, frame.studs
            com_x, _, com_z = frame.centre_of_mass_local
            panel = Panel(
                panel_id=pid,
                global_id=deterministic_guid(f"{BASE_IRI}frame/{pid}"),
                host_wall=gid,
                install_order=number,
                x=round(float(c[0]), 4),
                y=round(float(c[1]), 4),
                z=round(float(c[2]), 4),
                yaw=math.atan2(float(w["direction"][1]), float(w["direction"][0])),
                length=round(length, 4),
                height=PANEL_HEIGHT,
                thickness=STUD_DEPTH,
                studs=studs,
                stud_spacing=round(frame.stud_spacing, 4),
                volume_m3=round(vol, 6),
                mass_kg=round(vol * DENSITY, 2),
                centre_of_mass_local=(round(com_x, 6) + 0.0, 0.0, round(com_z, 6)),
            )
            out.append((panel, list(frame.pieces)))
    return out


def add_panels(f: Any, panels: list[tuple[Panel, list[Piece]]]) -> None:
    storey = next(s for s in f.by_type("IfcBuildingStorey") if s.Name == STOREY)
    context = next(c for c in f.by_type("IfcGeometricRepresentationContext", include_subtypes=False)
                   if c.ContextType == "Model")
    material = ifcopenshell.api.material.add_material(f, name=MATERIAL)
    containment = storey.ContainsElements[0]
    contained_before = list(containment.RelatedElements)
    z_dir = f.createIfcDirection((0.0, 0.0, 1.0))
    x_dir = f.createIfcDirection((1.0, 0.0, 0.0))
    products = []
    for panel, pieces in panels:
        m = ifcopenshell.api.root.create_entity(f, ifc_class="IfcMember",
                                                name=f"Stud frame panel {panel.panel_id}")
        m.GlobalId = panel.global_id
        m.ObjectType = "Interior stud frame panel"
        m.Tag = panel.panel_id
        m.Description = (f"Prefabricated wood stud frame {panel.length:.3f} x {panel.height:.2f} m, "
                         f"{panel.studs} studs 38x89 mm SPF, {panel.mass_kg:.1f} kg")
        ifcopenshell.api.spatial.assign_container(f, products=[m], relating_structure=storey)
        c, s = (round(v, 12) + 0.0 for v in (math.cos(panel.yaw), math.sin(panel.yaw)))
        matrix = np.array([[c, -s, 0.0, panel.x], [s, c, 0.0, panel.y], [0.0, 0.0, 1.0, panel.z],
                           [0.0, 0.0, 0.0, 1.0]])
        ifcopenshell.api.geometry.edit_object_placement(f, product=m, matrix=matrix, is_si=True)
        items = []
        for p in pieces:
            profile = f.createIfcRectangleProfileDef(
                "AREA", p.kind, f.createIfcAxis2Placement2D(
                    f.createIfcCartesianPoint(((p.x_min + p.x_max) / 2, 0.0)), None),
                p.x_max - p.x_min, STUD_DEPTH)
            origin = f.createIfcCartesianPoint((0.0, 0.0, p.z_min))
            position = f.createIfcAxis2Placement3D(origin, z_dir, x_dir)
            items.append(f.createIfcExtrudedAreaSolid(profile, position, z_dir, p.z_max - p.z_min))
        rep = f.createIfcShapeRepresentation(context, "Body", "SweptSolid", items)
        ifcopenshell.api.geometry.assign_representation(f, product=m, representation=rep)
        pset = ifcopenshell.api.pset.add_pset(f, product=m, name="Pset_MemberCommon")
        ifcopenshell.api.pset.edit_pset(f, pset=pset, properties={
            "Reference": panel.panel_id, "IsExternal": False, "LoadBearing": False})
        pset = ifcopenshell.api.pset.add_pset(f, product=m, name="Kbplanner_StudFramePanel")
        ifcopenshell.api.pset.edit_pset(f, pset=pset, properties={
            "PanelId": panel.panel_id,
            "HostWallGlobalId": panel.host_wall,
            "InstallOrder": panel.install_order,
            "StudCount": panel.studs,
            "StudSection": "38 x 89 mm",
            "StudSpacing": float(panel.stud_spacing),
            "AssumedDensity": DENSITY,
            "Mass": float(panel.mass_kg),
        })
        qto = ifcopenshell.api.pset.add_qto(f, product=m, name="BaseQuantities")
        ifcopenshell.api.pset.edit_qto(f, qto=qto, properties={
            "Length": float(panel.length), "Height": float(panel.height), "Width": float(panel.thickness),
            "NetVolume": float(panel.volume_m3), "NetWeight": float(panel.mass_kg)})
        products.append(m)
    ifcopenshell.api.material.assign_material(f, products=products, type="IfcMaterial", material=material)
    # The API keeps relations as sets; write a stable order: the source's order, then F01..F11.
    assert storey.ContainsElements == (containment,)
    containment.RelatedElements = contained_before + sorted(products, key=lambda e: e.Tag)
    for rel in f.get_inverse(material):
        if rel.is_a("IfcRelAssociatesMaterial"):
            rel.RelatedObjects = sorted(rel.RelatedObjects, key=lambda e: e.Tag)


def make_deterministic(f: Any, before: set[int], owner_history: Any) -> None:
    """Stable GlobalIds and the source's owner history on everything this tool created."""
    for e in f.by_type("IfcRoot"):
        if e.OwnerHistory is not None and e.OwnerHistory.id() not in before:
            e.OwnerHistory = owner_history  # also relations the API edited, e.g. Level 1 containment
    created = sorted((e for e in f.by_type("IfcRoot") if e.id() not in before), key=lambda e: e.id())
    for e in created:
        if not e.is_a("IfcMember"):
            e.GlobalId = deterministic_guid(f"{BASE_IRI}frames-build/{e.is_a()}/{e.id()}")
    for oh in f.by_type("IfcOwnerHistory"):
        if oh.id() not in before and not f.get_inverse(oh):
            f.remove(oh)
    f.header.file_name.time_stamp = TIME_STAMP
    f.header.file_name.originating_system = "kbplanner data/case_study/tools/build_frames.py (ifcopenshell)"


def grasp_turtle(panels: list[Panel]) -> str:
    from urllib.parse import quote

    lines = [
        "@prefix kbp:  <https://w3id.org/kbplanner/ontology#> .",
        "@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .",
        "@prefix xsd:  <http://www.w3.org/2001/XMLSchema#> .",
        "",
        "# Augmentation (paper A4, MM-G-1 'pick frame'): where the gripper holds each frame panel.",
        "# A kbp:graspPoint is a pose in the frame's own coordinates (origin at the middle of the bottom",
        "# plate on the wall axis, x along the panel, y across it, z up), metres and radians. It is the",
        "# panel's centre of mass, on the centre stud or the mid-height nogging, so a lifted panel hangs",
        "# level.",
        "# Generated by tools/build_frames.py; do not edit by hand.",
        "",
    ]
    for p in panels:
        iri = f"<{BASE_IRI}element/{quote(p.global_id, safe='')}>"
        pose = f"<{BASE_IRI}pose/{p.panel_id}-grasp>"
        x, y, z = p.centre_of_mass_local
        lines += [
            f"{iri} kbp:graspPoint {pose} .",
            f"{pose} a kbp:Pose ;",
            f'    rdfs:label "grasp point of stud frame panel {p.panel_id} (local, centre of mass)" ;',
            f"    kbp:x {x:.4f}e0 ; kbp:y {y:.4f}e0 ; kbp:z {z:.4f}e0 ;",
            "    kbp:roll 0.0e0 ; kbp:pitch 0.0e0 ; kbp:yaw 0.0e0 .",
            "",
        ]
    return "\n".join(lines)


def main(out_dir: Path = PROJECT) -> list[Panel]:
    """Build everything into ``out_dir`` (the project directory unless a test asks for another)."""
    for rel in (OUT_IFC, OUT_JSON, OUT_GRASP):
        (out_dir / rel).parent.mkdir(parents=True, exist_ok=True)
    f = ifcopenshell.open(str(SOURCE_IFC))
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    walls = unit_a_partitions(f, settings)
    assert len(walls) == 3, [w["wall"].GlobalId for w in walls]
    panels = build_panels(walls)
    before = {e.id() for e in f}
    owner_history = f.by_type("IfcOwnerHistory")[0]
    add_panels(f, panels)
    make_deterministic(f, before, owner_history)
    f.write(str(out_dir / OUT_IFC))
    plain = [p for p, _ in panels]
    (out_dir / OUT_JSON).write_text(json.dumps({
        "source": SOURCE_IFC.name,
        "panel_height_m": PANEL_HEIGHT,
        "stud_section_m": [STUD_WIDTH, STUD_DEPTH],
        "max_stud_spacing_m": MAX_STUD_SPACING,
        "density_kg_m3": DENSITY,
        "total_mass_kg": round(sum(p.mass_kg for p in plain), 2),
        "panels": [asdict(p) for p in plain],
    }, indent=2) + "\n", encoding="utf-8")
    (out_dir / OUT_GRASP).write_text(grasp_turtle(plain), encoding="utf-8")
    return plain


def report(plain: list[Panel]) -> None:
    for p in plain:
        print(f"{p.panel_id} {p.global_id} wall {p.host_wall} ({p.x:.3f}, {p.y:.3f}) yaw {p.yaw:+.4f} "
              f"L {p.length:.3f} studs {p.studs} @ {p.stud_spacing:.3f}  {p.volume_m3:.5f} m3  "
              f"{p.mass_kg:.2f} kg")
    print(f"total {sum(p.mass_kg for p in plain):.2f} kg -> {OUT_IFC}")


if __name__ == "__main__":
    report(main())
