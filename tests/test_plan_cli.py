"""``kbplanner plan`` on the case study: table, B4 verdicts, plan.json + plan.ttl + feasibility.json,
exit codes 0 / 1 / 2 (byte-identical reruns: tests/test_plan_feasibility.py, on a small project)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from rdflib import Graph

from conftest import CASE_STUDY
from kbplanner.cli import main
from kbplanner.core.vocab import KBP
from kbplanner.planning.plan_model import Plan


def _kbplanner(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "kbplanner", *args], capture_output=True, text=True,
                          timeout=120, check=False)


def test_plan_writes_json_and_turtle_prints_the_table_and_exits_0_when_every_step_is_feasible(
        tmp_path: Path) -> None:
    out = tmp_path / "run"
    r = _kbplanner("plan", str(CASE_STUDY), "--scenario", "storage-outside", "--task", "T-FRAME",
                   "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "44 steps" in r.stdout and "(44 rows)" in r.stdout
    assert "robot: Clearpath Husky A200 + UR16e (husky-ur16e, husky_ur16e.urdf)" in r.stdout
    assert "1. husky-ur16e (Clearpath Husky A200 + UR16e): fit, chosen" in r.stdout
    assert "destination (17.50, -16.00, 0.00; yaw 0.00)" in r.stdout
    assert sorted(p.name for p in out.iterdir()) == [".kbplanner-run", "feasibility.json", "plan.json",
                                                     "plan.png", "plan.ttl"]
    assert "feasibility (B4): 11 of 11 elements installable" in r.stdout
    plan = Plan.from_json((out / "plan.json").read_text())
    assert len(plan.steps) == 44 and plan.feasible
    assert all(s.base_pose is not None for s in plan.steps)  # B4 ran: every step has its base pose
    g = Graph().parse(out / "plan.ttl", format="turtle")
    assert len(set(g.subjects(KBP.forSkill, None))) == 44
    verdicts = json.loads((out / "feasibility.json").read_text())
    assert (verdicts["installable"], verdicts["total"]) == (11, 11)


def test_no_feasibility_gives_the_action_level_plan_only(tmp_path: Path) -> None:
    assert main(["plan", str(CASE_STUDY), "--scenario", "storage-outside", "--no-feasibility",
                 "--out", str(tmp_path / "run")]) == 0
    assert sorted(p.name for p in (tmp_path / "run").iterdir()) == [".kbplanner-run", "plan.json", "plan.ttl"]
    plan = Plan.from_json((tmp_path / "run" / "plan.json").read_text())
    assert all(s.base_pose is None for s in plan.steps)


def test_an_infeasible_plan_is_printed_and_written_and_exits_1(tmp_path: Path) -> None:
    r = _kbplanner("plan", str(CASE_STUDY), "--out", str(tmp_path))
    assert r.returncode == 1, r.stderr
    assert "44 of 44 steps are infeasible (22 skipped after an infeasible step of their element)" in r.stdout
    assert "missing input 'grasp point'" in r.stdout and "Traceback" not in r.stderr
    assert "feasibility (B4): 0 of 11 elements installable" in r.stdout
    assert "fix: add the missing model information" in r.stdout
    data = json.loads((tmp_path / "plan.json").read_text())
    assert sum(1 for s in data["steps"] if not s["feasible"]) == 44
    assert sum(1 for s in data["steps"] if s["reason"].startswith("skipped")) == 22
    verdicts = json.loads((tmp_path / "feasibility.json").read_text())["elements"]
    assert all(v["figure"] and (tmp_path / v["figure"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
               for v in verdicts)


def test_an_unknown_task_or_robot_exits_2_naming_the_known_ids() -> None:
    r = _kbplanner("plan", str(CASE_STUDY), "--task", "T-NOPE")
    assert r.returncode == 2
    assert "no robotized task with id 'T-NOPE'" in r.stderr and "T-FRAME" in r.stderr
    assert "Traceback" not in r.stderr
    assert main(["plan", str(CASE_STUDY), "--robot", "r2d2"]) == 2


def test_plan_help_documents_the_exit_codes() -> None:
    r = _kbplanner("plan", "--help")
    assert r.returncode == 0
    text = " ".join(r.stdout.split())
    assert "0 every step feasible; 1 some step infeasible" in text and "2 bad input" in text
