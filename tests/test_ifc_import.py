"""IFC import: the Duplex (IFC2X3, Revit) hand-verified, and small buildings written by ifc_factory."""

from __future__ import annotations

import hashlib
import math
import os
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from rdflib import RDF, RDFS, XSD, Graph, Literal, URIRef

from ifc_factory import TestBuilding, write_test_building
from kbplanner.core.errors import IfcError
from kbplanner.core.iris import element_iri
from kbplanner.core.vocab import BOT, KBP
from kbplanner.model.ifc_geometry import matrix_to_pose
from kbplanner.model.ifc_import import ImportResult, import_ifc, import_ifc_graph

BASE = "https://w3id.org/kbplanner/data/test/"
DUPLEX_CANDIDATES = (
    Path(__file__).resolve().parents[1] / "data" / "case_study" / "model" / "Duplex_A_20110907.ifc",
    Path("/work/shared/data/ifc/Duplex_A_20110907.ifc"),
)


def duplex_path() -> Path:
    for p in DUPLEX_CANDIDATES:
        if p.is_file():
            return p
    pytest.skip("the Duplex IFC is not on this machine")


@pytest.fixture(scope="module")
def duplex(tmp_path_factory: pytest.TempPathFactory) -> ImportResult:
    return import_ifc(duplex_path(), tmp_path_factory.mktemp("duplex"), base=BASE)


def num(g: Graph, s: URIRef, p: URIRef) -> float:
    value = g.value(s, p)
    assert isinstance(value, Literal), f"{s} has no {p}"
    assert value.datatype == XSD.double
    return float(value)


def el(gid: str) -> URIRef:
    return element_iri(BASE, gid)


def pose_matrix(g: Graph, node: URIRef) -> np.ndarray:
    pose = g.value(node, KBP.installedPose)
    assert isinstance(pose, URIRef)
    x, y, z = (num(g, pose, p) for p in (KBP.x, KBP.y, KBP.z))
    roll, pitch, yaw = (num(g, pose, p) for p in (KBP.roll, KBP.pitch, KBP.yaw))
    rx = trimesh.transformations.rotation_matrix(roll, [1, 0, 0])
    ry = trimesh.transformations.rotation_matrix(pitch, [0, 1, 0])
    rz = trimesh.transformations.rotation_matrix(yaw, [0, 0, 1])
    m: np.ndarray = rz @ ry @ rx
    m[:3, 3] = [x, y, z]
    return m


def bounds(g: Graph, node: URIRef) -> np.ndarray:
    box = g.value(node, KBP.bounds)
    assert isinstance(box, URIRef)
    return np.array([[num(g, box, KBP.minX), num(g, box, KBP.minY), num(g, box, KBP.minZ)],
                     [num(g, box, KBP.maxX), num(g, box, KBP.maxY), num(g, box, KBP.maxZ)]])


def storey_walls(g: Graph) -> dict[str, tuple[int, int]]:
    """Storey name -> (interior walls, exterior walls)."""
    out: dict[str, tuple[int, int]] = {}
    for storey in g.subjects(RDF.type, BOT.Storey):
        walls = [w for w in g.objects(storey, BOT.containsElement) if (w, RDF.type, KBP.Wall) in g]
        ext = sum(1 for w in walls if g.value(w, KBP.isExternal).toPython() is True)
        out[str(g.value(storey, RDFS.label))] = (len(walls) - ext, ext)
    return out


# ---------------------------------------------------------------------------------------------
# The Duplex


def test_duplex_has_four_storeys_at_their_elevations_in_metres(duplex: ImportResult) -> None:
    assert [(s.name, s.elevation_m) for s in duplex.storeys] == [
        ("T/FDN", -1.25), ("Level 1", 0.0), ("Level 2", 3.1), ("Roof", 6.0)]
    g = duplex.graph
    building = next(g.subjects(RDF.type, BOT.Building))
    assert len(list(g.objects(building, BOT.hasStorey))) == 4
    assert (next(g.subjects(RDF.type, BOT.Site)), BOT.hasBuilding, building) in g
    assert duplex.schema == "IFC2X3" and duplex.length_unit_m == 1.0


def test_duplex_has_57_walls_of_which_56_are_standard_case(duplex: ImportResult) -> None:
    g = duplex.graph
    walls = list(g.subjects(RDF.type, KBP.Wall))
    classes = sorted(str(g.value(w, KBP.ifcClass)) for w in walls)
    assert len(walls) == 57 == duplex.counts["kbp:Wall"]
    assert classes.count("IfcWallStandardCase") == 56 and classes.count("IfcWall") == 1


