"""Real IFC models: the import keeps every wall, door, window, slab, member ... the file holds.

The Duplex (Revit, IFC2X3) ships with the case study; the public models (IfcOpenHouse IFC4,
example.ifc IFC2X3) live in ``../shared/data/ifc/public`` and their tests skip when it is absent.
"""

from __future__ import annotations

from pathlib import Path

import ifcopenshell
import pytest

from kbplanner.core.iris import base_iri
from kbplanner.core.vocab import KBP
from kbplanner.model.dates import parse_date
from kbplanner.model.ifc_import import ImportResult, import_ifc_graph
from kbplanner.project import Project
from kbplanner.world.build import build_world
from kbplanner.world.maps import storey_map

REPO = Path(__file__).resolve().parents[1]
DUPLEX = REPO / "data" / "case_study" / "model" / "Duplex_A_20110907.ifc"
PUBLIC = REPO.parent / "shared" / "data" / "ifc" / "public"
CLASSES = ("IfcWall", "IfcDoor", "IfcWindow", "IfcSlab", "IfcRoof", "IfcStair", "IfcStairFlight", "IfcMember",
           "IfcPlate", "IfcColumn", "IfcBeam", "IfcCovering", "IfcSpace")


def _public(name: str) -> Path:
    path = PUBLIC / name
    if not path.is_file():
        pytest.skip(f"{path} not present (../shared is absent)")
    return path


def _lost(ifc: Path, result: ImportResult) -> dict[str, int]:
    """Per class, the products of the file that are neither in the graph nor listed as skipped."""
    f = ifcopenshell.open(str(ifc))
    in_graph = {str(v) for v in result.graph.objects(None, KBP.globalId)}
    listed = {s.global_id for s in result.skipped}
    lost = {}
    for cls in CLASSES:
        missing = {str(p.GlobalId) for p in f.by_type(cls)} - in_graph - listed
        if missing:
            lost[cls] = len(missing)
    return lost


def test_the_duplex_import_keeps_every_element() -> None:
    if not DUPLEX.is_file():  # pragma: no cover - the case study ships it
        pytest.skip("Duplex IFC not present")
    r = import_ifc_graph(DUPLEX, base=base_iri("duplex"))
    assert _lost(DUPLEX, r) == {}
    assert r.skipped == () and r.blocking == []
    assert (r.counts["kbp:Door"], r.counts["kbp:Window"], r.counts["kbp:Wall"]) == (14, 24, 57)


@pytest.mark.parametrize(("name", "schema", "doors", "windows", "walls"),
                         [("IfcOpenHouse_IFC4.ifc", "IFC4", 1, 5, 4), ("example.ifc", "IFC2X3", 0, 0, 17)])
def test_public_models_import_every_element(
    name: str, schema: str, doors: int, windows: int, walls: int
) -> None:
    ifc = _public(name)
    r = import_ifc_graph(ifc, base=base_iri(ifc.stem))
    assert r.schema == schema and _lost(ifc, r) == {} and r.blocking == []
    assert (r.counts.get("kbp:Door", 0), r.counts.get("kbp:Window", 0), r.counts["kbp:Wall"]) == (
        doors, windows, walls)


def test_a_storey_without_a_floor_is_occupied_and_says_why(tmp_path: Path) -> None:
    ifc = _public("example.ifc")  # its Level 2 (+3.14 m) has walls and beams but no slab
    manifest = f'[project]\nname = "example"\n[model]\nifc = "{ifc.as_posix()}"\n'
    (tmp_path / "project.toml").write_text(manifest, encoding="utf-8")
    world = build_world(Project.load(tmp_path), parse_date("2030-01-01"), None)
    upper = storey_map(world, "Level 2")
    assert upper.grid.occupied.all()
    assert any(n.startswith("no floor: ") for n in upper.notes)
    ground = storey_map(world, "Level 1")
    assert 0.0 < 1.0 - ground.grid.free_fraction < 0.1 and ground.notes == ()
