"""BCF out (issue 13): ``kbplanner validate --bcf`` gives one topic per non-conforming IFC element, and
the report one per element the robot did not install; read back with IfcOpenShell's BCF library, every
topic's viewpoint selects the GlobalId of an element of the IFC."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import ifcopenshell
import pytest

from kbplanner.analysis.bcf_export import read_bcf_topics, validation_issues, write_bcf
from kbplanner.knowledge.validation import validate_model
from kbplanner.project import Project
from sim_project_factory import make_sim_project

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"


def kbplanner(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "kbplanner", *args], capture_output=True, text=True,
                          timeout=600)


@pytest.mark.skipif(not (CASE / "project.toml").is_file(), reason="case study not present")
@pytest.mark.parametrize("version", ["3.0", "2.1"])
def test_validate_writes_one_topic_per_non_conforming_frame(version: str, tmp_path: Path) -> None:
    out = tmp_path / "issues.bcfzip"
    proc = kbplanner("validate", str(CASE), "--bcf", str(out), "--bcf-version", version)
    assert proc.returncode == 1, proc.stderr  # the bare model does not conform
    assert f"wrote BCF {version}" in proc.stderr and "16 topic(s)" in proc.stderr  # 11 frames, 5 boards
    topics = read_bcf_topics(out)
    project = Project.load(CASE)
    shacl = {e.global_id for r in project.requirements().requirements for e in r.elements}
    assert len(topics) == 16 and {g for _, _, gids in topics for g in gids} == shacl
    ifc = ifcopenshell.open(str(project.manifest.ifc))
    for title, kind, gids in topics:
        assert len(gids) == 1 and ifc.by_guid(gids[0]).is_a() in ("IfcMember", "IfcPlate")
        assert kind == "Error" and title.startswith(("Does not conform: Stud frame panel F",
                                                     "Does not conform: Gypsum board B"))


@pytest.mark.skipif(not (CASE / "project.toml").is_file(), reason="case study not present")
def test_the_same_report_gives_the_same_bytes_and_a_conforming_model_no_topics(tmp_path: Path) -> None:
    project = Project.load(CASE)
    report = validate_model(project.model, project.kb).report_graph
    issues, elsewhere = validation_issues(report, project.model)
    assert len(issues) == 16 and elsewhere == []
    when = project.world_date()
    ifc = project.manifest.ifc
    a = write_bcf(issues, tmp_path / "a.bcfzip", ifc_path=ifc, project_name="p", created=when)
    b = write_bcf(issues, tmp_path / "b.bcfzip", ifc_path=ifc, project_name="p", created=when)
    assert a.not_in_ifc == () and a.path.read_bytes() == b.path.read_bytes()
    ok = Project.load(CASE, scenario="storage-inside")
    assert validation_issues(validate_model(ok.model, ok.kb).report_graph, ok.model) == ([], [])


def test_the_report_writes_a_topic_for_the_panel_the_robot_could_not_install(tmp_path: Path) -> None:
    sp = make_sim_project(tmp_path / "proj")  # P3 hangs 1.8 m up, out of the arm's reach
    run = tmp_path / "run"
    sim = kbplanner("simulate", str(sp.directory), "--scenario", "stored", "--out", str(run),
                    "--no-keyframes")
    assert sim.returncode == 1, sim.stderr[-2000:]  # P3 not installed
    rep = kbplanner("report", str(run), "--out", str(tmp_path / "rep"))
    assert rep.returncode == 0, rep.stderr[-2000:]
    topics = read_bcf_topics(tmp_path / "rep" / "not_installed.bcfzip")
    assert [(t[0], t[2]) for t in topics] == [
        ("Robot could not install Panel P3 (stored)", [sp.panels["P3"]])]
    ifc = ifcopenshell.open(str(sp.directory / "model.ifc"))
    assert ifc.by_guid(sp.panels["P3"]).Name == "Panel P3"
    assert "not_installed.bcfzip" in (tmp_path / "rep" / "report.html").read_text(encoding="utf-8")
