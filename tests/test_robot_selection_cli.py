"""``kbplanner robots`` through a subprocess: every robot with its reasons for the case study task."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"
pytestmark = pytest.mark.skipif(not (CASE / "project.toml").is_file(), reason="case study not present")


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "kbplanner.cli", *args], capture_output=True, text=True,
                          timeout=300)


def test_robots_lists_every_robot_with_its_verdict_and_reasons() -> None:
    out = run("robots", str(CASE), "--scenario", "storage-outside", "--task", "T-FRAME", "--format", "json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["specification"] == "I-W-F-#1"
    verdicts = {r["robot"]: r["fit"] for r in data["robots"]}
    assert set(verdicts) == {"Clearpath Husky A200 + UR5", "Clearpath Husky A200 + UR16e", "Clearpath Jackal",
                             "Clearpath Jackal with a floor marking tool"}
    assert verdicts["Clearpath Jackal"] is False
    jackal = next(r for r in data["robots"] if r["robot"] == "Clearpath Jackal")
    assert any(c["check"] == "capability" and not c["ok"] and "MM-G-1" in c["message"]
               for c in jackal["checks"])


def test_robots_text_names_the_heaviest_frame_and_the_simulation_task_is_the_default() -> None:
    out = run("robots", str(CASE))
    assert out.returncode == 0, out.stderr
    assert "Task T-FRAME" in out.stdout and "heaviest element:" in out.stdout
    assert out.stdout.count("- Clearpath") == 4
    boards = run("robots", str(CASE), "--task", "T-BOARD")
    assert boards.returncode == 0 and "Task T-BOARD" in boards.stdout
    assert "14.62 kg" in boards.stdout and "Gypsum board" in boards.stdout


def test_an_unknown_task_exits_2_naming_the_robotized_tasks() -> None:
    out = run("robots", str(CASE), "--task", "T-NOPE")
    assert out.returncode == 2 and "T-FRAME" in out.stderr and "Traceback" not in out.stderr
