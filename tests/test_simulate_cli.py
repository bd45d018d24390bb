"""``kbplanner simulate``, run as a subprocess: the run directory, the summary table, exit codes 0/1/2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from sim_project_factory import make_sim_project

KB = [sys.executable, "-m", "kbplanner.cli"]


def kbplanner(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*KB, *args], capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def two_panels(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("simcli")
    make_sim_project(d, high_panel=False)
    return d


def test_simulate_installs_every_panel_writes_the_run_and_exits_0(two_panels: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    res = kbplanner("simulate", str(two_panels), "--scenario", "stored", "--seed", "3", "--out", str(out),
                    "--no-keyframes")
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Panel P1" in res.stdout and "Panel P2" in res.stdout and "installed 2 of 2" in res.stdout
    assert "B5 simulation" in res.stderr  # the progress bar
    for name in ("trajectories.csv", "events.jsonl", "metrics.json", "timing.json", "footprints.json",
                 "manifest.json", "plan.json"):
        assert (out / name).is_file(), name
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["totals"]["installed"] == 2 and metrics["seed"] == 3
    assert not (out / "keyframes").exists()


def test_a_run_with_failed_elements_exits_1_with_the_reasons(two_panels: Path, tmp_path: Path) -> None:
    res = kbplanner("simulate", str(two_panels), "--scenario", "walled", "--out", str(tmp_path / "run"),
                    "--no-keyframes")
    assert res.returncode == 1, res.stdout + res.stderr
    assert "failed" in res.stdout and "walled off" in res.stdout.replace("\n", " ")
    assert "Traceback" not in res.stderr
    assert (tmp_path / "run" / "metrics.json").is_file()


@pytest.mark.parametrize(("args", "needle"), [
    (("--scenario", "nowhere"), "unknown scenario"),
    (("--task", "T-NONE"), "unknown task"),
])
def test_bad_input_exits_2_with_a_message_and_no_traceback(two_panels: Path, tmp_path: Path,
                                                          args: tuple[str, ...], needle: str) -> None:
    res = kbplanner("simulate", str(two_panels), *args, "--out", str(tmp_path / "run"))
    assert res.returncode == 2
    assert needle in res.stderr and "fix:" in res.stderr
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "run").exists()


def test_max_elements_simulates_the_first_elements_and_names_the_rest(two_panels: Path,
                                                                      tmp_path: Path) -> None:
    out = tmp_path / "run"
    res = kbplanner("simulate", str(two_panels), "--scenario", "stored", "--max-elements", "1",
                    "--out", str(out), "--no-keyframes")
    assert res.returncode == 0, res.stdout + res.stderr
    assert "installed 1 of 1" in res.stdout and "Panel P1" in res.stdout and "Panel P2" not in res.stdout
    assert "simulating 1 of 2 elements; left out: Panel P2" in " ".join(res.stderr.split())
    assert json.loads((out / "metrics.json").read_text())["totals"]["elements"] == 1


def test_max_elements_must_be_positive(two_panels: Path, tmp_path: Path) -> None:
    res = kbplanner("simulate", str(two_panels), "--max-elements", "0", "--out", str(tmp_path / "run"))
    assert res.returncode == 2 and "Traceback" not in res.stderr and not (tmp_path / "run").exists()
