"""Import and world maps of IFC files with the traits of real exports (tests/ifc_traits.py)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
import trimesh
from rdflib import RDF, Literal

from ifc_traits import SPLIT_LEVEL_M, write_length_unit, write_mass_unit, write_traits, write_unnamed_sets
from kbplanner.cli import main
from kbplanner.core.iris import element_iri
from kbplanner.core.vocab import KBP
from kbplanner.model.dates import parse_date
from kbplanner.model.ifc_import import import_ifc_graph
from kbplanner.project import Project
from kbplanner.world.build import build_world
from kbplanner.world.levels import RAISED, STAIR
from kbplanner.world.maps import storey_map
from kbplanner.world.occupancy import Box, occupancy_from_meshes
from kbplanner.world.raster import fill_from_outline, fill_section

BASE = "https://w3id.org/kbplanner/data/traits/"


def el(gid: str) -> object:
    return element_iri(BASE, gid)


@pytest.mark.parametrize("schema", ["IFC2X3", "IFC4"])
def test_unnamed_property_and_quantity_sets_drop_no_door_window_or_wall(tmp_path: Path, schema: str) -> None:
    t = write_unnamed_sets(tmp_path / "m.ifc", schema)  # type: ignore[arg-type]
    assert int(t.extra["unnamed_sets"]) > 10
    r = import_ifc_graph(t.path, base=BASE)
    assert r.skipped == ()
    assert r.counts["kbp:Door"] == len(t.base.doors) == 3
    assert r.counts["kbp:Window"] == len(t.windows) == 2
    assert r.counts["kbp:Wall"] == len(t.base.walls) == 10
    g = r.graph
    for gid, wall in t.base.walls.items():  # the named set next to the unnamed one is still read
        assert (el(gid), KBP.isExternal, Literal(wall.is_external)) in g
        assert (el(gid), KBP.mass, None) in g and g.value(el(gid), KBP.mass).toPython() == 400.0
    for gid in t.base.doors:
        assert g.value(el(gid), KBP.mass).toPython() == 35.0
        assert "(unnamed #" in str(g.value(el(gid), KBP.massAssumption))
    for gid in t.windows:
        assert g.value(el(gid), KBP.mass).toPython() == 20.0
    # the windows stand in the building (millimetre file): no far geometry, no implausible mass
    assert [n for n in r.notes if n.kind in ("far", "mass")] == []


def test_import_ifc_cli_exits_0_on_unnamed_sets_and_writes_skipped_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    t = write_unnamed_sets(tmp_path / "m.ifc")
    out = tmp_path / "proj"
    assert main(["import-ifc", str(t.path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "kbp:Window" in text and "Skipped: none" in text
    data = json.loads((out / "skipped.json").read_text())
    assert data["skipped"] == [] and data["blocking"] == 0


def test_gram_mass_unit_is_converted_and_an_implausible_mass_is_noted(tmp_path: Path) -> None:
    t = write_mass_unit(tmp_path / "m.ifc", "gram", 13.63)
    r = import_ifc_graph(t.path, base=BASE)
    assert r.units is not None and r.units.mass_name == "gram" and r.units.mass_kg == pytest.approx(0.001)
    for gid in t.base.slabs:
        assert r.graph.value(el(gid), KBP.mass).toPython() == pytest.approx(0.014, abs=1e-9)
    notes = [n for n in r.notes if n.kind == "mass"]
    assert sorted(n.global_id for n in notes) == sorted(t.base.slabs)
    assert all("gram" in n.message and "MASSUNIT" in n.message for n in notes)


def test_gram_mass_note_is_printed_and_in_skipped_csv(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    t = write_mass_unit(tmp_path / "m.ifc", "gram", 13.63)
    out = tmp_path / "proj"
    assert main(["import-ifc", str(t.path), "--out", str(out)]) == 0  # a doubt, not a skipped element
    text = capsys.readouterr().out
    assert "mass unit gram = 0.001 kg" in text and "[mass]" in text
    rows = list(csv.DictReader((out / "skipped.csv").open()))
    assert [r["kind"] for r in rows] == ["note: mass", "note: mass"]


def test_pound_mass_unit_is_converted_without_a_note(tmp_path: Path) -> None:
    t = write_mass_unit(tmp_path / "m.ifc", "pound", 1000.0)
    r = import_ifc_graph(t.path, base=BASE)
    assert r.units is not None and r.units.mass_name == "pound"
    for gid in t.base.slabs:  # 1000 lb; ifcopenshell's pound is 0.454 kg
        assert r.graph.value(el(gid), KBP.mass).toPython() == pytest.approx(453.6, rel=2e-3)
    assert [n for n in r.notes if n.kind == "mass"] == []


@pytest.mark.parametrize(("unit", "metres"), [("MILLIMETER", 0.001), ("INCH", 0.0254), ("FOOT", 0.3048)])
def test_length_units_give_the_same_building_in_metres(tmp_path: Path, unit: str, metres: float) -> None:
    reference = import_ifc_graph(write_length_unit(tmp_path / "m.ifc", "MILLIMETER").path, base=BASE)
    t = write_length_unit(tmp_path / f"{unit}.ifc", unit)  # type: ignore[arg-type]
    r = import_ifc_graph(t.path, base=BASE)
    assert r.length_unit_m == pytest.approx(metres)
    assert r.counts == reference.counts and r.skipped == ()
    for gid in t.base.walls:
        box = r.graph.value(el(gid), KBP.bounds)
        ref = reference.graph.value(el(gid), KBP.bounds)
        for prop in (KBP.minX, KBP.minY, KBP.minZ, KBP.maxX, KBP.maxY, KBP.maxZ):
            assert r.graph.value(box, prop).toPython() == pytest.approx(
                reference.graph.value(ref, prop).toPython(), abs=1e-4)


@pytest.fixture(scope="module")
def traits(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    directory = tmp_path_factory.mktemp("traits")
    t = write_traits(directory / "model.ifc")
    (directory / "project.toml").write_text(f'[project]\nname = "traits"\nbase_iri = "{BASE}"\n'
                                            '[model]\nifc = "model.ifc"\n', encoding="utf-8")
    return directory, t


def test_traits_import_keeps_everything_and_lists_what_lacks_geometry(traits: tuple[Path, object]) -> None:
    _, t = traits
    r = import_ifc_graph(t.path, base=BASE)  # type: ignore[attr-defined]
    extra = t.extra  # type: ignore[attr-defined]
    assert [(s.global_id, s.in_graph, s.task_class) for s in r.skipped] == sorted(
        [(extra["no_geometry_wall"], True, True), (extra["no_geometry_proxy"], True, False)])
    assert [s.global_id for s in r.blocking] == [extra["no_geometry_wall"]]
    assert r.counts["kbp:Door"] == 4 and r.counts["kbp:Wall"] == 12 and r.counts["kbp:Stair"] == 3
    assert [n.kind for n in r.notes if n.global_id == extra["door_no_host"]] == ["host"]
    assert (el(extra["door_no_host"]), RDF.type, KBP.Door) in r.graph
    assert extra["overlapping_wall"] in r.meshes
    assert ("Level 3", 6.0) in [(s.name, s.elevation_m) for s in r.storeys]


def test_import_ifc_cli_exits_1_when_a_task_class_element_is_skipped(
    traits: tuple[Path, object], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _, t = traits
    out = tmp_path / "proj"
    assert main(["import-ifc", str(t.path), "--out", str(out)]) == 1  # type: ignore[attr-defined]
    text = capsys.readouterr().out
    assert "Negative result: 1 element(s)" in text and "'Wall without geometry'" in text
    assert (out / "model.ttl").is_file()  # the import is still written
    rows = {r["name"]: r for r in csv.DictReader((out / "skipped.csv").open())}
    assert rows["Wall without geometry"]["task_class"] == "yes"
    assert rows["Proxy without geometry"]["task_class"] == "no"
    assert rows["Door without host"]["kind"] == "note: host"


@pytest.fixture(scope="module")
def traits_world(traits: tuple[Path, object]) -> object:
    directory, _ = traits
    return build_world(Project.load(directory), parse_date("2030-01-01"), None)


def test_a_split_level_slab_and_stairs_are_obstacles_and_reported(traits_world: object) -> None:
    m = storey_map(traits_world, "Level 1")  # type: ignore[arg-type]
    roles = {(r.role, r.label) for r in m.levels}
    assert (RAISED, "Split-level floor") in roles
    assert {(STAIR, "Flight 1"), (STAIR, "Flight 2")} <= roles
    raised = next(r for r in m.levels if r.role == RAISED)
    assert raised.top_m == pytest.approx(SPLIT_LEVEL_M) and raised.area_m2 == pytest.approx(4.6 * 2.7)
    assert m.grid.is_occupied(7.0, 1.5)  # on the raised floor: the robot cannot drive there
    assert not m.grid.is_occupied(7.0, 4.5)  # the rest of bay 2 is free
    occupied = 1.0 - m.grid.free_fraction
    assert occupied < 0.25
    data = m.to_dict()
    assert [r["role"] for r in data["levels"]].count(RAISED) == 1


def test_a_storey_without_spaces_or_obstacles_gets_a_map(traits_world: object) -> None:
    m = storey_map(traits_world, "Level 3")  # type: ignore[arg-type]
    assert not m.grid.is_occupied(5.0, 3.0)  # on the Level 3 slab
    assert m.grid.is_occupied(-1.5, 3.0)  # off the slab on an upper storey: no floor
    assert m.levels == ()


def test_the_overlapping_self_intersecting_wall_is_on_the_level_2_map(traits_world: object) -> None:
    m = storey_map(traits_world, "Level 2")  # type: ignore[arg-type]
    assert m.grid.is_occupied(3.0, 2.1)
    assert not m.grid.is_occupied(3.0, 4.5)


def test_world_cli_prints_the_levels(traits: tuple[Path, object], tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    directory, _ = traits
    code = main(["world", str(directory), "--date", "2030-01-01", "--storey", "Level 1", "--out",
                 str(tmp_path / "w")])
    assert code == 0
    text = capsys.readouterr().out
    assert "at other heights than the floor: 1 raised floor, 2 stair" in text
    assert "raised floor: Split-level floor (Slab, top +1.44 m" in text
    world_json = json.loads((tmp_path / "w" / "world.json").read_text())
    assert world_json["map"]["levels"][0]["top_m"] == SPLIT_LEVEL_M


# --- rasterising fallbacks -------------------------------------------------------------------


def _box(x0: float, y0: float, x1: float, y1: float, z0: float = 0.0, z1: float = 2.5) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=(x1 - x0, y1 - y0, z1 - z0))
    mesh.apply_translation(((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2))
    return mesh


def test_filling_from_the_outline_matches_the_section_fill() -> None:
    wall = _box(0.52, 0.31, 3.47, 1.22)
    by_section = np.zeros((40, 80), dtype=bool)
    by_outline = np.zeros((40, 80), dtype=bool)
    assert fill_section(wall, 1.0, by_section, (0.0, 0.0), 0.05) is None
    fill_from_outline(wall, 1.0, by_outline, (0.0, 0.0), 0.05)
    assert by_section.sum() > 900
    assert (by_section & ~by_outline).sum() == 0  # the outline fill covers the section's cells
    assert (by_outline & ~by_section).sum() <= 2 * (by_section.shape[0] + by_section.shape[1])  # + its rim


def test_a_mesh_with_non_finite_coordinates_is_reported_not_fatal() -> None:
    bad = _box(0.0, 0.0, 1.0, 1.0)
    vertices = bad.vertices.copy()
    vertices[0] = (math.nan, 0.0, 0.0)
    broken = trimesh.Trimesh(vertices=vertices, faces=bad.faces, process=False)
    good = _box(2.0, 0.0, 3.0, 1.0)
    grid = occupancy_from_meshes([broken, good], (0.05, 1.5), Box(-0.5, -0.5, 3.5, 1.5), 0.05,
                                 names=["Broken wall", "Good wall"])
    assert len(grid.notes) == 1 and grid.notes[0].startswith("Broken wall: ")
    assert "non-finite" in grid.notes[0]
    assert grid.is_occupied(2.5, 0.5)