def test_duplex_interior_and_exterior_walls_per_storey_follow_pset_wall_common(duplex: ImportResult) -> None:
    g = duplex.graph
    assert storey_walls(g) == {"Level 1": (14, 7), "Level 2": (20, 5), "T/FDN": (0, 7), "Roof": (0, 4)}
    sources = {str(g.value(w, KBP.isExternalSource)) for w in g.subjects(RDF.type, KBP.Wall)}
    assert sources == {"Pset_WallCommon.IsExternal"}


def test_duplex_has_14_doors_24_windows_21_spaces_and_50_openings(duplex: ImportResult) -> None:
    c = duplex.counts
    assert (c["kbp:Door"], c["kbp:Window"], c["bot:Space"], c["kbp:Opening"]) == (14, 24, 21, 50)
    assert duplex.skipped == ()


def test_duplex_door_widths_and_heights_are_in_metres(duplex: ImportResult) -> None:
    g = duplex.graph
    sizes = {(num(g, d, KBP.overallWidth), num(g, d, KBP.overallHeight))
             for d in g.subjects(RDF.type, KBP.Door)}
    assert sizes == {(0.762, 2.032), (0.813, 2.42), (0.864, 2.032), (1.25, 2.01)}


def test_duplex_doors_are_hosted_by_the_wall_whose_opening_they_fill(duplex: ImportResult) -> None:
    g = duplex.graph
    for door in g.subjects(RDF.type, KBP.Door):
        opening = g.value(door, KBP.fillsOpening)
        host = g.value(door, KBP.hostWall)
        assert (opening, RDF.type, KBP.Opening) in g
        assert (host, RDF.type, KBP.Wall) in g
        assert (host, KBP.hasOpening, opening) in g and (host, BOT.hostsElement, door) in g
        assert g.value(opening, KBP.meshFile) is None  # openings keep RDF, not meshes


def test_duplex_wall_pose_is_its_ifc_placement(duplex: ImportResult) -> None:
    # Read by hand from the file: the party wall is placed at (4.4, -0.417, 3.1), its x axis along -y.
    g = duplex.graph
    wall = next(w for w in g.subjects(RDF.type, KBP.Wall)
                if str(g.value(w, RDFS.label)).endswith("Dimising Wall:143239"))
    pose = g.value(wall, KBP.installedPose)
    assert pose == URIRef(f"{wall}/installed-pose") and (pose, RDF.type, KBP.Pose) in g
    assert [num(g, pose, p) for p in (KBP.x, KBP.y, KBP.z, KBP.roll, KBP.pitch)] == [4.4, -0.417, 3.1, 0, 0]
    assert num(g, pose, KBP.yaw) == pytest.approx(-math.pi / 2, abs=1e-9)


def test_duplex_meshes_exist_load_and_match_the_bounds_in_the_graph(duplex: ImportResult) -> None:
    g = duplex.graph
    assert duplex.out_dir is not None
    with_mesh = list(g.subject_objects(KBP.meshFile))
    assert len(with_mesh) == len(duplex.meshes) == len(list((duplex.out_dir / "meshes").iterdir())) == 236
    for node, rel in with_mesh[::20]:
        loaded = trimesh.load(duplex.out_dir / str(rel), force="mesh")
        assert np.allclose(loaded.bounds, bounds(g, node), atol=1e-5)


def test_duplex_furniture_in_a_space_is_contained_by_the_space_and_its_storey(duplex: ImportResult) -> None:
    g = duplex.graph
    in_space = [(s, e) for s, e in g.subject_objects(BOT.containsElement) if (s, RDF.type, BOT.Space) in g]
    assert len(in_space) == 61
    for space, element in in_space:
        storey = next(s for s in g.subjects(BOT.hasSpace, space))
        assert (storey, BOT.containsElement, element) in g


def test_duplex_layered_walls_get_a_mass_with_its_assumption(duplex: ImportResult) -> None:
    g = duplex.graph
    walls = list(g.subjects(RDF.type, KBP.Wall))
    with_mass = [w for w in walls if g.value(w, KBP.mass) is not None]
    assert len(with_mass) == 57
    foundation = next(w for w in walls if "Foundation - Concrete (417mm)" in str(g.value(w, RDFS.label)))
    assert num(g, foundation, KBP.mass) == pytest.approx(num(g, foundation, KBP.volume) * 2400, rel=1e-6)
    assert "2400" in str(g.value(foundation, KBP.massAssumption))


