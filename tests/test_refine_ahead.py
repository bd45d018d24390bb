"""B4 ahead of B5 (planning/refine_ahead.py): B4 in a forked process hands each element over as it is
refined; the plan B5 runs is then B4's plan, value for value, the run writes the same bytes as one from
the plan B4 refined in-process, and B4's kept plan is written as before. An error of the B4 process reaches
the user as the sequential path's (same message, exit 2, no run folder); a process that ends without its
plan is no hang; B4's order feedback (another order after the first pass) is told with the final plan."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import pytest

from kbplanner.core.errors import KbplannerError
from kbplanner.planning import refine_ahead, refine_cache
from kbplanner.planning.step_kinds import elements_in_order
from sim_project_factory import SimCase, load_sim_case

RUN_FILES = ("trajectories.csv", "events.jsonl", "metrics.json", "plan.json", "footprints.json")
_CASES: dict[str, SimCase] = {}


def _case(tmp_path_factory: pytest.TempPathFactory) -> SimCase:
    if "stored" not in _CASES:
        _CASES["stored"] = load_sim_case(tmp_path_factory.mktemp("ahead") / "p")
    return _CASES["stored"]


def test_the_plan_handed_over_element_by_element_is_b4s_plan(
        tmp_path: Path, tmp_path_factory: pytest.TempPathFactory) -> None:
    case = _case(tmp_path_factory)
    done: list[tuple[int, int]] = []
    ahead = refine_ahead.start(case.plan, case.world, seed=3, grid=case.grid, cache_dir=tmp_path, folder=None)
    assert ahead is not None
    try:
        ahead.progress = lambda _iri, n, total: done.append((n, total))
        order = elements_in_order(case.plan)
        assert len(order) >= 2
        for iri in order:
            ahead.ready(iri)
            assert ahead.plan.steps_for(iri) == case.refined.steps_for(iri)  # field for field
        assert ahead.final is not None and ahead.b4_failed() is None
        assert ahead.plan == case.refined and ahead.plan.to_json() == case.refined.to_json()
    finally:
        assert ahead.close() == 0
    assert done[-1] == (len(order), len(order))
    # the refined plan kept as the sequential path keeps it; with it kept, nothing is started
    kept = refine_cache.kept_plan(case.plan, case.world, seed=3, cache_dir=tmp_path, grid=case.grid)
    assert kept is not None and kept.to_json() == case.refined.to_json()
    assert refine_ahead.start(case.plan, case.world, seed=3, grid=case.grid, cache_dir=tmp_path,
                              folder=None) is None


def test_nothing_is_started_when_turned_off(tmp_path_factory: pytest.TempPathFactory,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    case = _case(tmp_path_factory)
    monkeypatch.setenv("KBPLANNER_B4_AHEAD", "0")
    assert refine_ahead.start(case.plan, case.world, seed=3, grid=case.grid, cache_dir=None,
                              folder=None) is None


def test_a_run_with_b4_ahead_writes_the_same_bytes(tmp_path: Path,
                                                   tmp_path_factory: pytest.TempPathFactory) -> None:
    from kbplanner.simulation.executor import simulate
    from kbplanner.simulation.skills import ExecSettings

    case = _case(tmp_path_factory)
    settings = ExecSettings(keyframes=False)
    simulate(case.project, case.refined, seed=3, out_dir=tmp_path / "sequential", world=case.world,
             grid=case.grid, settings=settings)
    ahead = refine_ahead.start(case.plan, case.world, seed=3, grid=case.grid, cache_dir=None, folder=None)
    assert ahead is not None
    try:
        simulate(case.project, ahead.plan, seed=3, out_dir=tmp_path / "ahead", world=case.world,
                 grid=case.grid, settings=settings, ready=ahead.ready)
    finally:
        assert ahead.close() == 0
    for f in RUN_FILES:
        assert (tmp_path / "ahead" / f).read_bytes() == (tmp_path / "sequential" / f).read_bytes(), f


def test_an_error_of_the_b4_process_is_the_sequential_paths(tmp_path: Path,
                                                            tmp_path_factory: pytest.TempPathFactory) -> None:
    case = _case(tmp_path_factory)
    bad = dataclasses.replace(case.plan, robot_id="no-such-robot", robot_urdf="")  # B4 cannot load it
    with pytest.raises(KbplannerError) as sequential:
        refine_cache.refine_kept(bad, case.world, seed=3, grid=case.grid, cache_dir=tmp_path)
    ahead = refine_ahead.start(bad, case.world, seed=3, grid=case.grid, cache_dir=tmp_path, folder=None)
    assert ahead is not None
    with pytest.raises(refine_ahead.AheadFailed) as failed:
        ahead.ready(elements_in_order(bad)[0])
    assert str(sequential.value) in str(failed.value)
    assert str(sequential.value) in (ahead.b4_failed() or "")  # (asked where B5 failed first)
    assert ahead.close() == 1
    assert not list(tmp_path.rglob("*.json"))  # nothing kept


def test_the_command_reports_an_error_of_b4_once_with_exit_2(tmp_path: Path) -> None:
    from sim_project_factory import make_sim_project
    from test_site_checks import _move_pickup

    make_sim_project(tmp_path / "p")
    _move_pickup(tmp_path / "p", 50.0, -2.5)  # B4 checks the pickup location: off the site
    proc = subprocess.run([sys.executable, "-m", "kbplanner", "simulate", str(tmp_path / "p"), "--scenario",
                           "stored", "--no-keyframes", "--out", str(tmp_path / "run")],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("off the site") == 1 and "Traceback" not in proc.stderr
    assert not (tmp_path / "run").exists()


def test_a_b4_process_ending_without_its_plan_is_no_hang(tmp_path_factory: pytest.TempPathFactory,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    plan = _case(tmp_path_factory).plan
    first = elements_in_order(plan)[0]
    # its pipe closed (the process killed before it wrote)
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:
        os._exit(3)
    os.close(write)
    ahead = refine_ahead.RefineAhead(plan, pid, read)
    with pytest.raises(refine_ahead.AheadFailed, match="ended without its refined plan"):
        ahead.ready(first)
    assert ahead.close() == 3
    # its pipe still held by another process (here this one): the process's end is seen all the same
    monkeypatch.setattr(refine_ahead, "POLL_S", 0.05)
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:
        os._exit(0)
    ahead = refine_ahead.RefineAhead(plan, pid, read)
    try:
        with pytest.raises(refine_ahead.AheadFailed):
            ahead.ready(first)
    finally:
        os.close(write)
        ahead.close()


def test_the_command_with_b4_ahead_writes_what_a_kept_plan_run_writes(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    import logging

    from kbplanner.cli import main
    from sim_project_factory import make_sim_project

    make_sim_project(tmp_path / "p")
    words = ["simulate", str(tmp_path / "p"), "--scenario", "stored", "--no-keyframes", "--out"]
    with caplog.at_level(logging.INFO, logger=refine_ahead.__name__):
        first = main([*words, str(tmp_path / "first")])  # B4 ahead of B5
        assert [r for r in caplog.records if "ahead of B5" in r.getMessage()]
        caplog.clear()
        assert main([*words, str(tmp_path / "again")]) == first  # B4's plan kept: B4 then B5
        assert not [r for r in caplog.records if "ahead of B5" in r.getMessage()]
    for f in RUN_FILES:
        assert (tmp_path / "first" / f).read_bytes() == (tmp_path / "again" / f).read_bytes(), f


@pytest.mark.slow
def test_b4s_order_feedback_is_told_with_the_final_plan(tmp_path: Path) -> None:
    # the generated building of tests/test_install_order_generated.py: B4 moves a blocked frame first
    from kbplanner.core.vocab import KBP
    from kbplanner.planning.manipulation import refine_plan
    from kbplanner.planning.planner import plan_task
    from kbplanner.project import Project
    from kbplanner.scale.building_generator import generate_building
    from kbplanner.world.build import build_world
    from kbplanner.world.maps import storey_map

    generate_building(tmp_path / "b", storeys=1, units_per_storey=1)
    project = Project.load(tmp_path / "b", scenario="storage-in-units")
    project.model.remove((None, KBP.workSequence, None))
    world = build_world(project, project.world_date(None), None)
    plan = plan_task(project, world=world)
    grid = storey_map(world).grid
    ahead = refine_ahead.start(plan, world, seed=7, grid=grid, cache_dir=None, folder=None)
    assert ahead is not None
    try:
        with pytest.raises(refine_ahead.AheadDiffers) as differs:
            for iri in elements_in_order(plan):
                ahead.ready(iri)
    finally:
        assert ahead.close() == 0
    assert "B4 moved" in differs.value.plan.order_rule
    assert differs.value.plan.to_json() == refine_plan(plan, world, seed=7, grid=grid).to_json()
