"""The main job on the case study: every stage runs, the run directory holds what it says, and the
scenario comparison reproduces the paper's qualitative findings (storage outside: moments under 1 m
between robot and carpenters; inside: none, a larger minimum separation and a shorter time per frame)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# The whole main job on the case study (about 70 s): `make test-slow`, which .ci/run runs after `make test`.
pytestmark = pytest.mark.slow


Run = tuple[Path, subprocess.CompletedProcess[str]]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    out = tmp_path_factory.mktemp("run") / "case_study"
    proc = subprocess.run([sys.executable, "-m", "kbplanner", "run", str(REPO / "data" / "case_study"),
                           "--out", str(out)], capture_output=True, text=True, timeout=900)
    return out, proc


def test_run_exits_0_and_prints_a_summary_naming_the_results(run_dir: Run) -> None:
    out, proc = run_dir
    assert proc.returncode == 0, proc.stderr
    assert "4 additional modeling requirement(s)" in proc.stdout  # 2 for T-FRAME, 2 for T-BOARD
    assert str(out) in proc.stdout.replace("\n", "")
    assert not out.with_name(out.name + ".partial").exists()


def test_the_run_directory_holds_requirements_validation_and_worlds(run_dir: Run) -> None:
    out, _ = run_dir
    reqs = (out / "requirements.csv").read_text().splitlines()
    assert len(reqs) == 1 + 32  # one row per (requirement, element): 2 x 11 frames, 2 x 5 boards
    assert (out / "requirements_template.ttl").is_file()
    for scenario in ("storage-inside", "storage-outside"):
        s = out / "scenarios" / scenario
        assert "conforms" in (s / "validation.txt").read_text().lower()
        assert (s / "validation.ttl").is_file()
        assert "NOT FIT" in (s / "robots.txt").read_text()
        assert (s / "world" / "map.pgm").is_file() and (s / "world" / "world_existing.sdf").is_file()
    assert not (out / "metrics.json").exists()  # wall-clock timings are not called metrics (issue 17)
    metrics = json.loads((out / "run_timings.json").read_text())
    stages = {m["stage"] for m in metrics["stages"]}
    assert stages >= {"import and load", "requirements", "validation", "world"}
    manifest = json.loads((out / "manifest.json").read_text())
    assert any(k.endswith(".ifc") for k in manifest["inputs"])
    assert manifest["versions"]["rdflib"]


def test_the_comparison_reproduces_the_papers_findings(run_dir: Run) -> None:
    """Inside is faster (the paper's finding); with reactive workers and speed and separation
    monitoring (docs/safety.md) neither scenario comes into contact or under 1 m on seed 7 (the
    paper's robot had neither). Which scenario keeps people farther is not a seed-7 constant any more
    (README; the distribution over seeds is `compare --seeds`, docs/safety.md)."""
    import csv

    out, _ = run_dir
    rows = {r["scenario"]: r for r in csv.DictReader((out / "comparison.csv").open())}
    outside, inside = rows["storage-outside"], rows["storage-inside"]
    assert outside["installed"] == inside["installed"] == "11/11"
    assert outside["collisions"] == inside["collisions"] == "0"
    assert float(inside["time < 1 m (s)"]) == float(outside["time < 1 m (s)"]) == 0.0
    assert min(float(inside["min separation (m)"]), float(outside["min separation (m)"])) > 1.0
    assert float(inside["per frame (min)"]) < float(outside["per frame (min)"])
    assert float(inside["total (min)"]) < float(outside["total (min)"])
    page = (out / "report.html").read_text()
    assert "<h2>Scenario storage-outside</h2>" in page
    assert "frame 1 (min), paper" in page  # the [reference] figures of project.toml, beside ours