# ---------------------------------------------------------------------------------------------
# Buildings written with ifcopenshell.api


def build(tmp_path: Path, **kwargs: object) -> tuple[TestBuilding, ImportResult]:
    b = write_test_building(tmp_path / "model.ifc", **kwargs)  # type: ignore[arg-type]
    return b, import_ifc(b.path, tmp_path / "project", base=BASE)


def test_an_ifc4_file_in_millimetres_comes_out_in_metres(tmp_path: Path) -> None:
    b, r = build(tmp_path, schema="IFC4", unit_mm=True)
    g = r.graph
    assert r.length_unit_m == 0.001 and r.schema == "IFC4"
    assert {s.global_id: s.elevation_m for s in r.storeys} == {k: v[1] for k, v in b.storeys.items()}
    for gid, door in b.doors.items():
        assert num(g, el(gid), KBP.overallWidth) == door.width_m
        assert num(g, el(gid), KBP.overallHeight) == door.height_m
    slab = next(gid for gid, storey in b.slabs.items() if b.storeys[storey][1] == 3.0)
    assert np.allclose(bounds(g, el(slab)), [[0, 0, 2.8], [10, 6, 3.0]])
    assert num(g, el(slab), KBP.volume) == pytest.approx(12.0)
    assert num(g, el(slab), KBP.mass) == pytest.approx(12.0 * 2400)
    pose = g.value(el(slab), KBP.installedPose)
    assert num(g, pose, KBP.z) == 2.8


def test_the_same_building_in_metres_and_millimetres_gives_the_same_graph(tmp_path: Path) -> None:
    _, metres = build(tmp_path / "m", schema="IFC4", unit_mm=False)
    _, millimetres = build(tmp_path / "mm", schema="IFC4", unit_mm=True)

    def facts(r: ImportResult) -> dict[tuple[str, str], list[object]]:
        out: dict[tuple[str, str], list[object]] = {}
        for s, p, o in r.graph:
            out.setdefault((str(s), str(p)), []).append(o.toPython() if isinstance(o, Literal) else str(o))
        return {k: sorted(v, key=str) for k, v in out.items()}

    a, b = facts(metres), facts(millimetres)
    assert a.keys() == b.keys()
    for key, values in a.items():
        if all(isinstance(v, float) for v in values):
            assert values == pytest.approx(b[key], abs=1e-5), key
        else:
            assert values == b[key], key


def test_walls_without_pset_are_classified_by_their_names(tmp_path: Path) -> None:
    b, r = build(tmp_path, schema="IFC2X3", wall_psets=False, wall_names="descriptive")
    g = r.graph
    assert r.schema == "IFC2X3"
    for gid, wall in b.walls.items():
        assert str(g.value(el(gid), KBP.isExternalSource)) == "name"
        assert g.value(el(gid), KBP.isExternal).toPython() is wall.is_external
        assert str(g.value(el(gid), KBP.ifcClass)) == "IfcWallStandardCase"


def test_space_boundaries_decide_when_neither_pset_nor_name_tells(tmp_path: Path) -> None:
    b, r = build(tmp_path, schema="IFC4", wall_psets=False, wall_names="plain", space_boundaries=True)
    g = r.graph
    assert sorted(str(g.value(el(gid), KBP.isExternalSource)) for gid in b.walls) == ["space boundaries"] * 10
    assert {gid: g.value(el(gid), KBP.isExternal).toPython() for gid in b.walls} == {
        gid: w.is_external for gid, w in b.walls.items()}


def test_walls_with_no_evidence_default_to_internal(tmp_path: Path) -> None:
    b, r = build(tmp_path, wall_psets=False, wall_names="plain")
    g = r.graph
    assert {(str(g.value(el(gid), KBP.isExternalSource)), g.value(el(gid), KBP.isExternal).toPython())
            for gid in b.walls} == {("default", False)}


def test_an_element_whose_geometry_fails_is_skipped_and_reported(tmp_path: Path) -> None:
    b, r = build(tmp_path, broken_element=True)
    assert b.broken is not None
    assert [s.global_id for s in r.skipped] == [b.broken]
    assert "extrusion" in r.skipped[0].reason and r.skipped[0].ifc_class == "IfcBuildingElementProxy"
    g = r.graph
    assert (el(b.broken), RDF.type, KBP.OtherElement) in g  # still in the model, without geometry
    assert g.value(el(b.broken), KBP.meshFile) is None
    assert len(r.meshes) == 10 + 3 + 2 + 4  # every other element and space has its mesh


