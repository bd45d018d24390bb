"""``kbplanner plan`` runs B4: per element installable or the step, reason, fix and a figure; exit 1.

On the small executor project (tests/sim_project_factory.py): panels P1 and P2 can be picked from the
stack and installed; P3 is mounted 1.8 m above the floor, out of the arm's reach.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pytest

from kbplanner.cli import main
from kbplanner.core.vocab import KBP
from kbplanner.planning.feasibility import (
    DEFAULT_FIX,
    INSTALL_OUT_OF_REACH_FIX,
    element_verdicts,
    figure_name,
    fix_for,
    needs_figure,
)
from kbplanner.planning.plan_model import ElementInfo, Plan, Pose6, SkillCall
from sim_project_factory import make_sim_project

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def planned(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, int, str]:
    base = tmp_path_factory.mktemp("feasibility")
    make_sim_project(base / "project")
    out = base / "plan"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["plan", str(base / "project"), "--scenario", "stored", "--out", str(out)])
    return base, out, rc, buf.getvalue()


def test_an_element_out_of_reach_makes_the_plan_infeasible_with_reason_fix_and_figure(
        planned: tuple[Path, Path, int, str]) -> None:
    _base, out, rc, text = planned
    assert rc == 1
    assert "feasibility (B4): 2 of 3 elements installable" in text
    assert "Panel P1: installable" in text and "Panel P2: installable" in text
    assert "Panel P3: NOT installable, step 12 (MM-R-1" in text
    assert "out of reach from any base pose: the tool would have to be at 3.00 m" in text
    assert f"fix: {INSTALL_OUT_OF_REACH_FIX[:40]}" in text
    data = json.loads((out / "feasibility.json").read_text())
    assert (data["installable"], data["total"]) == (2, 3)
    p3 = next(v for v in data["elements"] if v["label"] == "Panel P3")
    assert p3["feasible"] is False and p3["step"] == 12 and p3["skill_id"] == "MM-R-1"
    assert p3["fix"] == INSTALL_OUT_OF_REACH_FIX
    assert p3["figure"] == "infeasible-step012-Panel-P3.png"
    assert (out / p3["figure"]).read_bytes()[:8] == PNG
    assert (out / "plan.png").read_bytes()[:8] == PNG
    assert all(v["figure"] is None for v in data["elements"] if v["feasible"])


def test_plan_outputs_are_byte_identical_on_a_rerun(planned: tuple[Path, Path, int, str]) -> None:
    base, out, _rc, _text = planned
    again = base / "again"
    assert main(["plan", str(base / "project"), "--scenario", "stored", "--out", str(again)]) == 1
    names = sorted(p.name for p in out.iterdir() if p.name != ".kbplanner-run")
    assert names == sorted(p.name for p in again.iterdir() if p.name != ".kbplanner-run")
    for name in names:
        assert (again / name).read_bytes() == (out / name).read_bytes(), name


def test_without_b4_the_same_project_plans_every_step_feasible(planned: tuple[Path, Path, int, str]) -> None:
    base, _out, _rc, _text = planned
    assert main(["plan", str(base / "project"), "--scenario", "stored", "--no-feasibility"]) == 0


# ---- verdicts and fixes without a simulation ----------------------------------------------------


def _step(n: int, element: str, kind: str, *, feasible: bool = True, reason: str | None = None) -> SkillCall:
    return SkillCall(step=n, element=element, action=f"urn:a{n}", action_label=f"action {n}", action_order=n,
                     skill=f"urn:s{n}", skill_id=f"S-{n}", skill_kind=str(kind), feasible=feasible,
                     reason=reason)


def _plan(steps: list[SkillCall]) -> Plan:
    el = ElementInfo("urn:e1", "e1", "Frame 1", 10.0, (0.6, 0.09, 2.4), Pose6(5.0, 4.0, 0.0),
                     Pose6(-6.0, 3.0, 0.5), None)
    return Plan("p", None, "T", "", "S", "r", "R", "r.urdf", "rule", elements=[el], steps=steps)


def test_the_verdict_names_the_first_real_failure_not_the_skipped_steps() -> None:
    plan = _plan([_step(1, "urn:e1", KBP.Navigation),
                  _step(2, "urn:e1", KBP.MoveManipulatorAndGrasp, feasible=False,
                        reason="the element lies under 2 element(s) still at its storage (a, b): ..."),
                  _step(3, "urn:e1", KBP.NavigationWithObject, feasible=False, reason="skipped: step 2"),
                  _step(4, "urn:e1", KBP.MoveManipulatorAndRelease, feasible=False,
                        reason="skipped: step 2")])
    (v,) = element_verdicts(plan)
    assert not v.feasible and v.step == 2 and v.skill_id == "S-2"
    assert v.at == (-6.0, 3.0)  # a pick fails where the element lies
    assert v.fix is not None and "kbp:stackIndex" in v.fix and "kbp:workSequence" in v.fix
    assert needs_figure(v) and figure_name(v) == "infeasible-step002-Frame-1.png"


def test_an_install_failure_is_shown_at_the_installed_pose() -> None:
    plan = _plan([_step(1, "urn:e1", KBP.MoveManipulatorAndGrasp),
                  _step(2, "urn:e1", KBP.MoveManipulatorAndRelease, feasible=False,
                        reason="installed pose out of reach from 0 free base pose(s) tried: no base pose "
                               "near the installed pose is free")])
    (v,) = element_verdicts(plan)
    assert v.at == (5.0, 4.0)
    assert v.fix is not None and "free the floor" in v.fix
    assert element_verdicts(_plan([_step(1, "urn:e1", KBP.Navigation)]))[0].feasible


@pytest.mark.parametrize(("reason", "words"), [
    ("the element weighs 30 kg, more than the arm's payload of 16 kg (husky_ur16e)", "--robot"),
    ("the element is not at a storage in the world: no storage", "kbp:storedIn"),
    ("the robot would be shut in by the installed element", "earlier"),
    ("grasp point out of reach from 7 free base pose(s) tried: no carry pose for the normal mode",
     "graspPoint"),
    ("installed pose out of reach from 10 free base pose(s) tried: place unreachable", "in front of it"),
    ("grasp point out of reach from 3 free base pose(s) tried: no lift pose is reachable", "pickupLocation"),
    ("missing input 'grasp point' of F1", "kbplanner requirements"),
    ("something new", DEFAULT_FIX),
])
def test_every_kind_of_reason_gets_a_fix_that_names_what_to_change(reason: str, words: str) -> None:
    assert words in fix_for(reason)


def test_a_robot_that_does_not_fit_gets_a_fix_but_no_figure_per_element() -> None:
    plan = _plan([_step(1, "urn:e1", KBP.Navigation, feasible=False,
                        reason="robot Husky UR5 does not fit the task: payload 5 kg below 13 kg")])
    (v,) = element_verdicts(plan)
    assert v.fix is not None and "kbplanner robots" in v.fix
    assert not needs_figure(v)
