"""``kbplanner requirements`` on the case study, through a subprocess: the paper's two requirements
for the bare model, every output format, and a template that, added to the project, meets them."""

from __future__ import annotations

import csv
import io
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from rdflib import RDF, Graph

from kbplanner.core.vocab import KBP

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"
pytestmark = pytest.mark.skipif(not (CASE / "project.toml").is_file(), reason="case study not present")


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "kbplanner.cli", *args], capture_output=True, text=True,
                          timeout=300)


def test_the_bare_case_study_needs_a_frame_storage_and_grasp_points_for_eleven_frames() -> None:
    out = run("requirements", str(CASE))
    assert out.returncode == 0, out.stderr
    assert "Additional modeling requirements (4)" in out.stdout  # two for T-FRAME, two for T-BOARD
    assert "NV-1" in out.stdout and "MM-G-1" in out.stdout and out.stdout.count("11: ") == 2
    assert out.stdout.count("5: ") == 2
    assert "already in the model: T-FRAME action 4 MM-R-1 'target pose'" in out.stdout


def test_csv_has_one_row_per_frame_and_requirement_and_json_and_turtle_parse() -> None:
    rows = list(csv.DictReader(io.StringIO(run("requirements", str(CASE), "--format", "csv").stdout)))
    assert len(rows) == 2 * 11 + 2 * 5 and {r["skill"] for r in rows} == {"NV-1", "MM-G-1"}
    data = json.loads(run("requirements", str(CASE), "--format", "json").stdout)
    assert [r["input"] for r in data["requirements"]] == ["destination", "grasp point"] * 2
    g = Graph().parse(data=run("requirements", str(CASE), "--format", "ttl").stdout, format="turtle")
    assert len(list(g.subjects(RDF.type, KBP.ModelingRequirement))) == 4


def test_a_scenario_meets_every_requirement() -> None:
    out = run("requirements", str(CASE), "--scenario", "storage-outside")
    assert out.returncode == 0, out.stderr
    assert "No additional modeling requirements" in out.stdout


def test_the_template_added_to_a_copy_of_the_project_meets_the_requirements(tmp_path: Path) -> None:
    proj = tmp_path / "case"
    shutil.copytree(CASE, proj, ignore=shutil.ignore_patterns(".kbplanner-cache", "tools"))
    template = proj / "augmentation" / "todo.ttl"
    out = run("requirements", str(proj), "--template", str(template))
    assert out.returncode == 0, out.stderr
    assert "TODO requirement 2" in template.read_text()
    manifest = proj / "project.toml"
    text = manifest.read_text().replace("augmentation = [", 'augmentation = ["augmentation/todo.ttl", ', 1)
    manifest.write_text(text)
    again = run("requirements", str(proj))
    assert again.returncode == 0, again.stderr
    assert "No additional modeling requirements" in again.stdout


def test_bad_input_exits_2_with_one_message_and_no_traceback(tmp_path: Path) -> None:
    for args in (("requirements", str(tmp_path / "nowhere")),
                 ("requirements", str(CASE), "--scenario", "moon")):
        out = run(*args)
        assert out.returncode == 2
        assert out.stderr.startswith("kbplanner: error:") and "Traceback" not in out.stderr