def test_door_size_comes_from_its_geometry_when_overall_width_is_missing(tmp_path: Path) -> None:
    b, r = build(tmp_path, door_size_attributes=False)
    g = r.graph
    for gid, door in b.doors.items():
        assert num(g, el(gid), KBP.overallWidth) == pytest.approx(door.width_m, abs=1e-6)
        assert num(g, el(gid), KBP.overallHeight) == pytest.approx(door.height_m, abs=1e-6)


def test_a_door_is_hosted_by_the_wall_through_the_opening_it_fills(tmp_path: Path) -> None:
    b, r = build(tmp_path)
    g = r.graph
    for gid, door in b.doors.items():
        assert g.value(el(gid), KBP.hostWall) == el(door.host_wall)
        assert g.value(el(gid), KBP.fillsOpening) == el(door.opening)
        assert (el(door.host_wall), KBP.hasOpening, el(door.opening)) in g
        assert (el(door.host_wall), BOT.hostsElement, el(gid)) in g
        assert (el(door.storey), BOT.containsElement, el(gid)) in g
    front = next(gid for gid, d in b.doors.items() if d.name.startswith("Door front"))
    assert (str(g.value(el(front), KBP.isExternalSource)), g.value(el(front), KBP.isExternal).toPython()) \
        == ("Pset_DoorCommon.IsExternal", True)


def test_installed_pose_and_mesh_are_in_the_same_site_frame(tmp_path: Path) -> None:
    b, r = build(tmp_path, site_origin=(100.0, 50.0, 2.0))
    g = r.graph
    # The site's offset is gone: the building starts at the site origin.
    slab = next(iter(b.slabs))
    assert np.allclose(bounds(g, el(slab)), [[0, 0, -0.2], [10, 6, 0]])
    for gid, door in b.doors.items():
        local = trimesh.transform_points(r.meshes[gid].vertices, np.linalg.inv(pose_matrix(g, el(gid))))
        assert np.allclose(local.min(axis=0)[[0, 2]], [0, 0], atol=1e-6)
        assert np.allclose(local.max(axis=0)[[0, 2]], [door.width_m, door.height_m], atol=1e-6)
    partition_door = next(gid for gid, d in b.doors.items() if d.name.startswith("Door p1"))
    assert num(g, g.value(el(partition_door), KBP.installedPose), KBP.yaw) == pytest.approx(math.pi / 2)


def test_furniture_in_a_space_is_contained_by_the_space_and_its_storey(tmp_path: Path) -> None:
    b, r = build(tmp_path, furniture_per_space=2)
    g = r.graph
    assert r.counts["kbp:Furniture"] == 8
    for gid, space in b.furniture.items():
        assert (el(space), BOT.containsElement, el(gid)) in g
        assert (el(b.spaces[space]), BOT.containsElement, el(gid)) in g
        assert (el(b.spaces[space]), BOT.hasSpace, el(space)) in g
        assert num(g, el(gid), KBP.mass) == pytest.approx(0.8 * 0.6 * 0.75 * 450)


def test_a_weight_quantity_gives_the_mass_before_any_density(tmp_path: Path) -> None:
    b, r = build(tmp_path, slab_net_weight_kg=5000.0)
    g = r.graph
    for gid in b.slabs:
        assert num(g, el(gid), KBP.mass) == 5000.0
        assert str(g.value(el(gid), KBP.massAssumption)) == "quantity set Qto_SlabBaseQuantities.NetWeight"


def test_layered_walls_weigh_by_the_thickness_weighted_density_of_their_layers(tmp_path: Path) -> None:
    b, r = build(tmp_path)
    g = r.graph
    density = (0.1 * 1900 + 0.2 * 1400) / 0.3
    for gid, wall in b.walls.items():
        expected = density if wall.is_external else 450
        assert num(g, el(gid), KBP.mass) == pytest.approx(num(g, el(gid), KBP.volume) * expected, rel=1e-4)
    interior = next(gid for gid, w in b.walls.items() if not w.is_external)
    assert str(g.value(el(interior), KBP.material)) == "Wood - Stud"


def test_an_ifc4x3_file_imports_with_geometry(tmp_path: Path) -> None:
    b, r = build(tmp_path, schema="IFC4X3")
    assert r.schema == "IFC4X3_ADD2"
    assert r.counts["kbp:Wall"] == len(b.walls) and r.skipped == ()
    assert len(r.meshes) == len(b.walls) + len(b.doors) + len(b.slabs) + len(b.spaces)


