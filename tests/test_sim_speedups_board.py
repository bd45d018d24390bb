"""B5 speed-ups of the board task's legs: the cell path kept per space and query (a leg planned again with
other seeds takes it without searching again: identical results), and the switch that skips those seed
retries altogether (a behaviour change, off by default)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kbplanner.simulation import carry_paths, cell_path, navigation
from kbplanner.simulation.nav_path import NavSettings
from kbplanner.simulation.skills import navigation as skill_navigation
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

CASE_STUDY = Path(__file__).resolve().parents[1] / "data" / "case_study"


def _space(read_only: bool, width_m: float = 0.3) -> ConfigurationSpace:
    occ = np.zeros((60, 100), dtype=bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    occ[:, 48:52] = True
    occ[26:36, 48:52] = False  # a 0.5 m door
    cs = ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05),
                                  Footprint((Rect(0.0, 0.0, 0.5, width_m),)), 36)
    if read_only:
        cs.free.setflags(write=False)
    return cs


def test_a_kept_cell_path_is_the_path_searched_again(monkeypatch: pytest.MonkeyPatch) -> None:
    searches = 0
    search = cell_path.face_path

    def counting(*args):  # type: ignore[no-untyped-def]
        nonlocal searches
        searches += 1
        return search(*args)

    monkeypatch.setattr(cell_path, "face_path", counting)
    monkeypatch.setattr(cell_path, "_ROUTES", {})
    start, goal = (0.8, 0.8, 0.3), (4.2, 2.2, 2.0)
    kept, fresh = _space(read_only=True), _space(read_only=False)
    paths = []
    for seed in (1, 2, 3, 1):
        settings = NavSettings(seed=seed, max_motion_checks=40)  # RRTConnect gives up: the cell path
        got = navigation.plan_path(kept, start, goal, settings=settings)
        want = navigation.plan_path(fresh, start, goal, settings=settings)  # writable maps: searched anew
        assert got.ok and "cell search" in got.reason
        assert (got.poses, got.reason, got.planner, got.length_m) == (
            want.poses, want.reason, want.planner, want.length_m)
        paths.append(got.poses)
    assert len(set(paths)) == 1  # the cell path does not depend on the seed
    assert searches == 4 + 1  # the writable space each time, the read-only one once
    # another query on the same space is searched
    other = navigation.plan_path(kept, start, (4.4, 1.0, 0.0), settings=NavSettings(max_motion_checks=40))
    assert other.ok and other.poses[-1][:2] == (4.4, 1.0) and searches == 6


def test_no_cell_path_is_kept_as_no_path(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cell_path, "_ROUTES", {})
    cs = _space(read_only=True, width_m=0.6)  # wider than the door whichever way it turns
    settings = NavSettings(max_motion_checks=40)
    start, goal = (0.8, 0.8, 0.3), (4.2, 2.2, 2.0)
    for _ in range(2):
        assert cell_path.cell_route(cs, start, goal, settings, 0.0, "no path") is None
    key = (0.0, 0.0, 0.05, start, goal, "turn_drive_turn", True, settings.base_limits,
           settings.reverse_s_per_m)
    assert list(cell_path._ROUTES.values()) == [{key: "none"}]  # kept: not searched again
    path = navigation.plan_path(cs, start, goal, settings=settings)
    assert not path.ok and "walled off" in path.reason


@pytest.mark.slow
def test_board_legs_not_retried_after_a_cell_path_drive_the_same_on_the_case_study(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``ExecSettings.detour_retry_cell_paths`` False (a behaviour change, off by default) skips the seed
    retries of detour legs that ended on the cell path: fewer planning queries, and on the case study's
    board task outside (seed 7) a slower run: one retry there drives quicker (since reverse12; before,
    none did and the outputs were the same). With the carry legs'
    cell route first (``carry_cells_first``, the default) those legs no longer try RRTConnect at all, so
    the retries are looked at with it off, where they still happen."""
    from kbplanner.planning.manipulation import refine_plan
    from kbplanner.planning.planner import plan_task
    from kbplanner.project import Project
    from kbplanner.simulation.executor import INSTALLED, simulate
    from kbplanner.simulation.skills.base import ExecSettings
    from kbplanner.world.build import build_world
    from kbplanner.world.maps import storey_map

    queries = 0
    plan_path = navigation.plan_path

    def counting(*args, **kwargs):  # type: ignore[no-untyped-def]
        nonlocal queries
        queries += 1
        return plan_path(*args, **kwargs)

    monkeypatch.setattr(navigation, "plan_path", counting)
    monkeypatch.setattr(carry_paths, "plan_path", counting)
    monkeypatch.setattr(skill_navigation, "plan_path", counting)
    outputs, counts = [], []
    for retry in (True, False):
        project = Project.load(CASE_STUDY, scenario="storage-outside")
        world = build_world(project, project.world_date("T-BOARD"), "T-BOARD")
        grid = storey_map(world).grid
        plan = refine_plan(plan_task(project, "T-BOARD", world=world), world, seed=7, grid=grid)
        queries = 0
        out = tmp_path / f"retry-{retry}"
        result = simulate(project, plan, seed=7, out_dir=out, world=world, grid=grid,
                          settings=ExecSettings(keyframes=False, carry_cells_first=False,
                                                detour_retry_cell_paths=retry))
        assert [e.outcome for e in result.elements] == [INSTALLED] * 5
        counts.append(queries)
        outputs.append([(out / f).read_bytes() for f in ("trajectories.csv", "events.jsonl", "metrics.json")])
    assert counts[1] < counts[0]
    # Since reverse12 (a path that drove backwards under monitoring is turned round where the base can
    # turn, which changes the legs' drive times) one retry there drives quicker: the outputs differ, and
    # skipping the retries costs simulated time (630.7 vs 636.6 s when this was written).
    assert outputs[0] != outputs[1]
    ends = [float(o[0].decode().rstrip().rsplit("\n", 1)[-1].split(",", 1)[0]) for o in outputs]
    assert ends[0] < ends[1]
