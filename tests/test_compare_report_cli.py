"""``kbplanner compare`` and ``kbplanner report`` through a subprocess: outputs and exit codes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from sim_project_factory import make_sim_project


def kbplanner(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "kbplanner", *args], capture_output=True, text=True, timeout=900
    )


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("cmp")
    make_sim_project(d, high_panel=False)
    return d


def test_compare_simulates_each_scenario_and_writes_table_results_and_report(
    project: Path, tmp_path: Path
) -> None:
    out = tmp_path / "cmp"
    proc = kbplanner("compare", str(project), "--scenarios", "stored", "--out", str(out))
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "stored" in proc.stdout and "report.html" in proc.stdout
    assert (out / "comparison.csv").read_text().startswith("scenario,installed,first frame (min)")
    assert (out / "stored" / "trajectories.csv").is_file()
    assert (out / "scenarios" / "stored" / "results.ttl").read_text().count("simulatedDuration") == 1
    assert "simulated_duration_h" in (out / "scenarios" / "stored" / "schedule_with_results.csv").read_text()
    assert "<h2>Scenario stored</h2>" in (out / "report.html").read_text()

    # the report command on the run directory alone
    rep = kbplanner("report", str(out / "stored"), "--out", str(tmp_path / "rep"))
    assert rep.returncode == 0, rep.stderr[-3000:]
    assert (tmp_path / "rep" / "report.html").is_file() and (tmp_path / "rep" / "report.md").is_file()


def test_compare_and_report_reject_bad_input_with_exit_2(project: Path, tmp_path: Path) -> None:
    bad = kbplanner("compare", str(project), "--scenarios", "nowhere", "--out", str(tmp_path / "x"))
    assert bad.returncode == 2 and "unknown scenario" in bad.stderr and "Traceback" not in bad.stderr
    assert not (tmp_path / "x").exists()
    rep = kbplanner("report", str(tmp_path / "missing"))
    assert rep.returncode == 2 and "run directory not found" in rep.stderr and "Traceback" not in rep.stderr
