"""The case study project data (data/case_study): the Duplex with 11 frame panels, its schedule, site
layout, workers and the two storage scenarios, checked against the IFC itself (ifcopenshell), the
figures in expected.toml, the schedule reader, and the loaded project (requirements and validation)."""

from __future__ import annotations

import csv
import fnmatch
import importlib.util
import math
import sys
import tomllib
from collections import Counter
from collections.abc import Iterator
from datetime import date, datetime
from pathlib import Path
from types import ModuleType
from typing import Any
from urllib.parse import unquote

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.element
import ifcopenshell.util.placement
import numpy as np
import pytest
import trimesh
from rdflib import RDF, RDFS, BNode, Graph, Literal, URIRef
from rdflib.namespace import XSD

from kbplanner.core.iris import element_iri
from kbplanner.core.rdf_io import parse_turtle
from kbplanner.core.vocab import BOT, KBP

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"
EXPECTED = tomllib.loads((CASE / "expected.toml").read_text(encoding="utf-8"))
MANIFEST = tomllib.loads((CASE / "project.toml").read_text(encoding="utf-8"))
BASE = MANIFEST["project"]["base_iri"]
FRAMES_IFC = CASE / EXPECTED["ifc"]["file"]
SITE_FILES = [CASE / p for p in MANIFEST["model"]["site"]]
SCENARIOS = {name: [CASE / p for p in s["overlays"]] for name, s in MANIFEST["scenarios"].items()}
ENTRANCE = (9.3, -16.18)  # just outside unit A's front door (east facade)
POSE_KEYS = (KBP.x, KBP.y, KBP.z, KBP.roll, KBP.pitch, KBP.yaw)


# ---- helpers ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def ifc() -> ifcopenshell.file:
    return ifcopenshell.open(str(FRAMES_IFC))


@pytest.fixture(scope="module")
def geom_settings() -> Any:
    s = ifcopenshell.geom.settings()
    s.set("use-world-coords", True)
    return s


def gypsum_boards(f: ifcopenshell.file) -> list[Any]:
    boards = [m for m in f.by_type("IfcPlate") if m.ObjectType == EXPECTED["boards"]["object_type"]]
    return sorted(boards, key=lambda m: m.Name)


def frame_panels(f: ifcopenshell.file) -> list[Any]:
    panels = [m for m in f.by_type("IfcMember") if m.ObjectType == EXPECTED["frames"]["object_type"]]
    return sorted(panels, key=lambda m: m.Name)


def mesh(settings: Any, product: Any) -> trimesh.Trimesh:
    g = ifcopenshell.geom.create_shape(settings, product).geometry
    return trimesh.Trimesh(np.array(g.verts).reshape(-1, 3), np.array(g.faces).reshape(-1, 3), process=False)


def storeys_of(e: Any) -> set[str]:
    """Storey names an element is contained in, directly or through a space (as the schedule reader)."""
    out: set[str] = set()
    for rel in e.ContainedInStructure:
        s = rel.RelatingStructure
        if s.is_a("IfcBuildingStorey"):
            out.add(s.Name)
        elif s.is_a("IfcSpace"):
            out |= {r.RelatingObject.Name for r in s.Decomposes if r.RelatingObject.is_a("IfcBuildingStorey")}
    return out


def selector_matches(entry: str, e: Any) -> bool:
    """docs/schedule.md selectors, evaluated on the IFC directly: all key=value pairs must hold."""
    keys = dict(part.split("=", 1) for part in entry.split(";"))
    if "class" in keys and not e.is_a().lower().startswith(keys["class"].lower()):
        return False
    if "storey" in keys and keys["storey"] not in storeys_of(e):
        return False
    if "name" in keys and not fnmatch.fnmatchcase(e.Name or "", keys["name"]):
        return False
    if "external" in keys:
        psets = ifcopenshell.util.element.get_psets(e)
        ext = next((p["IsExternal"] for p in psets.values() if "IsExternal" in p), None)
        return ext is (keys["external"].lower() == "true")
    return True


def building_elements(f: ifcopenshell.file) -> list[Any]:
    return [e for e in f.by_type("IfcElement") if not e.is_a("IfcOpeningElement")]


def schedule_rows() -> list[dict[str, str]]:
    with open(CASE / "schedule.csv", encoding="utf-8", newline="") as fh:
        return list(csv.DictReader(fh))


def task_elements(f: ifcopenshell.file, row: dict[str, str]) -> list[Any]:
    els = building_elements(f)
    out: list[Any] = []
    for entry in filter(None, (x.strip() for x in row["elements"].split("|"))):
        if "=" in entry:
            matched = [e for e in els if selector_matches(entry, e)]
            assert matched, f"{row['task_id']}: selector {entry!r} matches nothing"
            out += matched
        else:
            out.append(f.by_guid(entry))
    return list(dict.fromkeys(out))


def parse(paths: list[Path]) -> Graph:
    g = Graph()
    for p in paths:
        parse_turtle(p, into=g)
    return g


