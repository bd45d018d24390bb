"""Case study data (issue 12): gypsum boards on the installed frames of the living-room wall.

The second robotized task of the case study, board installation (knowledge base: ``B-I-#1`` in
``ontology/kb/board_installation.ttl``). Takes ``model/Duplex_A_frames.ifc`` as ``build_frames.py``
wrote it and ``model/frames.json``, and writes

- ``model/Duplex_A_frames.ifc`` again, plus 5 ``IfcPlate`` "Gypsum board B01".."B05" (ObjectType
  "Gypsum wall board", material "Gypsum board", contained in Level 1): one 12.5 mm board per frame
  panel F07-F11 of the living room / foyer wall ``2O2Fr$t4X7Zf8NOew3FKGS``, as long as its panel and
  2.40 m high, standing against the panel's living-room face (2 mm off it); a 12.5 mm gypsum board
  weighs 8.5 kg/m2 (EN 520 type A), so each is 14.62 kg (Qto NetWeight);
- ``model/boards.json``: the board table (id, GlobalId, frame, pose, size, mass);
- ``augmentation/boards.ttl``: each board's grasp point (its centre, local (0, 0, 1.2)) and its
  ``kbp:workSequence`` (B01 at the kitchen end first, like the panels);
- ``scenarios/boards_outside.ttl`` and ``scenarios/boards_inside.ttl``: the boards stacked on the
  scenario's material storage (``kbp:storedIn``, ``kbp:stackIndex``; B01 on top). The storage holds
  the frames until T-FRAME ends (23 May) and the boards from T-BOARD's start (24 May): in each task's
  world only that task's elements lie on it.

Run after ``build_frames.py`` from the repository root; the output is deterministic and checked in::

    .venv/bin/python data/case_study/tools/build_frames.py
    .venv/bin/python data/case_study/tools/build_boards.py
    .venv/bin/python data/case_study/tools/build_scenarios.py
"""

from __future__ import annotations

import json
import math
import uuid
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any
from urllib.parse import quote

import ifcopenshell
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.geom
import ifcopenshell.guid
import numpy as np

HERE = Path(__file__).resolve().parent
PROJECT = HERE.parent
IFC = Path("model") / "Duplex_A_frames.ifc"    # read and rewritten, relative to the output directory
FRAMES = Path("model") / "frames.json"
OUT_JSON = Path("model") / "boards.json"
OUT_AUGMENT = Path("augmentation") / "boards.ttl"
OUT_SCENARIOS = {"storage-outside": (Path("scenarios") / "boards_outside.ttl", "frame-storage-outside"),
                 "storage-inside": (Path("scenarios") / "boards_inside.ttl", "frame-storage-inside")}
BASE_IRI = "https://w3id.org/kbplanner/data/duplex/"

WALL = "2O2Fr$t4X7Zf8NOew3FKGS"   # living room A102 / foyer A101
ROOM = "A102"                     # the side the boards go on
STOREY = "Level 1"
THICKNESS = 0.0125                # m, EN 520 type A
AREA_MASS = 8.5                   # kg/m2
GAP = 0.002                       # m between the panel's face and the board
MATERIAL = "Gypsum board"
GUID_NAMESPACE = uuid.UUID("0b6f5d1e-7a43-5c52-8d1b-626f61726473")  # fixed namespace of this tool


@dataclass
class Board:
    """A gypsum board and where it goes."""

    board_id: str
    global_id: str
    frame: str
    install_order: int
    x: float
    y: float
    z: float
    yaw: float
    length: float
    height: float
    thickness: float
    mass_kg: float


def deterministic_guid(name: str) -> str:
    """An IFC GlobalId from a stable name, without '$' (re-salted), as in build_frames.py."""
    salt = 0
    while True:
        gid = ifcopenshell.guid.compress(uuid.uuid5(GUID_NAMESPACE, f"{name}#{salt}" if salt else name).hex)
        if "$" not in gid:
            return gid
        salt += 1


def room_centre(f: Any) -> np.ndarray:
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    space = next(s for s in f.by_type("IfcSpace") if s.Name == ROOM)
    shape: Any = ifcopenshell.geom.create_shape(settings, space)
    v = np.array(shape.geometry.verts, dtype=float).reshape(-1, 3)
    return np.asarray((v.min(axis=0) + v.max(axis=0)) / 2)


