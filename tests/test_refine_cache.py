"""B4 kept by content hash (planning/refine_cache.py): a kept refined plan is the plan B4 gives, read back
exactly; any input B4 reads makes another key; a damaged file is ignored; and a run simulated from the
kept plan writes the same bytes as one from the plan B4 just refined."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import kbplanner.planning.refine_cache as rc
from conftest import CASE_STUDY
from kbplanner.planning.manipulation import refine_plan
from kbplanner.planning.plan_model import Plan
from kbplanner.planning.planner import plan_task
from kbplanner.planning.pose_search import RefineSettings
from kbplanner.project import Project
from kbplanner.world.build import build_world
from kbplanner.world.maps import storey_map
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import World

Case = tuple[Project, Plan, World, OccupancyGrid]
_CASES: dict[str, Case] = {}


def _case(scenario: str = "storage-inside", elements: int = 2) -> Case:
    if scenario not in _CASES:
        project = Project.load(CASE_STUDY, scenario=scenario)
        world = build_world(project, project.world_date(None), None)
        plan = plan_task(project, world=world)
        plan.keep_first(elements)
        _CASES[scenario] = (project, plan, world, storey_map(world).grid)
    return _CASES[scenario]


def test_a_kept_plan_is_read_back_exactly_and_b4_is_not_run_again(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    _, plan, world, grid = _case()
    calls: list[int] = []
    done: list[tuple[int, int]] = []

    def counted(*args: object, **kwargs: object) -> Plan:
        calls.append(1)
        return refine_plan(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(rc, "refine_plan", counted)
    first = rc.refine_kept(plan, world, seed=7, grid=grid, cache_dir=tmp_path)
    kept = list((tmp_path / rc.SUBDIR).glob("*.json"))
    assert len(kept) == 1 and kept[0].read_text(encoding="utf-8") == first.to_json()
    again = rc.refine_kept(plan, world, seed=7, grid=grid, cache_dir=tmp_path,
                           progress=lambda _iri, n, total: done.append((n, total)))
    assert len(calls) == 1  # the second call read the kept plan
    assert again.to_json() == first.to_json()
    assert again == first  # field for field, not only the same text
    assert done[-1] == (len(plan.elements), len(plan.elements))
    assert first.to_json() == refine_plan(plan, world, seed=7, grid=grid).to_json()
    # no folder: B4 runs and nothing is written
    rc.refine_kept(plan, world, seed=7, grid=grid, cache_dir=None)
    assert len(calls) == 2


def test_every_input_b4_reads_makes_another_key() -> None:
    _, plan, world, grid = _case()
    base = rc.refine_key(plan, world, grid, 7, None, True)
    assert base == rc.refine_key(plan, world, grid, 7, RefineSettings(), True)  # the defaults
    other_plan = Plan.from_json(plan.to_json())
    other_plan.steps[0].parameters = {**other_plan.steps[0].parameters, "maxSpeed": 0.123}
    blocked = np.array(grid.occupied)
    blocked[0, 0] = not blocked[0, 0]
    moved = dataclasses.replace(world, ground_z=world.ground_z + 1e-9)
    others = [
        rc.refine_key(plan, world, grid, 8, None, True),
        rc.refine_key(plan, world, grid, 7, RefineSettings(base_samples=399), True),
        rc.refine_key(plan, world, grid, 7, None, False),
        rc.refine_key(other_plan, world, grid, 7, None, True),
        rc.refine_key(plan, moved, grid, 7, None, True),
        rc.refine_key(plan, world, OccupancyGrid(blocked, grid.origin, grid.resolution, grid.band), 7, None,
                      True),
        rc.refine_key(plan, world, OccupancyGrid(grid.occupied, (grid.origin[0] + 0.01, grid.origin[1]),
                                                 grid.resolution, grid.band), 7, None, True),
    ]
    assert len({base, *others}) == len(others) + 1


def test_a_damaged_file_is_ignored_and_replaced(tmp_path: Path) -> None:
    _, plan, world, grid = _case()
    path = tmp_path / rc.SUBDIR / f"{rc.refine_key(plan, world, grid, 7, None, True)}.json"
    path.parent.mkdir(parents=True)
    path.write_text("{not json", encoding="utf-8")
    out = rc.refine_kept(plan, world, seed=7, grid=grid, cache_dir=tmp_path)
    assert path.read_text(encoding="utf-8") == out.to_json()
    path.write_text(out.to_json()[:-200], encoding="utf-8")  # cut short (a full disk)
    assert rc._read(path) is None
    assert rc._read(tmp_path / "missing.json") is None


def test_only_the_newest_plans_are_kept(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _, plan, world, grid = _case()
    monkeypatch.setattr(rc, "KEEP", 2)
    for seed in (1, 2, 3):
        rc.refine_kept(plan, world, seed=seed, grid=grid, cache_dir=tmp_path)
    names = {p.name for p in (tmp_path / rc.SUBDIR).glob("*.json")}
    assert names == {f"{rc.refine_key(plan, world, grid, s, None, True)}.json" for s in (2, 3)}


@pytest.mark.slow
def test_a_run_from_the_kept_plan_writes_the_same_bytes(tmp_path: Path) -> None:
    from kbplanner.simulation.executor import simulate
    from kbplanner.simulation.skills import ExecSettings

    project, plan, world, grid = _case()
    fresh = rc.refine_kept(plan, world, seed=7, grid=grid, cache_dir=tmp_path / "cache")
    kept = rc.refine_kept(plan, world, seed=7, grid=grid, cache_dir=tmp_path / "cache")
    settings = ExecSettings(keyframes=False)
    for name, refined in (("fresh", fresh), ("kept", kept)):
        simulate(project, refined, seed=7, out_dir=tmp_path / name, world=world, grid=grid, settings=settings)
    for f in ("trajectories.csv", "events.jsonl", "metrics.json", "plan.json", "footprints.json"):
        assert (tmp_path / "fresh" / f).read_bytes() == (tmp_path / "kept" / f).read_bytes(), f