def test_every_graph_node_is_an_iri_and_every_element_is_keyed_by_global_id(tmp_path: Path) -> None:
    _, r = build(tmp_path, furniture_per_space=1, space_boundaries=True)
    g = r.graph
    assert all(isinstance(t, URIRef | Literal) for triple in g for t in triple)
    for node in g.subjects(KBP.globalId, None):
        assert node == el(str(g.value(node, KBP.globalId)))


def test_progress_reports_every_shape_and_ends_at_the_total(tmp_path: Path) -> None:
    b = write_test_building(tmp_path / "m.ifc")
    calls: list[tuple[int, int]] = []
    import_ifc_graph(b.path, base=BASE, progress=lambda done, total: calls.append((done, total)))
    assert calls[-1] == (19, 19) and len(calls) >= 19
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)


# ---------------------------------------------------------------------------------------------
# Output files

def tree_digest(directory: Path) -> dict[str, str]:
    return {str(p.relative_to(directory)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(directory.rglob("*")) if p.is_file()}


def test_output_is_byte_identical_across_runs_hash_seeds_and_process_counts(tmp_path: Path) -> None:
    b = write_test_building(tmp_path / "m.ifc", furniture_per_space=1, space_boundaries=True)
    script = ("import sys; from pathlib import Path; from kbplanner.model.ifc_import import import_ifc; "
              "a = sys.argv; "
              "import_ifc(Path(a[1]), Path(a[2]), base=a[3], processes=int(a[4]))")
    digests = []
    for seed, processes in (("1", "1"), ("2", "2")):
        out = tmp_path / f"out-{seed}"
        env = {**os.environ, "PYTHONHASHSEED": seed}
        subprocess.run([sys.executable, "-c", script, str(b.path), str(out), BASE, processes],
                       check=True, env=env, timeout=120)
        digests.append(tree_digest(out))
    assert digests[0] == digests[1]
    assert "model.ttl" in digests[0] and len(digests[0]) == 1 + 19 + 4 + 2  # + skipped.json, skipped.csv


def test_reimport_replaces_old_meshes_and_leaves_no_temporary_files(tmp_path: Path) -> None:
    b = write_test_building(tmp_path / "m.ifc")
    out = tmp_path / "project"
    (out / "meshes").mkdir(parents=True)
    (out / "meshes" / "stale.glb").write_bytes(b"old")
    (out / "project.toml").write_text("[project]\nname = 'kept'\n")
    import_ifc(b.path, out, base=BASE)
    assert sorted(p.name for p in out.iterdir()) == ["meshes", "model.ttl", "project.toml", "skipped.csv",
                                                    "skipped.json"]
    assert not (out / "meshes" / "stale.glb").exists()
    assert Graph().parse(out / "model.ttl", format="turtle").isomorphic(
        import_ifc_graph(b.path, base=BASE).graph)


# ---------------------------------------------------------------------------------------------
# Bad input


def test_a_missing_file_raises_an_ifc_error_naming_it(tmp_path: Path) -> None:
    with pytest.raises(IfcError, match="not found") as err:
        import_ifc(tmp_path / "nope.ifc", tmp_path / "out", base=BASE)
    assert "nope.ifc" in str(err.value) and err.value.fix
    assert not (tmp_path / "out").exists()


def test_a_text_file_that_is_not_ifc_raises_an_ifc_error(tmp_path: Path) -> None:
    path = tmp_path / "notes.ifc"
    path.write_text("these are meeting notes, not a building\n")
    with pytest.raises(IfcError, match="not an IFC file") as err:
        import_ifc_graph(path, base=BASE)
    assert str(path) in str(err.value) and "fix:" in str(err.value)


def test_an_unsupported_schema_raises_an_ifc_error_naming_the_schema(tmp_path: Path) -> None:
    b = write_test_building(tmp_path / "m.ifc", schema="IFC2X3")
    old = tmp_path / "old.ifc"
    old.write_text(b.path.read_text().replace("FILE_SCHEMA(('IFC2X3'))", "FILE_SCHEMA(('IFC2X2_FINAL'))"))
    with pytest.raises(IfcError, match="unsupported IFC schema IFC2X2_FINAL") as err:
        import_ifc_graph(old, base=BASE)
    assert "IFC4" in (err.value.fix or "")


def test_a_truncated_file_raises_instead_of_importing_half_a_building(tmp_path: Path) -> None:
    b = write_test_building(tmp_path / "m.ifc")
    cut = tmp_path / "cut.ifc"
    cut.write_bytes(b.path.read_bytes()[:5000])
    with pytest.raises(IfcError, match="incomplete"):
        import_ifc_graph(cut, base=BASE)


def test_an_ifczip_archive_is_refused_with_a_hint_to_unzip_it(tmp_path: Path) -> None:
    b = write_test_building(tmp_path / "m.ifc")
    archive = tmp_path / "m.ifczip"
    with zipfile.ZipFile(archive, "w") as z:
        z.write(b.path, "m.ifc")
    with pytest.raises(IfcError, match="ZIP"):
        import_ifc_graph(archive, base=BASE)


def test_matrix_to_pose_recovers_roll_pitch_yaw() -> None:
    angles = (0.3, -0.4, 2.5)
    m = trimesh.transformations.euler_matrix(*angles, axes="sxyz")
    m[:3, 3] = [1.0, -2.0, 0.5]
    pose = matrix_to_pose(m)
    assert (pose.x, pose.y, pose.z) == (1.0, -2.0, 0.5)
    assert (pose.roll, pose.pitch, pose.yaw) == pytest.approx(angles, abs=1e-9)


def test_an_element_whose_optional_data_cannot_be_read_is_kept_with_a_note(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from kbplanner.model import ifc_semantics

    b = write_test_building(tmp_path / "m.ifc")
    bad = next(gid for gid, w in b.walls.items() if not w.is_external)
    real = ifc_semantics.material_names

    def failing(product: object) -> list[str]:
        if getattr(product, "GlobalId", None) == bad:
            raise ValueError("malformed material association")
        return real(product)

    monkeypatch.setattr(ifc_semantics, "material_names", failing)
    r = import_ifc_graph(b.path, base=BASE)
    assert r.skipped == ()
    assert [(n.global_id, n.kind, n.message) for n in r.notes if n.kind == "unreadable"] == [
        (bad, "unreadable", "mass not imported: ValueError: malformed material association"),
        (bad, "unreadable", "materials not imported: ValueError: malformed material association")]
    g = r.graph
    assert (el(bad), RDF.type, KBP.Wall) in g and (el(bad), KBP.installedPose, None) in g
    assert (el(bad), KBP.material, None) not in g
    assert r.counts["kbp:Wall"] == len(b.walls)


def test_an_element_whose_placement_cannot_be_read_is_kept_without_a_pose(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from kbplanner.model import ifc_geometry

    b = write_test_building(tmp_path / "m.ifc")
    bad = next(gid for gid, w in b.walls.items() if not w.is_external)
    real = ifc_geometry.placement_matrix

    def failing(product: Any, scale: float, memo: dict[int, Any] | None = None) -> Any:
        if getattr(product, "GlobalId", None) == bad:
            raise ValueError("malformed placement")
        return real(product, scale, memo)

    monkeypatch.setattr(ifc_geometry, "placement_matrix", failing)
    r = import_ifc_graph(b.path, base=BASE)
    assert r.skipped == ()
    assert [(n.global_id, n.message.split(";")[0]) for n in r.notes if n.kind == "unreadable"] == [
        (bad, "placement not imported (ValueError: malformed placement)")]
    g = r.graph
    assert (el(bad), KBP.installedPose, None) not in g and (el(bad), KBP.bounds, None) in g


def test_an_element_whose_data_cannot_be_read_at_all_is_dropped_and_reported(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from kbplanner.model import ifc_semantics

    b = write_test_building(tmp_path / "m.ifc")
    bad = next(gid for gid, w in b.walls.items() if not w.is_external)
    real = ifc_semantics.kbp_class

    def failing(product: Any) -> Any:
        if getattr(product, "GlobalId", None) == bad:
            raise ValueError("unknown entity")
        return real(product)

    monkeypatch.setattr(ifc_semantics, "kbp_class", failing)
    r = import_ifc_graph(b.path, base=BASE)
    assert [(s.global_id, s.reason, s.in_graph, s.task_class) for s in r.skipped] == [
        (bad, "could not read its data (ValueError: unknown entity)", False, True)]
    assert [s.global_id for s in r.blocking] == [bad]
    g = r.graph
    assert not list(g.triples((el(bad), None, None))) and not list(g.triples((None, None, el(bad))))
    assert r.counts["kbp:Wall"] == len(b.walls) - 1
