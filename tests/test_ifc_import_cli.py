"""``kbplanner import-ifc``, run as a subprocess: files written, summary printed, exit codes."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

from rdflib import RDF, Graph

from ifc_factory import write_test_building
from kbplanner.core.iris import base_iri, element_iri
from kbplanner.core.vocab import BOT


def kbplanner(*args: str) -> subprocess.CompletedProcess[str]:
    script = Path(sys.executable).with_name("kbplanner")
    command = [str(script)] if script.is_file() else [
        sys.executable, "-c", "import sys; from kbplanner.cli import main; sys.exit(main(sys.argv[1:]))"]
    return subprocess.run([*command, *args], capture_output=True, text=True, timeout=120)


def test_import_ifc_writes_model_meshes_and_a_starter_project_toml(tmp_path: Path) -> None:
    b = write_test_building(tmp_path / "in" / "house.ifc", broken_element=True)
    out = tmp_path / "project"
    done = kbplanner("import-ifc", str(b.path), "--out", str(out), "--name", "Test House")
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in out.iterdir()) == ["meshes", "model.ttl", "project.toml", "skipped.csv",
                                                     "skipped.json"]
    manifest = tomllib.loads((out / "project.toml").read_text())
    assert manifest == {"project": {"name": "Test House"}, "model": {"ifc": "../in/house.ifc"}}
    assert (out / manifest["model"]["ifc"]).resolve() == b.path.resolve()
    g = Graph().parse(out / "model.ttl")
    storey = element_iri(base_iri("Test House"), next(iter(b.storeys)))
    assert (storey, RDF.type, BOT.Storey) in g
    text = done.stdout
    assert "kbp:Wall" in text and "Level 2" in text and "3.000" in text
    heading = "Skipped or without geometry (1; 0 of classes tasks use):"
    assert f"{heading}\n  {b.broken} IfcBuildingElementProxy" in text
    assert "length unit metre = 1 m, mass unit kilogram = 1 kg" in text
    assert "project.toml: written" in text


def test_import_ifc_keeps_an_existing_project_toml_and_uses_its_name(tmp_path: Path) -> None:
    b = write_test_building(tmp_path / "house.ifc")
    out = tmp_path / "project"
    out.mkdir()
    original = '[project]\nname = "Existing"\n\n[model]\nifc = "../house.ifc"\n'
    (out / "project.toml").write_text(original)
    done = kbplanner("import-ifc", str(b.path), "--out", str(out))
    assert done.returncode == 0, done.stderr
    assert (out / "project.toml").read_text() == original
    g = Graph().parse(out / "model.ttl")
    assert (element_iri(base_iri("Existing"), b.site), RDF.type, BOT.Site) in g
    assert "project.toml: kept" in done.stdout


def test_import_ifc_exits_2_with_one_message_on_a_file_that_is_not_ifc(tmp_path: Path) -> None:
    bad = tmp_path / "readme.ifc"
    bad.write_text("not a model")
    done = kbplanner("import-ifc", str(bad), "--out", str(tmp_path / "p"))
    assert done.returncode == 2
    assert "readme.ifc" in done.stderr and "fix:" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "p" / "project.toml").exists()


def test_import_ifc_exits_2_when_name_contradicts_the_project_toml(tmp_path: Path) -> None:
    b = write_test_building(tmp_path / "house.ifc")
    out = tmp_path / "project"
    out.mkdir()
    (out / "project.toml").write_text('[project]\nname = "Existing"\n')
    done = kbplanner("import-ifc", str(b.path), "--out", str(out), "--name", "Other")
    assert done.returncode == 2 and "Existing" in done.stderr and "Traceback" not in done.stderr
    assert not (out / "model.ttl").exists()