def plan_boards(frames: dict[str, Any], room: np.ndarray) -> list[Board]:
    panels = [p for p in frames["panels"] if p["host_wall"] == WALL]
    out = []
    for n, p in enumerate(sorted(panels, key=lambda q: q["install_order"]), start=1):
        yaw = float(p["yaw"])
        across = np.array([-math.sin(yaw), math.cos(yaw)])  # the panel's local +y
        side = 1.0 if float(np.dot(room[:2] - np.array([p["x"], p["y"]]), across)) > 0 else -1.0
        offset = side * (p["thickness"] / 2 + GAP + THICKNESS / 2)
        bid = f"B{n:02d}"
        out.append(Board(
            board_id=bid, global_id=deterministic_guid(f"{BASE_IRI}board/{bid}"), frame=p["panel_id"],
            install_order=n, x=round(p["x"] + across[0] * offset, 4) + 0.0,
            y=round(p["y"] + across[1] * offset, 4) + 0.0, z=p["z"], yaw=yaw, length=p["length"],
            height=p["height"], thickness=THICKNESS,
            mass_kg=round(p["length"] * p["height"] * AREA_MASS, 2)))
    return out


def add_boards(f: Any, boards: list[Board]) -> None:
    storey = next(s for s in f.by_type("IfcBuildingStorey") if s.Name == STOREY)
    context = next(c for c in f.by_type("IfcGeometricRepresentationContext", include_subtypes=False)
                   if c.ContextType == "Model")
    owner_history = f.by_type("IfcOwnerHistory")[0]
    before = {e.id() for e in f}
    material = ifcopenshell.api.material.add_material(f, name=MATERIAL)
    containment = storey.ContainsElements[0]
    contained_before = list(containment.RelatedElements)
    z_dir = f.createIfcDirection((0.0, 0.0, 1.0))
    x_dir = f.createIfcDirection((1.0, 0.0, 0.0))
    products = []
    for b in boards:
        m = ifcopenshell.api.root.create_entity(f, ifc_class="IfcPlate", name=f"Gypsum board {b.board_id}")
        m.GlobalId = b.global_id
        m.ObjectType = "Gypsum wall board"
        m.Tag = b.board_id
        m.Description = (f"Gypsum board {b.length:.3f} x {b.height:.2f} m, 12.5 mm, {b.mass_kg:.2f} kg, "
                         f"on stud frame panel {b.frame}")
        ifcopenshell.api.spatial.assign_container(f, products=[m], relating_structure=storey)
        c, s = (round(v, 12) + 0.0 for v in (math.cos(b.yaw), math.sin(b.yaw)))
        matrix = np.array([[c, -s, 0.0, b.x], [s, c, 0.0, b.y], [0.0, 0.0, 1.0, b.z], [0.0, 0.0, 0.0, 1.0]])
        ifcopenshell.api.geometry.edit_object_placement(f, product=m, matrix=matrix, is_si=True)
        profile = f.createIfcRectangleProfileDef(
            "AREA", "board", f.createIfcAxis2Placement2D(f.createIfcCartesianPoint((0.0, 0.0)), None),
            b.length, b.thickness)
        position = f.createIfcAxis2Placement3D(f.createIfcCartesianPoint((0.0, 0.0, 0.0)), z_dir, x_dir)
        solid = f.createIfcExtrudedAreaSolid(profile, position, z_dir, b.height)
        rep = f.createIfcShapeRepresentation(context, "Body", "SweptSolid", [solid])
        ifcopenshell.api.geometry.assign_representation(f, product=m, representation=rep)
        pset = ifcopenshell.api.pset.add_pset(f, product=m, name="Pset_PlateCommon")
        ifcopenshell.api.pset.edit_pset(f, pset=pset, properties={
            "Reference": b.board_id, "IsExternal": False, "LoadBearing": False})
        qto = ifcopenshell.api.pset.add_qto(f, product=m, name="BaseQuantities")
        ifcopenshell.api.pset.edit_qto(f, qto=qto, properties={
            "Length": float(b.length), "Height": float(b.height), "Width": float(b.thickness),
            "NetWeight": float(b.mass_kg)})
        products.append(m)
    ifcopenshell.api.material.assign_material(f, products=products, type="IfcMaterial", material=material)
    containment.RelatedElements = contained_before + sorted(products, key=lambda e: e.Tag)
    for rel in f.get_inverse(material):
        if rel.is_a("IfcRelAssociatesMaterial"):
            rel.RelatedObjects = sorted(rel.RelatedObjects, key=lambda e: e.Tag)
    for e in f.by_type("IfcRoot"):  # also relations the API edited (the Level 1 containment)
        if e.OwnerHistory is not None and e.OwnerHistory.id() not in before:
            e.OwnerHistory = owner_history
    for e in sorted((e for e in f.by_type("IfcRoot") if e.id() not in before), key=lambda e: e.id()):
        if not e.is_a("IfcPlate"):
            e.GlobalId = deterministic_guid(f"{BASE_IRI}boards-build/{e.is_a()}/{e.id()}")
    for oh in f.by_type("IfcOwnerHistory"):
        if oh.id() not in before and not f.get_inverse(oh):
            f.remove(oh)
    f.header.file_name.originating_system = ("kbplanner data/case_study/tools/build_frames.py and "
                                             "build_boards.py (ifcopenshell)")


