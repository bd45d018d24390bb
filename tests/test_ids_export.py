"""IDS out (issue 13): the case study's additional modeling requirements as buildingSMART IDS 1.0,
checked with ifctester: a valid IDS; the bare IFC fails on exactly the elements the SHACL requirements
name; the IFC augmented with a scenario's values (written with ifcopenshell.api) passes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import ifcopenshell
import ifcopenshell.util.element
import pytest
from ifctester import ids

from kbplanner.core.errors import KbplannerError
from kbplanner.knowledge.ids_export import PSET, ids_export
from kbplanner.model.ifc_augment import write_augmented_ifc
from kbplanner.project import Project

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"
pytestmark = pytest.mark.skipif(not (CASE / "project.toml").is_file(), reason="case study not present")


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "kbplanner.cli", *args], capture_output=True, text=True,
                          timeout=300)


def failing(doc: ids.Ids, ifc: Path) -> dict[str, set[str]]:
    """Specification name -> GlobalIds that fail it."""
    f = ifcopenshell.open(str(ifc))
    doc.validate(f)
    return {s.name: {e.GlobalId for e in s.failed_entities} for s in doc.specifications}


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    out = tmp_path_factory.mktemp("ids")
    r = run("requirements", str(CASE), "--scenario", "storage-outside", "--ids", str(out / "req.ids"),
            "--augmented-ifc", str(out / "augmented.ifc"))
    assert r.returncode == 0, r.stderr
    assert "wrote IDS" in r.stderr and "112 properties on 16 element(s)" in r.stderr  # 11 frames, 5 boards
    return out / "req.ids", out / "augmented.ifc"


def test_the_ids_is_valid_ids_1_0_and_says_what_it_cannot_express(files: tuple[Path, Path]) -> None:
    doc = ids.open(str(files[0]), validate=True)  # raises on an XML schema violation
    assert [s.name for s in doc.specifications] == [
        "T-BOARD action 1 'navigate to board pickup location': NV-1 destination",
        "T-BOARD action 2 'pick board': MM-G-1 grasp point",
        "T-FRAME action 1 'navigate to frame pickup location': NV-1 destination",
        "T-FRAME action 2 'pick frame': MM-G-1 grasp point"]
    assert 'identifier="T-FRAME/2/MM-G-1/grasp point"' in files[0].read_text(encoding="utf-8")
    assert all(s.ifcVersion == ["IFC2X3"] for s in doc.specifications)
    names = {s.name.split(": ")[1]: [(r.propertySet, r.baseName, r.dataType) for r in s.requirements]
             for s in doc.specifications}
    assert names["NV-1 destination"] == [(PSET, "StoredIn", "IFCLABEL")]
    assert [n for _, n, _ in names["MM-G-1 grasp point"]] == [
        "GraspPointX", "GraspPointY", "GraspPointZ", "GraspPointRoll", "GraspPointPitch", "GraspPointYaw"]
    assert "kbp:pickupLocation" in doc.info["description"] and "outside the IFC" in doc.info["description"]


def test_the_bare_ifc_fails_on_exactly_the_shacl_elements_and_the_augmented_one_passes(
        files: tuple[Path, Path]) -> None:
    project = Project.load(CASE)
    shacl = {f"{r.task_id} action {r.action_order} '{r.action_label}': {r.skill_id} {r.input_name}":
             {e.global_id for e in r.elements} for r in project.requirements().requirements}
    doc = ids.open(str(files[0]))
    assert failing(doc, project.manifest.ifc) == shacl
    assert sorted(len(v) for v in shacl.values()) == [5, 5, 11, 11]  # boards, frames
    assert failing(doc, files[1]) == {k: set() for k in shacl}
    assert all(s.status for s in doc.specifications)
    # the values are the scenario's: F01's grasp point is 1.2 m up, all frames in the outside storage
    f = ifcopenshell.open(str(files[1]))
    pset = ifcopenshell.util.element.get_pset(f.by_guid("1DTPPSXlnHtAyhZMSpYMVU"), PSET)
    assert pset["GraspPointZ"] == pytest.approx(1.2)
    assert pset["StoredIn"] == "Frame material storage (outside)"


def test_a_met_model_gives_an_ids_without_specifications_and_augmenting_needs_a_scenario(
        tmp_path: Path) -> None:
    met = Project.load(CASE, scenario="storage-inside")
    export = ids_export(met.requirements())
    assert export.specs == [] and export.already_met
    with pytest.raises(KbplannerError, match="not valid IDS"):  # IDS 1.0 needs one specification
        export.write(tmp_path / "empty.ids")
    assert not (tmp_path / "empty.ids").exists()
    r = run("requirements", str(CASE), "--augmented-ifc", str(tmp_path / "a.ifc"))
    assert r.returncode == 2 and "--augmented-ifc needs --scenario" in r.stderr
    assert not (tmp_path / "a.ifc").exists() and r.stdout == ""
    # the writer never touches its input
    before = met.manifest.ifc.read_bytes()
    write_augmented_ifc(met.manifest.ifc, tmp_path / "b.ifc", ids_export(Project.load(CASE).requirements()),
                        met.model)
    assert met.manifest.ifc.read_bytes() == before and (tmp_path / "b.ifc").stat().st_size > len(before)


def test_a_range_the_shacl_shapes_put_on_a_property_becomes_an_ids_value_restriction(tmp_path: Path) -> None:
    from rdflib import Graph, Literal, URIRef

    from kbplanner.core.vocab import KBP
    from kbplanner.knowledge.knowledge_base import SH

    shapes = Graph()
    shape = URIRef("https://example.org/shapes#GraspZ")
    shapes.add((shape, SH.path, KBP.z))
    shapes.add((shape, SH.minInclusive, Literal(0.0)))
    shapes.add((shape, SH.maxExclusive, Literal(3.0)))
    export = ids_export(Project.load(CASE).requirements(), shapes)
    grasp = next(s for s in export.specs if "MM-G-1" in s.identifier)
    bounds = {p.name: p.bounds for p in grasp.properties}
    assert bounds["GraspPointZ"] == (("maxExclusive", 3.0), ("minInclusive", 0.0))
    assert bounds["GraspPointX"] == ()
    export.write(tmp_path / "r.ids")
    doc = ids.open(str(tmp_path / "r.ids"), validate=True)
    ifc = ifcopenshell.open(str(Project.load(CASE).manifest.ifc))
    doc.validate(ifc)  # the bare IFC still fails on 5 boards and 11 frames, now also for the value range
    assert [len(s.failed_entities) for s in doc.specifications] == [5, 5, 11, 11]
    assert '<xs:maxExclusive value="3.0"' in (tmp_path / "r.ids").read_text(encoding="utf-8")
    aug = write_augmented_ifc(Project.load(CASE).manifest.ifc, tmp_path / "a.ifc", export,
                              Project.load(CASE, scenario="storage-outside").model)
    doc.validate(ifcopenshell.open(str(aug.path)))  # grasp points 1.2 m up: within [0, 3)
    assert [len(s.failed_entities) for s in doc.specifications] == [0, 0, 0, 0]
