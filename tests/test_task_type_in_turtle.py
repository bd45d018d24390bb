"""Issue 12: a construction task type written in Turtle only, as docs/knowledge_base.md documents it.

The Turtle of the section "Adding a construction task type in Turtle only" is read from the page itself
(so the documented example is the tested one) and added to a small project (one room, two panels on a
storage in the yard, tests/sim_project_factory.py) with no Python change: requirements on the bare
model, then with the data added requirements, validation, robots, plan (B1-B4) and a short simulation.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from kbplanner.project import Project
from sim_project_factory import make_sim_project

DOC = Path(__file__).resolve().parents[1] / "docs" / "knowledge_base.md"
SECTION = "## Adding a construction task type in Turtle only"
LIFT_POINT = (0.05, 0.0, 1.2)  # not the kbp:graspPoint of the panels: the plan must use the new property


def documented_turtle() -> str:
    text = DOC.read_text(encoding="utf-8")
    section = text[text.index(SECTION):]
    match = re.search(r"```turtle\n(.*?)```", section, re.S)
    assert match is not None, "the section has a Turtle example"
    return match.group(1)


@pytest.fixture(scope="module")
def project_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("cladding")
    sp = make_sim_project(d, high_panel=False)
    for name in ("site.ttl", "stored.ttl"):  # the factory writes decimals; shapes/model.ttl wants doubles
        f = d / name
        f.write_text(re.sub(r"(?<=[\s(])(-?\d+\.\d+)(?=[\s;.,)])", r"\1e0", f.read_text()))
    (d / "kb").mkdir()
    (d / "kb" / "panel_cladding.ttl").write_text(documented_turtle(), encoding="utf-8")
    schedule = d / "schedule.csv"
    schedule.write_text(schedule.read_text().replace("Panels,2022-05-10,2022-05-12,T3,class=IfcMember,true,I-W-F-#1",
                                                     "Panels,2022-05-10,2022-05-12,T3,class=IfcMember,true,P-C-#1"))
    lines = ["@prefix kbp: <https://w3id.org/kbplanner/ontology#> .",
             "@prefix ext: <https://example.org/cladding#> ."]
    for name in sorted(sp.panels):
        pose = f"<{sp.iri(name)}-lift>"
        x, y, z = LIFT_POINT
        lines += [f"<{sp.iri(name)}> ext:liftPoint {pose} .",
                  f"{pose} a kbp:Pose ; kbp:x {x}e0 ; kbp:y {y}e0 ; kbp:z {z}e0 ; "
                  "kbp:roll 0.0e0 ; kbp:pitch 0.0e0 ; kbp:yaw 0.0e0 ."]
    (d / "lift.ttl").write_text("\n".join(lines) + "\n", encoding="utf-8")
    toml = d / "project.toml"
    text = toml.read_text().replace("[model]\n", '[model]\nknowledge_base = ["kb/panel_cladding.ttl"]\n', 1)
    toml.write_text(text.replace('overlays = ["stored.ttl"]', 'overlays = ["stored.ttl", "lift.ttl"]', 1))
    assert "P-C-#1" in schedule.read_text() and "lift.ttl" in toml.read_text()
    return d


def test_the_bare_model_needs_a_storage_and_a_lift_point_for_every_panel(project_dir: Path) -> None:
    result = Project.load(project_dir).requirements()
    got = sorted((r.spec_id, r.skill_id, r.input_name, len(r.elements)) for r in result.requirements)
    assert got == [("P-C-#1", "MM-G-1", "grasp point", 2), ("P-C-#1", "NV-1", "destination", 2)]
    lift = next(r for r in result.requirements if r.skill_id == "MM-G-1")
    assert "lift point" in lift.missing and "ext:liftPoint" in lift.how_to_add


def test_with_the_data_the_task_validates_finds_a_robot_and_plans_from_the_turtle(project_dir: Path) -> None:
    project = Project.load(project_dir, scenario="stored")
    assert project.requirements().requirements == []
    assert project.validate().conforms
    assert [a.robot.label for a in project.select_robots().fit]
    plan = project.plan()
    assert plan.spec_id == "P-C-#1" and plan.feasible, plan.notes
    assert [s.skill_id for s in plan.steps[:4]] == ["NV-1", "MM-G-1", "NV-2", "MM-R-1"]
    assert plan.steps[1].inputs["grasp point"] == pytest.approx([*LIFT_POINT, 0.0, 0.0, 0.0])
    assert plan.steps[2].parameters["maxSpeed"] == 0.25  # the action's setting


def test_the_task_simulates_from_the_cli(project_dir: Path, tmp_path: Path) -> None:
    out = subprocess.run([sys.executable, "-m", "kbplanner.cli", "simulate", str(project_dir),
                          "--scenario", "stored", "--max-elements", "1", "--no-keyframes",
                          "--out", str(tmp_path / "run")], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "T5 (P-C-#1)" in out.stdout and "installed 1 of 1" in out.stdout