def _iri(b: Board) -> str:
    return f"<{BASE_IRI}element/{quote(b.global_id, safe='')}>"


def augment_turtle(boards: list[Board]) -> str:
    lines = [
        "@prefix kbp:  <https://w3id.org/kbplanner/ontology#> .",
        "@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .",
        "",
        "# Augmentation (paper A4) of the board installation task T-BOARD (B-I-#1): where the gripper holds",
        "# each gypsum board (MM-G-1 'pick board': a pose in the board's own coordinates, origin at the",
        "# middle of its bottom edge, x along it, y across, z up; its centre) and the order the boards",
        "# go on (kbp:workSequence, from the kitchen end of the wall to the facade, like the panels).",
        "# Generated by tools/build_boards.py; do not edit by hand.",
        "",
    ]
    for b in boards:
        pose = f"<{BASE_IRI}pose/{b.board_id}-grasp>"
        lines += [
            f"{_iri(b)} kbp:graspPoint {pose} ; kbp:workSequence {b.install_order} .  # {b.board_id}",
            f"{pose} a kbp:Pose ;",
            f'    rdfs:label "grasp point of gypsum board {b.board_id} (local, its centre)" ;',
            f"    kbp:x 0.0e0 ; kbp:y 0.0e0 ; kbp:z {b.height / 2:.4f}e0 ;",
            "    kbp:roll 0.0e0 ; kbp:pitch 0.0e0 ; kbp:yaw 0.0e0 .",
            "",
        ]
    return "\n".join(lines)


def storage_turtle(boards: list[Board], scenario: str, storage: str) -> str:
    lines = [
        "@prefix kbp:  <https://w3id.org/kbplanner/ontology#> .",
        "",
        f"# Scenario '{scenario}' (overlay): the gypsum boards of T-BOARD (B-I-#1, NV-1 destination) lie on",
        "# the scenario's material storage, flat, B01 (installed first) on top. The frames of T-FRAME",
        "# have left it by then (T-FRAME ends on 23 May, T-BOARD starts on 24 May).",
        "# Generated by tools/build_boards.py; do not edit by hand.",
        "",
    ]
    for b in boards:
        lines.append(f"{_iri(b)} kbp:storedIn <{BASE_IRI}site/{storage}> ; "
                     f"kbp:stackIndex {len(boards) - b.install_order} .  # {b.board_id}")
    return "\n".join(lines) + "\n"


def main(out_dir: Path = PROJECT) -> list[Board]:
    """Add the boards to ``out_dir``'s frames IFC and write the tables and Turtle (see module docstring)."""
    f = ifcopenshell.open(str(out_dir / IFC))
    frames = json.loads((out_dir / FRAMES).read_text(encoding="utf-8"))
    boards = plan_boards(frames, room_centre(f))
    add_boards(f, boards)
    f.write(str(out_dir / IFC))
    for rel in (OUT_JSON, OUT_AUGMENT, *(p for p, _ in OUT_SCENARIOS.values())):
        (out_dir / rel).parent.mkdir(parents=True, exist_ok=True)
    (out_dir / OUT_JSON).write_text(json.dumps({
        "wall": WALL, "side": ROOM, "thickness_m": THICKNESS, "area_mass_kg_m2": AREA_MASS, "gap_m": GAP,
        "total_mass_kg": round(sum(b.mass_kg for b in boards), 2), "boards": [asdict(b) for b in boards],
    }, indent=2) + "\n", encoding="utf-8")
    (out_dir / OUT_AUGMENT).write_text(augment_turtle(boards), encoding="utf-8")
    for scenario, (rel, storage) in OUT_SCENARIOS.items():
        (out_dir / rel).write_text(storage_turtle(boards, scenario, storage), encoding="utf-8")
    return boards


if __name__ == "__main__":
    for b in main():
        print(f"{b.board_id} {b.global_id} on {b.frame} ({b.x:.4f}, {b.y:.4f}) yaw {b.yaw:+.4f} "
              f"{b.length:.4f} x {b.height:.2f} m {b.mass_kg:.2f} kg")
