"""Import, world maps and init of IFC files placed, built and named as real exports are (tests/ifc_wild.py).

Georeferenced (a site at easting 500 000 m, or a building placed there with an IfcMapConversion) and
rotated buildings come out in the building's local frame: bounds, meshes, maps and init's proposals
equal those of the same building at the origin. Geometry kinds (faceted Brep, mapped items, boolean
clipping, assemblies, walls of parts, IfcWallStandardCase), IFC4X3_ADD2, millimetre and foot units,
a building without storeys, an element in no spatial structure and odd names are imported, mapped
and initialised without a traceback.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import ifcopenshell
import ifcopenshell.util.placement
import numpy as np
import pytest
import trimesh
from rdflib import RDFS, Graph, URIRef

from ifc_factory import write_test_building
from ifc_traits import write_length_unit
from ifc_wild import (
    CLIP_HEIGHT_M,
    EASTING_M,
    NON_ASCII_NAME,
    NORTHING_M,
    QUOTED_NAME,
    ROTATION_DEG,
    write_far_geometry,
    write_geometry_kinds,
    write_placed,
    write_storey_heights,
    write_without_storeys,
)
from kbplanner.cli import main
from kbplanner.core.errors import KbplannerError
from kbplanner.core.iris import element_iri
from kbplanner.core.vocab import BOT, KBP
from kbplanner.model.dates import parse_date
from kbplanner.model.ifc_geometry import far_shift, model_frame
from kbplanner.model.ifc_import import ImportResult, import_ifc, import_ifc_graph
from kbplanner.project import Project
from kbplanner.scale.project_init import init_project
from kbplanner.world import maps
from kbplanner.world.build import build_world
from kbplanner.world.maps import StoreyMap, storey_map
from kbplanner.world.occupancy import Box

BASE = "https://w3id.org/kbplanner/data/wild/"
BOUNDS = (KBP.minX, KBP.minY, KBP.minZ, KBP.maxX, KBP.maxY, KBP.maxZ)


def _bounds(r: ImportResult, gid: str) -> list[float]:
    box = r.graph.value(element_iri(BASE, gid), KBP.bounds)
    assert box is not None, gid
    return [r.graph.value(box, p).toPython() for p in BOUNDS]


def _project(tmp: Path, ifc: Path) -> Path:
    """A project folder importing ``ifc`` (written by import-ifc, as a user would)."""
    out = tmp / f"proj-{ifc.stem}"
    import_ifc(ifc, out, base=BASE)
    (out / "project.toml").write_text(f'[project]\nname = "wild"\nbase_iri = "{BASE}"\n'
                                      f'[model]\nifc = "{ifc}"\n', encoding="utf-8")
    return out


def _map(project: Path, storey: str = "Level 1") -> StoreyMap:
    return storey_map(build_world(Project.load(project), parse_date("2030-01-01"), None), storey)


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, ImportResult]:
    """The plain test building (IFC4, metres, at the origin), imported."""
    tmp = tmp_path_factory.mktemp("reference")
    ifc = tmp / "plain.ifc"
    write_test_building(ifc, schema="IFC4")
    return ifc, import_ifc_graph(ifc, base=BASE)


# --- georeferenced and rotated buildings -------------------------------------------------------


@pytest.mark.parametrize("kind", ["site-far", "georeferenced", "rotated"])
def test_placed_buildings_come_out_in_the_buildings_local_frame(
    kind: str, reference: tuple[Path, ImportResult], tmp_path: Path
) -> None:
    ref_ifc, ref = reference
    t = write_placed(tmp_path / f"{kind}.ifc", kind)  # type: ignore[arg-type]
    r = import_ifc_graph(t.path, base=BASE)
    assert r.skipped == () and r.counts == ref.counts
    assert [(s.name, s.elevation_m) for s in r.storeys] == [(s.name, s.elevation_m) for s in ref.storeys]
    for gid in (*t.base.walls, *t.base.doors, *t.base.slabs):
        assert _bounds(r, gid) == pytest.approx(_bounds(ref, gid), abs=1e-6)
        pose = r.graph.value(element_iri(BASE, gid), KBP.installedPose)
        assert abs(r.graph.value(pose, KBP.x).toPython()) < 100.0  # local metres, not 500 000
    # the meshes as written (GLB holds float32): no loss at the scale of a building
    project = _project(tmp_path, t.path)
    for gid in t.base.walls:
        mesh = trimesh.load(project / "meshes" / f"{gid}.glb", force="mesh")
        assert np.allclose(mesh.bounds, ref.meshes[gid].bounds, atol=1e-5)
    ref_map = _map(_project(tmp_path, ref_ifc))
    m = _map(project)
    assert m.grid.origin == pytest.approx(ref_map.grid.origin, abs=1e-9)
    assert m.grid.occupied.shape == ref_map.grid.occupied.shape
    assert np.array_equal(m.grid.occupied, ref_map.grid.occupied)  # the map is the plan, cell for cell


def test_storeys_at_survey_coordinates_under_a_building_at_the_origin_move_the_frame(
    reference: tuple[Path, ImportResult], tmp_path: Path
) -> None:
    _, ref = reference
    t = write_placed(tmp_path / "far.ifc", "storeys-far")
    f = ifcopenshell.open(str(t.path))
    shift = far_shift(f, np.eye(4), 1.0)  # the walls' median, whole metres
    assert shift == (512_351.0, 5_403_211.0)
    moved = (EASTING_M - shift[0], NORTHING_M - shift[1])  # where the building's origin ends up
    r = import_ifc_graph(t.path, base=BASE)
    assert r.skipped == () and r.notes == ()
    for gid in (*t.base.walls, *t.base.slabs):
        expected = np.array(_bounds(ref, gid)) + [moved[0], moved[1], 0.0] * 2
        assert _bounds(r, gid) == pytest.approx(expected.tolist(), abs=1e-6)
    m = _map(_project(tmp_path, t.path))
    assert m.grid.is_occupied(5.0 + moved[0], 3.0 + moved[1])  # the partition
    assert not m.grid.is_occupied(2.5 + moved[0], 3.0 + moved[1])  # a room
    assert m.grid.occupied.size < 300 * 300


def test_a_shape_whose_own_coordinates_are_far_is_imported_and_noted(tmp_path: Path) -> None:
    t = write_far_geometry(tmp_path / "g.ifc")
    r = import_ifc_graph(t.path, base=BASE)
    far = t.extra["far_column"]
    assert [(n.kind, n.global_id) for n in r.notes] == [("far", far)]
    assert "5427.4 km from the model frame's origin" in r.notes[0].message
    assert _bounds(r, far)[0] == pytest.approx(EASTING_M)
    # its map is the building's: the far column is left off it, with a note, not 5 000 km wide
    project = _project(tmp_path, t.path)
    m = _map(project)
    assert m.grid.occupied.shape == (200, 280)
    assert len(m.notes) == 1 and m.notes[0].startswith("Far column (IfcColumn ")
    assert "5427.4 km from the rest of the storey's obstacles: left off the map" in m.notes[0]
    assert main(["world", str(project), "--date", "2030-01-01", "--out", str(tmp_path / "w")]) == 0


def test_a_map_too_large_to_hold_is_bad_input_naming_the_storey_and_the_fix(tmp_path: Path) -> None:
    world = build_world(Project.load(_project(tmp_path, write_test_building(tmp_path / "b.ifc").path)),
                        parse_date("2030-01-01"), None)
    level = world.storey("Level 1")
    assert level is not None
    with pytest.raises(KbplannerError) as error:
        maps._check_size(Box(0.0, 0.0, 20_000.0, 1_000.0), 0.05, level)
    assert "the map of Level 1 would be 20,000 x 1,000 m" in str(error.value)
    assert error.value.fix is not None and "kbp:siteExtent" in error.value.fix


def test_the_model_frame_is_the_buildings_levelled_placement(tmp_path: Path) -> None:
    t = write_placed(tmp_path / "g.ifc", "georeferenced")
    frame = model_frame(ifcopenshell.open(str(t.path)), 1.0)
    assert frame[:3, 3] == pytest.approx([512_345.6, 5_403_210.9, 0.0])
    assert math.degrees(math.atan2(frame[1, 0], frame[0, 0])) == pytest.approx(ROTATION_DEG)
    assert frame[2, 2] == pytest.approx(1.0)


@pytest.fixture(scope="module")
def reference_init(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("init-ref")
    write_test_building(tmp / "plain.ifc", schema="IFC4")
    out = tmp / "proj"
    assert init_project(tmp / "plain.ifc", out, check_plan=False).written
    return out


PROPOSALS = ("schedule.csv", "site/site_layout.ttl", "site/workers.ttl", "augmentation/grasp_points.ttl",
             "scenarios/storage_inside.ttl", "scenarios/storage_outside.ttl")


def _proposals(project: Path, stem: str) -> dict[str, str]:
    """init's proposals with the project's name (from the IFC file name) taken out of IRIs."""
    return {name: (project / name).read_text(encoding="utf-8").replace(f"/data/{stem}/", "/data/N/")
            .replace(f"{stem}_frames", "N_frames") for name in PROPOSALS}


def _init_equals_reference(ifc: Path, stem: str, reference_init: Path, tmp_path: Path) -> Path:
    out = tmp_path / "proj"
    assert main(["init", str(ifc), "--out", str(out), "--no-plan-check"]) == 0
    assert _proposals(out, stem) == _proposals(reference_init, "plain")
    assert main(["validate", str(out), "--scenario", "storage-inside"]) == 0
    assert main(["world", str(out), "--scenario", "storage-inside", "--out", str(tmp_path / "w")]) == 0
    return out


@pytest.mark.parametrize("kind", ["georeferenced", "storeys-far"])
def test_init_on_georeferenced_buildings_places_the_panels_at_survey_coordinates(
    kind: str, reference_init: Path, tmp_path: Path
) -> None:
    t = write_placed(tmp_path / "geo.ifc", kind)  # type: ignore[arg-type]
    out = tmp_path / "proj"
    assert main(["init", str(t.path), "--out", str(out), "--no-plan-check"]) == 0
    if kind == "georeferenced":  # in the building's frame: the same proposals as the plain building
        assert _proposals(out, "geo") == _proposals(reference_init, "plain")
    assert main(["validate", str(out), "--scenario", "storage-inside"]) == 0
    assert main(["world", str(out), "--scenario", "storage-inside", "--out", str(tmp_path / "w")]) == 0
    # each panel is where the plain building's panel is, moved as the building was
    copy = ifcopenshell.open(str(out / "model" / "geo_frames.ifc"))
    plain = ifcopenshell.open(str(reference_init / "model" / "plain_frames.ifc"))
    turn = math.radians(ROTATION_DEG) if kind == "georeferenced" else 0.0
    building = np.eye(4)
    building[:3, :3] = [[math.cos(turn), -math.sin(turn), 0.0], [math.sin(turn), math.cos(turn), 0.0],
                        [0.0, 0.0, 1.0]]
    building[:2, 3] = (EASTING_M, NORTHING_M)
    panels = copy.by_type("IfcMember")
    assert len(panels) == 7
    for panel in panels:
        placed = np.array(ifcopenshell.util.placement.get_local_placement(panel.ObjectPlacement))
        twin = plain.by_guid(panel.GlobalId)
        local = np.array(ifcopenshell.util.placement.get_local_placement(twin.ObjectPlacement))
        assert np.allclose(placed, building @ local, atol=1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("unit", ["MILLIMETER", "FOOT"])
def test_init_in_millimetres_and_feet_proposes_the_metre_buildings_project(
    unit: str, reference_init: Path, tmp_path: Path
) -> None:
    t = write_length_unit(tmp_path / f"u{unit.lower()}.ifc", unit)  # type: ignore[arg-type]
    _init_equals_reference(t.path, f"u{unit.lower()}", reference_init, tmp_path)


@pytest.mark.slow
def test_init_on_ifc4x3_add2_proposes_the_ifc4_buildings_project(
    reference_init: Path, tmp_path: Path
) -> None:
    write_test_building(tmp_path / "x3.ifc", schema="IFC4X3")
    assert ifcopenshell.open(str(tmp_path / "x3.ifc")).schema_identifier == "IFC4X3_ADD2"
    _init_equals_reference(tmp_path / "x3.ifc", "x3", reference_init, tmp_path)


# --- geometry kinds and names ----------------------------------------------------------------------


@pytest.mark.parametrize("schema", ["IFC2X3", "IFC4", "IFC4X3"])
def test_every_geometry_kind_is_imported_with_its_bounds(schema: str, tmp_path: Path) -> None:
    t = write_geometry_kinds(tmp_path / "k.ifc", schema)  # type: ignore[arg-type]
    r = import_ifc_graph(t.path, base=BASE)
    assert r.skipped == () and r.notes == ()
    x = t.extra
    expected = {
        "brep_column": [2.0, 2.0, 0.0, 2.4, 2.4, 2.5],
        "mapped_furniture": [2.5, 4.0, 0.0, 3.0, 5.0, 0.75],  # the mapping target turned it 90 degrees
        "clipped_wall": [6.0, 2.0, 0.0, 8.0, 2.1, CLIP_HEIGHT_M],
        "assembly": [6.0, 4.0, 0.0, 8.0, 4.1, 1.5],  # from its parts
        "wall_with_parts": [8.45, 1.0, 0.0, 8.55, 2.5, 2.5],
    }
    if schema != "IFC4X3":
        expected["standard_case"] = [1.0, 4.0, 0.0, 1.1, 5.5, 3.0]
    if schema != "IFC2X3":
        expected["tessellated"] = [1.5, 1.0, 0.0, 2.0, 1.5, 1.0]
    for key, box in expected.items():
        assert _bounds(r, x[key]) == pytest.approx(box, abs=1e-6), key
    # curved bodies, triangulated: within 1 mm of the true shape
    assert _bounds(r, x["round_column"]) == pytest.approx([3.3, 0.8, 0.0, 3.7, 1.2, 2.5], abs=1e-3)
    assert _bounds(r, x["railing"]) == pytest.approx([6.5, 4.97, 0.97, 8.5, 5.03, 1.03], abs=1e-3)
    g = r.graph
    assert str(g.value(element_iri(BASE, x["brep_column"]), KBP.ifcClass)) == "IfcColumn"
    assert g.value(element_iri(BASE, x["brep_column"]), KBP.volume).toPython() == pytest.approx(0.4)
    assert str(g.value(element_iri(BASE, x["brep_column"]), RDFS.label)) == NON_ASCII_NAME
    assert str(g.value(element_iri(BASE, x["clipped_wall"]), RDFS.label)) == QUOTED_NAME
    assert g.value(element_iri(BASE, x["assembly"]), RDFS.label) is None  # no Name: no label, still there
    assert (element_iri(BASE, x["assembly"]), KBP.globalId, None) in g
    assert r.counts["kbp:Wall"] == 10 + (3 if schema != "IFC4X3" else 2)


def test_geometry_kinds_and_odd_names_through_import_ifc_world_and_init(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    t = write_geometry_kinds(tmp_path / "kinds.ifc", "IFC4")
    out = tmp_path / "imported"
    assert main(["import-ifc", str(t.path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "Skipped: none" in text
    graph = Graph().parse(out / "model.ttl")  # the odd names survive Turtle
    assert {str(o) for o in graph.objects(None, RDFS.label)} >= {NON_ASCII_NAME, QUOTED_NAME}
    project = _project(tmp_path, t.path)
    m = _map(project)
    for x, y in ((2.2, 2.2), (2.75, 4.5), (7.0, 2.05), (6.5, 4.05), (8.5, 1.5), (3.5, 1.0), (7.5, 5.0),
                 (1.75, 1.25)):
        assert m.grid.is_occupied(x, y), (x, y)  # column, desk, clipped wall, assembly, wall of parts,
        # round column, railing, tessellated box
    assert not m.grid.is_occupied(3.5, 2.2)
    # the storey without a name is mapped by its GlobalId
    unnamed = next(gid for gid, (name, _z) in t.base.storeys.items() if name == "Level 2")
    assert _map(project, unnamed).storey.label == unnamed
    init = tmp_path / "init"
    assert main(["init", str(t.path), "--out", str(init), "--no-plan-check"]) == 0
    text = capsys.readouterr().out
    assert "'Standard case wall': 2 panels" in text
    parted = t.extra["wall_with_parts"]
    assert f"{parted} '': 2 panels" in text  # a wall of parts gets panels from its parts' body
    rows = {r["task_id"]: r for r in csv.DictReader(io.StringIO((init / "schedule.csv").read_text()))}
    built_later = set(rows["T-PART"]["elements"].split("|"))
    assert {parted, t.extra["wall_part_0"], t.extra["wall_part_1"]} <= built_later
    assert main(["validate", str(init), "--scenario", "storage-outside"]) == 0


# --- spatial structure ---------------------------------------------------------------------------


@pytest.mark.parametrize("schema", ["IFC2X3", "IFC4"])
def test_a_building_without_storeys_is_one_storey_and_an_uncontained_element_is_noted(
    schema: str, tmp_path: Path
) -> None:
    t = write_without_storeys(tmp_path / "n.ifc", schema)  # type: ignore[arg-type]
    r = import_ifc_graph(t.path, base=BASE)
    assert r.skipped == ()
    assert [(s.name, s.elevation_m) for s in r.storeys] == [("Test building (no storey)", 0.0)]
    storey = URIRef(f"{element_iri(BASE, t.base.building)}/storey")
    g = r.graph
    assert (storey, BOT.containsElement, element_iri(BASE, next(iter(t.base.walls)))) in g
    assert (storey, BOT.hasSpace, element_iri(BASE, next(iter(t.base.spaces)))) in g
    kinds = {(n.kind, n.global_id) for n in r.notes}
    assert kinds == {("storey", t.base.building), ("containment", t.extra["uncontained"])}
    assert r.counts["kbp:Wall"] == 5 and r.counts["kbp:Door"] == 2


def test_a_building_without_storeys_is_mapped_and_initialised(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    t = write_without_storeys(tmp_path / "n.ifc")
    project = _project(tmp_path, t.path)
    m = _map(project, "Test building (no storey)")
    assert m.grid.is_occupied(2.15, 2.15)  # the uncontained column is an obstacle by its height
    assert m.grid.is_occupied(5.0, 3.0) and not m.grid.is_occupied(2.5, 3.0)  # partition; room
    assert main(["world", str(project), "--date", "2030-01-01", "--out", str(tmp_path / "w")]) == 0
    out = tmp_path / "init"
    assert main(["init", str(t.path), "--out", str(out), "--no-plan-check"]) == 0
    assert "storey Test building (no storey)" in capsys.readouterr().out
    assert main(["validate", str(out), "--scenario", "storage-inside"]) == 0


def test_a_model_without_any_storey_or_building_is_a_clear_error(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    t = write_without_storeys(tmp_path / "n.ifc")
    f = ifcopenshell.open(str(t.path))
    for rel in f.by_type("IfcRelContainedInSpatialStructure"):
        f.remove(rel)
    building = f.by_type("IfcBuilding")[0]
    for rel in list(building.Decomposes or ()) + list(building.IsDecomposedBy or ()):
        f.remove(rel)
    f.remove(building)
    f.write(str(tmp_path / "bare.ifc"))
    project = _project(tmp_path, tmp_path / "bare.ifc")
    code = main(["world", str(project), "--date", "2030-01-01", "--out", str(tmp_path / "w")])
    assert code == 2
    err = capsys.readouterr().err
    assert "no storey to map" in err and "fix: export the model with its building and storeys" in err
    assert "Traceback" not in err


@pytest.mark.parametrize(("kind", "noted"), [("absolute-elevation", ["Level 1", "Level 2"]),
                                            ("storeys-at-zero", ["Level 2"])])
def test_a_storey_elevation_that_disagrees_with_its_placement_follows_its_elements(
    kind: str, noted: list[str], reference: tuple[Path, ImportResult], tmp_path: Path
) -> None:
    _, ref = reference
    t = write_storey_heights(tmp_path / "s.ifc", kind)  # type: ignore[arg-type]
    r = import_ifc_graph(t.path, base=BASE)
    assert [(s.name, s.elevation_m) for s in r.storeys] == [("Level 1", 0.0), ("Level 2", 3.0)]
    notes = [n for n in r.notes if n.kind == "storey"]
    assert sorted(n.name for n in notes) == noted
    assert all("differ" in n.message and "correct the storey's Elevation" in n.message for n in notes)
    for gid in t.base.walls:
        assert _bounds(r, gid) == pytest.approx(_bounds(ref, gid), abs=1e-6)
    m = _map(_project(tmp_path, t.path))
    assert m.storey.elevation_m == 0.0 and 0.03 < 1.0 - m.grid.free_fraction < 0.2  # walls, not everything


def test_storeys_with_the_same_name_are_noted_and_chosen_by_globalid(tmp_path: Path) -> None:
    b = write_test_building(tmp_path / "same.ifc", schema="IFC4")
    f = ifcopenshell.open(str(b.path))
    for storey in f.by_type("IfcBuildingStorey"):
        storey.Name = "Level"
    f.write(str(b.path))
    r = import_ifc_graph(b.path, base=BASE)
    notes = [n for n in r.notes if n.kind == "storey"]
    assert sorted(n.global_id for n in notes) == sorted(b.storeys)
    upper = next(gid for gid, (_name, z) in b.storeys.items() if z == 3.0)
    assert all("2 storeys are named 'Level'" in n.message for n in notes)
    assert any(f"--storey {upper}" in n.message for n in notes)
    world = build_world(Project.load(_project(tmp_path, b.path)), parse_date("2030-01-01"), None)
    assert storey_map(world, "Level").storey.elevation_m == 0.0  # the lowest of the name
    assert storey_map(world, str(element_iri(BASE, upper))).storey.elevation_m == 3.0
    assert storey_map(world, upper).storey.elevation_m == 3.0  # the GlobalId the note names
