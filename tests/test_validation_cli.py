"""``kbplanner validate`` through a subprocess: exit 1 and a readable list for the bare case study,
0 for a scenario, the SHACL report written as Turtle or text, 2 for bad input."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from rdflib import RDF, Graph

from kbplanner.knowledge.knowledge_base import SH

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"
pytestmark = pytest.mark.skipif(not (CASE / "project.toml").is_file(), reason="case study not present")


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "kbplanner.cli", *args], capture_output=True, text=True,
                          timeout=300)


def test_the_bare_case_study_does_not_conform_and_exits_1(tmp_path: Path) -> None:
    report = tmp_path / "validation.ttl"
    out = run("validate", str(CASE), "--report", str(report))
    assert out.returncode == 1, out.stderr
    # two requirements per element: 11 frames (T-FRAME) and 5 boards (T-BOARD)
    assert out.stdout.startswith("The model does not conform: 32 violation(s).")
    assert "Stud frame panel F01" in out.stdout and "NV-1 destination" in out.stdout
    assert "Gypsum board B01" in out.stdout
    g = Graph().parse(report, format="turtle")
    assert len(list(g.subjects(RDF.type, SH.ValidationResult))) == 32


def test_a_storage_scenario_conforms_and_exits_0(tmp_path: Path) -> None:
    text = tmp_path / "validation.txt"
    out = run("validate", str(CASE), "--scenario", "storage-inside", "--report", str(text))
    assert out.returncode == 0, out.stdout + out.stderr
    assert text.read_text().splitlines()[1].startswith("The model conforms.")


def test_a_missing_project_exits_2_without_traceback(tmp_path: Path) -> None:
    out = run("validate", str(tmp_path / "nowhere"))
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "project directory not found" in out.stderr