def pose_of(g: Graph, node: Any) -> tuple[float, ...]:
    return tuple(float(g.value(node, k)) for k in POSE_KEYS)


def pickup_xy(g: Graph) -> np.ndarray:
    storage = next(g.subjects(KBP.pickupLocation, None))
    return np.array(pose_of(g, g.value(storage, KBP.pickupLocation))[:2])


def panel_pset(panel: Any) -> dict[str, Any]:
    return ifcopenshell.util.element.get_psets(panel)["Kbplanner_StudFramePanel"]


def layout_extent(g: Graph) -> tuple[float, float, float, float]:
    layout = g.value(None, RDF.type, KBP.SiteLayout)
    box = g.value(layout, KBP.siteExtent)
    return tuple(float(g.value(box, k)) for k in (KBP.minX, KBP.minY, KBP.maxX, KBP.maxY))  # type: ignore[return-value]


def segment_distance(p: np.ndarray, q: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Shortest distance between 2D segments pq and ab (0 when they cross)."""
    def cross(o: np.ndarray, u: np.ndarray, v: np.ndarray) -> float:
        return float((u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0]))

    if cross(p, q, a) * cross(p, q, b) < 0 and cross(a, b, p) * cross(a, b, q) < 0:
        return 0.0

    def point_seg(x: np.ndarray, u: np.ndarray, v: np.ndarray) -> float:
        length2 = float(np.dot(v - u, v - u))
        t = float(np.clip(np.dot(x - u, v - u) / length2, 0.0, 1.0)) if length2 > 0 else 0.0
        return float(np.linalg.norm(x - (u + t * (v - u))))

    return min(point_seg(p, a, b), point_seg(q, a, b), point_seg(a, p, q), point_seg(b, p, q))


def load_tool(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"case_study_{name}", CASE / "tools" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


# ---- the IFC model with the frame panels ----------------------------------------------------------

def test_the_frames_model_is_the_duplex_plus_eleven_frame_panels_contained_in_level_1(ifc: Any) -> None:
    exp = EXPECTED["frames"]
    panels = frame_panels(ifc)
    assert ifc.schema == EXPECTED["ifc"]["schema"]
    assert [p.Name for p in panels] == [f"Stud frame panel F{i:02d}" for i in range(1, exp["count"] + 1)]
    for p in panels:
        assert storeys_of(p) == {exp["storey"]}
        assert p.Representation is not None
        mat = ifcopenshell.util.element.get_material(p)
        assert mat is not None and mat.Name == exp["material"]
    source = ifcopenshell.open(str(CASE / "model" / "Duplex_A_20110907.ifc"))
    assert {e.GlobalId for e in ifc.by_type("IfcRoot")} >= {e.GlobalId for e in source.by_type("IfcRoot")}
    assert len(building_elements(ifc)) == (len(building_elements(source)) + exp["count"]
                                           + EXPECTED["boards"]["count"])


def test_every_frame_panel_is_38x89_studs_at_most_600_mm_apart_between_plates(ifc: Any) -> None:
    exp = EXPECTED["frames"]
    for p in frame_panels(ifc):
        items = p.Representation.Representations[0].Items
        assert all(i.is_a("IfcExtrudedAreaSolid") for i in items)
        studs = sorted((i for i in items if i.SweptArea.ProfileName == "stud"),
                       key=lambda i: i.SweptArea.Position.Location.Coordinates[0])
        plates = [i for i in items if i.SweptArea.ProfileName.endswith("plate")]
        assert len(plates) == 2 and len(studs) >= 2
        for s in studs:
            assert (s.SweptArea.XDim, s.SweptArea.YDim) == pytest.approx(tuple(exp["stud_section_m"]))
        centres = [s.SweptArea.Position.Location.Coordinates[0] for s in studs]
        assert max(np.diff(centres)) <= exp["max_stud_spacing_m"] + 1e-9
        top = max(i.Position.Location.Coordinates[2] + i.Depth for i in items)
        assert top == pytest.approx(exp["height_m"])


def test_every_frame_panel_lies_in_the_plane_of_its_unit_a_partition_wall(ifc: Any,
                                                                          geom_settings: Any) -> None:
    exp = EXPECTED["frames"]
    boxes = []
    for panel, host_gid in zip(frame_panels(ifc), exp["host_walls"], strict=True):
        assert panel_pset(panel)["HostWallGlobalId"] == host_gid
        wall = ifc.by_guid(host_gid)
        assert "Interior - Partition (92mm Stud)" in wall.Name
        assert ifcopenshell.util.element.get_psets(wall)["Pset_WallCommon"]["IsExternal"] is False
        assert storeys_of(wall) == {"Level 1"}
        lo, hi = mesh(geom_settings, panel).bounds
        wlo, whi = mesh(geom_settings, wall).bounds
        assert np.all(lo[:2] >= wlo[:2] - 1e-3) and np.all(hi[:2] <= whi[:2] + 1e-3)  # inside the wall
        assert lo[2] == pytest.approx(0.0, abs=1e-6) and hi[2] == pytest.approx(exp["height_m"])
        extent = sorted(hi[:2] - lo[:2])
        assert extent[0] == pytest.approx(exp["thickness_m"], abs=1e-3)
        assert exp["min_length_m"] - 1e-3 <= extent[1] <= exp["max_length_m"] + 1e-3 <= 1.2
        for opening in (r.RelatedOpeningElement for r in wall.HasOpenings):
            olo, ohi = mesh(geom_settings, opening).bounds
            overlap = np.minimum(hi[:2], ohi[:2]) - np.maximum(lo[:2], olo[:2])
            assert not np.all(overlap > 1e-3), f"{panel.Name} covers a door opening"
        boxes.append((panel.Name, lo, hi))
    for i, (na, alo, ahi) in enumerate(boxes):
        for nb, blo, bhi in boxes[i + 1:]:
            overlap = np.minimum(ahi, bhi) - np.maximum(alo, blo)
            assert not np.all(overlap > 1e-3), f"{na} overlaps {nb}"


def test_frame_masses_are_the_stud_volume_times_spf_density(ifc: Any, geom_settings: Any) -> None:
    exp = EXPECTED["frames"]
    masses = []
    for p in frame_panels(ifc):
        volume = mesh(geom_settings, p).volume
        mass = volume * exp["density_kg_m3"]
        assert mass == pytest.approx(panel_pset(p)["Mass"], abs=0.01)
        masses.append(mass)
    assert masses == pytest.approx(exp["masses_kg"], abs=0.01)
    assert sum(masses) == pytest.approx(exp["total_mass_kg"], abs=0.05)
    assert min(masses) == pytest.approx(exp["min_mass_kg"], abs=0.01)
    assert max(masses) == pytest.approx(exp["max_mass_kg"], abs=0.01)


def test_frame_global_ids_avoid_dollar_signs_and_name_their_element_iris(ifc: Any) -> None:
    for p in frame_panels(ifc):
        assert "$" not in p.GlobalId
        assert unquote(str(element_iri(BASE, p.GlobalId)).rsplit("/", 1)[-1]) == p.GlobalId


def test_one_gypsum_board_stands_against_the_living_room_face_of_each_panel_of_its_wall(
        ifc: Any, geom_settings: Any) -> None:
    exp = EXPECTED["boards"]
    boards = gypsum_boards(ifc)
    assert [b.Name for b in boards] == [f"Gypsum board B{i:02d}" for i in range(1, exp["count"] + 1)]
    panels = {p.Tag: p for p in frame_panels(ifc)}
    room = next(s for s in ifc.by_type("IfcSpace") if s.Name == exp["side_space"])
    room_centre = mesh(geom_settings, room).bounds.mean(axis=0)
    for b, tag in zip(boards, exp["frames"], strict=True):
        assert storeys_of(b) == {exp["storey"]}
        assert ifcopenshell.util.element.get_material(b).Name == exp["material"]
        qto = ifcopenshell.util.element.get_psets(b)["BaseQuantities"]
        assert qto["NetWeight"] == pytest.approx(exp["mass_kg"]) and qto["Width"] == exp["thickness_m"]
        m_b = ifcopenshell.util.placement.get_local_placement(b.ObjectPlacement)
        m_p = ifcopenshell.util.placement.get_local_placement(panels[tag].ObjectPlacement)
        assert np.allclose(m_b[:3, :3], m_p[:3, :3])  # same orientation as its panel
        offset = (m_b[:3, 3] - m_p[:3, 3]) @ m_p[:3, 1]  # across the wall
        assert abs(offset) == pytest.approx(EXPECTED["frames"]["thickness_m"] / 2 + exp["gap_m"]
                                            + exp["thickness_m"] / 2, abs=1e-4)
        assert np.sign(offset) == np.sign((room_centre - m_p[:3, 3]) @ m_p[:3, 1])  # on the room's side
        vb, vp = mesh(geom_settings, b).bounds, mesh(geom_settings, panels[tag]).bounds
        assert vb[1][2] - vb[0][2] == pytest.approx(vp[1][2] - vp[0][2], abs=1e-6)  # as high as its panel
        assert not (np.all(vb[0] < vp[1] - 1e-6) and np.all(vp[0] < vb[1] - 1e-6))  # not inside it


def test_the_board_task_builds_the_five_boards_after_the_frames_robotized() -> None:
    exp = EXPECTED["schedule"]
    row = next(r for r in schedule_rows() if r["task_id"] == exp["board_task"])
    assert (row["start"], row["finish"], row["robotized"], row["task_specification"]) == (
        exp["board_start"], exp["board_finish"], "true", exp["board_specification"])
    framing = next(r for r in schedule_rows() if r["task_id"] == exp["framing_task"])
    assert row["predecessors"] == exp["framing_task"] and framing["finish"] < row["start"]


def test_rebuilding_frames_and_scenarios_reproduces_the_checked_in_files(tmp_path: Path) -> None:
    build_frames = load_tool("build_frames")
    build_boards = load_tool("build_boards")
    build_scenarios = load_tool("build_scenarios")
    build_frames.main(tmp_path)
    build_boards.main(tmp_path)
    build_scenarios.main(tmp_path / "model" / "frames.json", tmp_path)
    for rel in ("model/Duplex_A_frames.ifc", "model/frames.json", "augmentation/grasp_points.ttl",
                "scenarios/storage_outside.ttl", "scenarios/storage_inside.ttl", "model/boards.json",
                "augmentation/boards.ttl", "scenarios/boards_outside.ttl", "scenarios/boards_inside.ttl"):
        assert (tmp_path / rel).read_bytes() == (CASE / rel).read_bytes(), rel


def test_the_readme_table_is_printed_from_comparison_csv_in_the_readme_format(tmp_path: Path) -> None:
    readme_table = load_tool("readme_table")
    (tmp_path / "comparison.csv").write_text(
        "scenario,installed,first frame (min),per frame (min),total (min),min separation (m),time < 1 m (s),"
        "time < ISO/TS 15066 S_p (s),stops for workers,stopped (s),slow-downs,time lost to monitoring (s),"
        "collisions\nstorage-inside,11/11,1.910,1.200,13.170,1.490,0.000,18.600,0,0.000,2,0.220,0\n",
        encoding="utf-8")
    lines = readme_table.table(tmp_path).splitlines()
    readme = (CASE.parents[1] / "README.md").read_text(encoding="utf-8")
    assert lines[0] in readme and lines[1] in readme  # the README's header
    assert lines[2] == ("| storage inside | 11/11 | 1.9 min | 1.2 min | 13.2 min | 1.49 m | 0 s | 18.6 s | "
                        "2 (0.2 s) | 0 |")


def test_expected_counts_match_the_ifc(ifc: Any) -> None:
    exp = EXPECTED["ifc"]
    storeys = sorted(ifc.by_type("IfcBuildingStorey"), key=lambda s: s.Elevation)
    assert [s.Name for s in storeys] == exp["storeys"]
    assert [round(s.Elevation, 3) for s in storeys] == exp["storey_elevations_m"]
    walls = ifc.by_type("IfcWall")
    external = Counter(ifcopenshell.util.element.get_psets(w)["Pset_WallCommon"]["IsExternal"] for w in walls)
    assert (len(walls), external[False], external[True]) == (exp["walls"], exp["walls_interior"],
                                                              exp["walls_exterior"])
    level1_interior = [w for w in walls if storeys_of(w) == {"Level 1"}
                       and ifcopenshell.util.element.get_psets(w)["Pset_WallCommon"]["IsExternal"] is False]
    assert len(level1_interior) == exp["level1_interior_walls"]
    counts = {k: len(ifc.by_type(c)) for k, c in [("doors", "IfcDoor"), ("windows", "IfcWindow"),
              ("spaces", "IfcSpace"), ("slabs", "IfcSlab"), ("furniture", "IfcFurnishingElement"),
              ("members", "IfcMember"), ("plates", "IfcPlate"), ("openings", "IfcOpeningElement")]}
    assert counts == {k: exp[k] for k in counts}
    assert len(building_elements(ifc)) == exp["building_elements"]


def test_the_apartment_is_unit_a_with_its_bedrooms_upstairs(ifc: Any) -> None:
    exp = EXPECTED["unit"]
    level1 = sorted(s.Name for s in ifc.by_type("IfcSpace") if s.Name.startswith("A1"))
    assert level1 == exp["level1_spaces"]
    bedrooms = [s for s in ifc.by_type("IfcSpace")
                if s.Name.startswith("A") and "Bedroom" in (s.LongName or "")]
    assert len(bedrooms) == 2
    assert {s.Decomposes[0].RelatingObject.Name for s in bedrooms} == {exp["bedroom_storey"]}
    lengths = []
    for gid in exp["partition_walls"]:
        reps = ifc.by_guid(gid).Representation.Representations
        axis = next(r for r in reps if r.RepresentationIdentifier == "Axis")
        pts = np.array([p.Coordinates for p in axis.Items[0].Points])
        lengths.append(float(np.linalg.norm(pts[-1] - pts[0])))
    assert sum(lengths) == pytest.approx(exp["partition_axis_length_m"], abs=1e-3)
    assert set(exp["partition_walls"]) == set(EXPECTED["frames"]["host_walls"])


def test_the_entrance_door_on_the_robot_route_is_1_25_m_wide(ifc: Any, geom_settings: Any) -> None:
    exp = EXPECTED["route"]
    door = ifc.by_guid(exp["entrance_door"])
    assert door.OverallWidth == pytest.approx(exp["entrance_door_width_m"])
    assert ifcopenshell.util.element.get_psets(door)["Pset_DoorCommon"]["IsExternal"] is True
    opening = door.FillsVoids[0].RelatingOpeningElement
    lo, hi = mesh(geom_settings, opening).bounds
    assert hi[1] - lo[1] == pytest.approx(exp["entrance_opening_width_m"], abs=1e-3)
    assert lo[1] < ENTRANCE[1] < hi[1] and abs(ENTRANCE[0] - hi[0]) < 1.0
    assert exp["narrowest_door_on_route_m"] == min(exp["entrance_door_width_m"],
                                                   exp["foyer_to_living_opening_m"])
    north_end_living_wall = mesh(geom_settings, ifc.by_guid("2O2Fr$t4X7Zf8NOew3FKGS")).bounds[1][1]
    south_end_foyer_wall = mesh(geom_settings, ifc.by_guid("2O2Fr$t4X7Zf8NOew3FKST")).bounds[0][1]
    gap = south_end_foyer_wall - north_end_living_wall
    assert gap == pytest.approx(exp["foyer_to_living_opening_m"], abs=2e-3)


# ---- the schedule ---------------------------------------------------------------------------------

def test_the_framing_task_selector_matches_exactly_the_eleven_frames(ifc: Any) -> None:
    exp = EXPECTED["schedule"]
    row = next(r for r in schedule_rows() if r["task_id"] == exp["framing_task"])
    assert "=" in row["elements"] and "|" not in row["elements"]
    assert {e.GlobalId for e in task_elements(ifc, row)} == {p.GlobalId for p in frame_panels(ifc)}
    assert (row["name"], row["start"], row["finish"], row["robotized"], row["task_specification"]) == (
        exp["framing_name"], exp["framing_start"], exp["framing_finish"], "true",
        exp["framing_specification"])


def test_the_schedule_builds_every_element_exactly_once(ifc: Any) -> None:
    # the layout-marking task works on the partitions (marks their axes) but does not build them
    marking = EXPECTED["schedule"]["marking_task"]
    built = Counter(e.GlobalId for row in schedule_rows() if row["task_id"] != marking
                    for e in task_elements(ifc, row))
    assert sorted(built) == sorted(e.GlobalId for e in building_elements(ifc))
    assert set(built.values()) == {1}
    assert sum(built.values()) == EXPECTED["schedule"]["scheduled_elements"]


def test_every_task_starts_after_its_predecessors_finish() -> None:
    rows = {r["task_id"]: r for r in schedule_rows()}
    for r in rows.values():
        for p in r["predecessors"].split():
            start = datetime.fromisoformat(r["start"]).date()  # a start may give a time (work start)
            assert date.fromisoformat(rows[p]["finish"]) < start, (p, r["task_id"])
    exp = EXPECTED["schedule"]
    assert len(rows) == exp["tasks"]
    assert [t for t, r in rows.items() if r["robotized"] == "true"] == exp["robotized"]
    assert min(r["start"] for r in rows.values()) == exp["first_start"]
    assert max(r["finish"] for r in rows.values()) == exp["last_finish"]


def test_on_the_simulation_date_roof_and_framing_are_in_progress_and_level_1_partitions_not_started(
        ifc: Any) -> None:
    at = datetime.fromisoformat(MANIFEST["simulation"]["date"])
    assert MANIFEST["simulation"]["task"] == EXPECTED["schedule"]["framing_task"]
    rows = schedule_rows()

    def span(r: dict[str, str]) -> tuple[datetime, datetime]:
        return (datetime.fromisoformat(r["start"]), datetime.fromisoformat(r["finish"] + "T23:59:59"))

    in_progress = sorted(r["task_id"] for r in rows if span(r)[0] <= at <= span(r)[1])
    assert in_progress == EXPECTED["schedule"]["in_progress_at_simulation_date"]
    for r in rows:  # structure and envelope done before, except doors (hung after the interior work)
        if r["task_id"] not in in_progress and span(r)[0] < at:
            assert span(r)[1] < at
    partitions = {w.GlobalId for w in ifc.by_type("IfcWall") if storeys_of(w) == {"Level 1"}
                  and "Interior - Partition" in w.Name}
    for r in rows:  # the layout marking only marks them (the day before): it builds nothing
        if r["task_id"] != EXPECTED["schedule"]["marking_task"] and partitions & {
                e.GlobalId for e in task_elements(ifc, r)}:
            assert r["task_id"] == EXPECTED["schedule"]["level1_interior_walls_task"]
            assert span(r)[0] > at


def test_the_schedule_reader_resolves_the_framing_task_to_the_eleven_frames(ifc: Any) -> None:
    from kbplanner.model.schedule_csv import read_csv_schedule

    model = Graph()
    storeys: dict[str, URIRef] = {}
    for s in ifc.by_type("IfcBuildingStorey"):
        storeys[s.Name] = URIRef(f"{BASE}storey/{s.GlobalId}")
        model.add((storeys[s.Name], RDF.type, BOT.Storey))
        model.add((storeys[s.Name], RDFS.label, Literal(s.Name)))
    for e in building_elements(ifc):
        iri = element_iri(BASE, e.GlobalId)
        model.add((iri, RDF.type, BOT.Element))
        model.add((iri, KBP.globalId, Literal(e.GlobalId)))
        model.add((iri, KBP.ifcClass, Literal(e.is_a())))
        model.add((iri, RDFS.label, Literal(e.Name)))
        for name in storeys_of(e):
            model.add((storeys[name], BOT.containsElement, iri))
    schedule = read_csv_schedule(CASE / "schedule.csv", model)
    task = schedule.task(EXPECTED["schedule"]["framing_task"])
    assert task.robotized and task.task_specification_id == EXPECTED["schedule"]["framing_specification"]
    assert set(task.element_iris) == {element_iri(BASE, p.GlobalId) for p in frame_panels(ifc)}
    assert (task.start, task.finish) == (datetime(2022, 5, 10), datetime(2022, 5, 23, 23, 59, 59))


# ---- site layout, workers, scenarios --------------------------------------------------------------

def all_turtle() -> list[Path]:
    return sorted(p for d in ("site", "scenarios", "augmentation") for p in (CASE / d).glob("*.ttl"))


@pytest.mark.parametrize("path", all_turtle(), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_case_study_turtle_parses_without_blank_nodes_and_poses_have_six_doubles(path: Path) -> None:
    g = parse_turtle(path)
    assert len(g) > 0
    assert not any(isinstance(t, BNode) for triple in g for t in triple)
    assert all(str(s).startswith(BASE) for s in g.subjects())
    for pose in g.subjects(RDF.type, KBP.Pose):
        for key in POSE_KEYS:
            values = list(g.objects(pose, key))
            assert len(values) == 1 and isinstance(values[0], Literal) and values[0].datatype == XSD.double, (
                pose, key)


def test_the_bare_site_files_hold_no_frame_storage_pickup_or_grasp_point() -> None:
    g = parse(SITE_FILES)
    for p in (KBP.pickupLocation, KBP.storedIn, KBP.graspPoint, KBP.stackIndex):
        assert not list(g.subject_objects(p)), p
    lumber = list(g.subjects(RDF.type, KBP.MaterialStorage))
    assert len(lumber) == 1 and "Lumber" in str(g.value(lumber[0], RDFS.label))
    assert sum(1 for _ in g.subjects(RDF.type, KBP.Worker)) == EXPECTED["site"]["workers"]
    objects = {s for s, _, c in g.triples((None, RDF.type, None)) if c in {
        KBP.SiteOffice, KBP.Equipment, KBP.MaterialStorage, KBP.Workspace, KBP.NoGoZone,
        KBP.SafetyFence, KBP.TemporaryStructure}}
    assert len(objects) == EXPECTED["site"]["site_objects"]
    for o in objects:
        assert g.value(o, RDFS.label) is not None and g.value(o, KBP.obstructs) is not None
        assert all(float(g.value(o, k)) > 0 for k in (KBP.sizeX, KBP.sizeY, KBP.sizeZ))
        assert len(pose_of(g, g.value(o, KBP.installedPose))) == 6
    for area in (*g.subjects(RDF.type, KBP.Workspace), *g.subjects(RDF.type, KBP.NoGoZone)):
        assert g.value(area, KBP.obstructs) == Literal(False)
    assert list(layout_extent(g)) == EXPECTED["site"]["extent"]


def test_every_worker_walks_an_ordered_route_between_site_objects_of_the_layout() -> None:
    g = parse(SITE_FILES)
    roles = Counter()
    for w in g.subjects(RDF.type, KBP.Worker):
        roles[str(g.value(w, KBP.role))] += 1
        assert 0.5 < float(g.value(w, KBP.walkingSpeed)) < 1.6
        stops = list(g.objects(w, KBP.routeStop))
        assert sorted(int(g.value(s, KBP.order)) for s in stops) == list(range(1, len(stops) + 1))
        for s in stops:
            loc = g.value(s, KBP.location)
            assert g.value(loc, KBP.installedPose) is not None, loc
            assert float(g.value(s, KBP.dwellTime)) >= 0
    assert roles == {"carpenter": 2, "supervisor": 1}
    assert {str(g.value(w, RDFS.label)) for w in g.subjects(RDF.type, KBP.Worker)} == {
        "Carpenter 1", "Carpenter 2", "Site supervisor"}


def scenario_graph(name: str) -> Graph:
    return parse([*SITE_FILES, *SCENARIOS[name]])


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_each_scenario_stacks_every_frame_once_in_one_storage_with_a_grasp_point(ifc: Any, name: str) -> None:
    g = scenario_graph(name)
    frames = {element_iri(BASE, p.GlobalId) for p in frame_panels(ifc)}
    boards = {element_iri(BASE, p.GlobalId) for p in gypsum_boards(ifc)}
    named = {o for t in g for o in (t[0], t[2])
             if isinstance(o, URIRef) and str(o).startswith(f"{BASE}element/")}
    assert named == frames | boards  # every element the overlays name is a frame panel or board of the IFC
    storages = {g.value(f, KBP.storedIn) for f in frames | boards}
    assert len(storages) == 1  # the boards use the frames' storage once the frames are installed
    storage = storages.pop()
    assert (storage, RDF.type, KBP.MaterialStorage) in g and g.value(storage, KBP.pickupLocation) is not None
    for group, local in ((frames, EXPECTED["frames"]["grasp_point_local"]),
                         (boards, EXPECTED["boards"]["grasp_point_local"])):
        assert sorted(int(g.value(f, KBP.stackIndex)) for f in group) == list(range(len(group)))
        for f in group:
            grasp = pose_of(g, g.value(f, KBP.graspPoint))
            assert grasp == pytest.approx((*local, 0.0, 0.0, 0.0))


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_the_robot_picks_inside_the_site_extent_1_m_from_the_stack_facing_it_without_touching_it(
        name: str) -> None:
    g = scenario_graph(name)
    storage = next(g.subjects(KBP.pickupLocation, None))
    x, y, _, _, _, pick_yaw = pose_of(g, g.value(storage, KBP.pickupLocation))
    min_x, min_y, max_x, max_y = layout_extent(g)
    assert min_x < x < max_x and min_y < y < max_y
    exp = EXPECTED["scenarios"]
    assert [x, y, pick_yaw] == pytest.approx(exp[name]["pickup"])
    sx, sy, _, _, _, syaw = pose_of(g, g.value(storage, KBP.installedPose))
    half_x, half_y = float(g.value(storage, KBP.sizeX)) / 2, float(g.value(storage, KBP.sizeY)) / 2
    c, s = math.cos(syaw), math.sin(syaw)
    lx, ly = c * (x - sx) + s * (y - sy), -s * (x - sx) + c * (y - sy)  # robot in the storage's frame
    size_z = float(g.value(storage, KBP.sizeZ))
    assert [2 * half_x, 2 * half_y, size_z] == pytest.approx(exp["storage_size_m"])
    assert abs(lx) < 1e-9 and abs(ly) == pytest.approx(exp["pickup_to_stack_centre_m"])
    assert 0.8 <= abs(ly) <= 1.0
    assert abs(ly) - exp["robot_footprint_m"][0] / 2 - half_y > 0.05  # the base stops short of the bearers
    frames = list(g.subjects(KBP.storedIn, storage))
    assert frames and all((f, KBP.graspPoint, None) in g for f in frames)
    to_storage = math.atan2(sy - y, sx - x)
    assert math.cos(to_storage - pick_yaw) == pytest.approx(1.0, abs=1e-6)


def test_the_outside_storage_is_in_the_yard_and_the_inside_storage_in_the_living_room(
        ifc: Any, geom_settings: Any) -> None:
    building_lo, building_hi = np.array([0.0, -17.8]), np.array([8.8, 0.0])
    out = scenario_graph("storage-outside")
    ins = scenario_graph("storage-inside")
    po, pi = pickup_xy(out), pickup_xy(ins)
    assert not np.all((building_lo <= po) & (po <= building_hi))
    assert float(np.linalg.norm(po - np.array(ENTRANCE))) == pytest.approx(
        EXPECTED["scenarios"]["storage-outside"]["pickup_to_entrance_m"], abs=0.05)
    space_name = EXPECTED["scenarios"]["storage-inside"]["pickup_space"]
    living = next(s for s in ifc.by_type("IfcSpace") if s.Name == space_name)
    lo, hi = mesh(geom_settings, living).bounds
    storage = next(ins.subjects(KBP.pickupLocation, None))
    sx, sy = pose_of(ins, ins.value(storage, KBP.installedPose))[:2]
    for px, py in [(pi[0], pi[1]), (sx, sy)]:
        assert lo[0] < px < hi[0] and lo[1] < py < hi[1]
    # clear of the install locations: the stack (its yaw is 0) is over 1.5 m from every frame
    half = np.array([float(ins.value(storage, KBP.sizeX)), float(ins.value(storage, KBP.sizeY))]) / 2
    assert pose_of(ins, ins.value(storage, KBP.installedPose))[5] == 0.0
    for p in frame_panels(ifc):
        plo, phi = mesh(geom_settings, p).bounds
        gap = np.maximum(0, np.maximum(plo[:2] - (np.array([sx, sy]) + half),
                                       (np.array([sx, sy]) - half) - phi[:2]))
        assert float(np.linalg.norm(gap)) > 1.5, p.Name


def carpenter_legs(g: Graph) -> Iterator[tuple[str, np.ndarray, np.ndarray]]:
    for w in g.subjects(RDF.type, KBP.Worker):
        if str(g.value(w, KBP.role)) != "carpenter":
            continue
        stops = sorted(g.objects(w, KBP.routeStop), key=lambda s: int(g.value(s, KBP.order)))
        pts = [np.array(pose_of(g, g.value(g.value(s, KBP.location), KBP.installedPose))[:2]) for s in stops]
        for a, b in zip(pts, pts[1:] + pts[:1], strict=True):
            yield str(g.value(w, RDFS.label)), a, b


def test_carpenters_cross_the_robot_way_from_the_outside_storage_and_keep_3_m_from_the_inside_work(
        ifc: Any) -> None:
    out = scenario_graph("storage-outside")
    pickup = pickup_xy(out)
    crossing = {name for name, a, b in carpenter_legs(out)
                if segment_distance(pickup, np.array(ENTRANCE), a, b) == 0.0}
    assert crossing == {"Carpenter 1", "Carpenter 2"}  # the paper's case 1: closer than 1 m happens
    ins = scenario_graph("storage-inside")
    pi = pickup_xy(ins)
    work = [pi] + [np.array(ifcopenshell.util.placement.get_local_placement(p.ObjectPlacement)[:2, 3])
                   for p in frame_panels(ifc)]
    nearest = min(segment_distance(w, w, a, b) for w in work for _, a, b in carpenter_legs(ins))
    assert nearest >= 3.0  # case 2: about 3 m or more from the carpenters


# ---- the loaded project: requirements (A3) and validation (A4) -------------------------------------

@pytest.fixture(scope="module")
def projects(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str | None, Any]]:
    from kbplanner.project import CACHE_ENV, Project

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(CACHE_ENV, str(tmp_path_factory.mktemp("case-study-cache")))
        yield {name: Project.load(CASE, scenario=name) for name in (None, *sorted(SCENARIOS))}


def test_the_loaded_case_study_matches_the_expected_summary(projects: dict[str | None, Any]) -> None:
    info = projects[None].info()
    exp = EXPECTED
    assert info.schema == exp["ifc"]["schema"]
    assert [s[0] for s in info.storeys] == exp["ifc"]["storeys"]
    assert info.walls_interior == exp["ifc"]["walls_interior"]
    assert info.walls_exterior == exp["ifc"]["walls_exterior"]
    assert info.counts["Door"] == exp["ifc"]["doors"] and info.counts["Window"] == exp["ifc"]["windows"]
    assert info.tasks == exp["schedule"]["tasks"]
    assert [r[0] for r in info.robotized_tasks] == exp["schedule"]["robotized"]
    assert info.date_range == (f"{exp['schedule']['first_start']}T00:00:00",
                               f"{exp['schedule']['last_finish']}T23:59:59")
    assert info.workers == exp["site"]["workers"]
    assert sum(info.site_objects.values()) == exp["site"]["site_objects"]


def test_the_bare_model_needs_a_frame_storage_and_grasp_points_for_every_frame(
        projects: dict[str | None, Any]) -> None:
    from kbplanner.knowledge.requirements import derive_requirements

    p = projects[None]
    result = derive_requirements(p.model, p.kb)
    exp = EXPECTED["requirements"]
    assert len(result.requirements) == exp["bare_model_requirements"]
    assert sorted((r.task_id, r.skill_id) for r in result.requirements) == [
        ("T-BOARD", "MM-G-1"), ("T-BOARD", "NV-1"), ("T-FRAME", "MM-G-1"), ("T-FRAME", "NV-1")]
    assert all(len(r.elements) == exp["bare_model_unmet_elements"][r.task_id] for r in result.requirements)
    unmet_install = [c for c in result.checks if c.skill_id in {"NV-2", "MM-R-1"}]
    assert unmet_install and all(c.unmet == 0 for c in unmet_install)  # the installed pose is in the 4D model


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_each_storage_scenario_meets_every_requirement_and_conforms(projects: dict[str | None, Any],
                                                                   name: str) -> None:
    from kbplanner.knowledge.requirements import derive_requirements
    from kbplanner.knowledge.validation import validate_model

    p = projects[name]
    requirements = derive_requirements(p.model, p.kb).requirements
    assert len(requirements) == EXPECTED["requirements"]["scenario_requirements"]
    result = validate_model(p.model, p.kb)
    assert result.conforms, result.rows[:5]


def test_the_jobsite_admits_a_robot_through_the_front_door_and_slows_it_down_with_a_frame(
        projects: dict[str | None, Any]) -> None:
    from kbplanner.knowledge.jobsite import action_parameters, jobsite_parameters
    from kbplanner.knowledge.task_specs import task_specification

    exp = EXPECTED["jobsite"]
    p = projects[None]
    js = jobsite_parameters(p.model)
    assert js.max_robot_width_m == pytest.approx(exp["max_robot_width_m"])
    assert js.max_robot_width_m <= EXPECTED["route"]["entrance_door_width_m"] - 0.2
    assert (js.max_robot_length_m, js.max_robot_height_m, js.max_robot_mass_kg) == pytest.approx(
        (exp["max_robot_length_m"], exp["max_robot_height_m"], exp["max_robot_mass_kg"]))
    assert [z.label for z in js.no_go_zones] == exp["no_go_zones"]
    actions = {a.action.skill.skill_id: a for a in
               action_parameters(task_specification(p.kb, EXPECTED["schedule"]["framing_specification"]), js)}
    assert [actions["NV-1"].value(KBP.minSpeed), actions["NV-1"].value(KBP.maxSpeed)] == exp["nv1_speed_mps"]
    assert [actions["NV-2"].value(KBP.minSpeed), actions["NV-2"].value(KBP.maxSpeed)] == exp["nv2_speed_mps"]
    assert actions["NV-2"].value(KBP.safetyStopDistance) == exp["nv2_stop_distance_m"]
