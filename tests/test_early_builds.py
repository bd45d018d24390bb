"""B5 set-up built early in a second process (simulation/early_builds.py): the workers' walking legs kept
by a forked process are the very legs the crowd searches (its walk the same, the legs from a stop not
searched); nothing is started without a kept folder or with the cache off; a process killed before it
wrote leaves no file. (The case study's runs with and without it: byte-identical, docs/scale.md.)"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

from kbplanner.simulation import early_builds, walk_store
from kbplanner.simulation.crowd import Crowd
from kbplanner.simulation.workers import RouteStop, WorkerSpec
from kbplanner.world import cspace_store
from kbplanner.world.occupancy import OccupancyGrid


def _map() -> OccupancyGrid:
    occ = np.zeros((140, 180), dtype=bool)
    occ[20:120, 60:70] = True  # walls to walk round
    occ[0:90, 120:125] = True
    return OccupancyGrid(occ, origin=(-0.3, 0.2), resolution=0.05)


def _specs() -> list[WorkerSpec]:
    # (stops at cell centres: a worker back at a stop stands within 5 cm of it, in its cell)
    stops = [((0.525, 0.525), 12.0), ((8.025, 5.525), 10.0), ((1.025, 6.025), 14.0)]
    return [WorkerSpec("urn:test:w1", "W1", "carpenter", 1.2,
                       tuple(RouteStop(f"s{k}", f"S{k}", x, y, d) for k, ((x, y), d) in enumerate(stops))),
            WorkerSpec("urn:test:w2", "W2", "carpenter", 1.0,
                       (RouteStop("a", "A", 8.525, 0.625, 10.0), RouteStop("b", "B", 0.625, 6.525, 10.0))),
            WorkerSpec("urn:test:w3", "W3", "site manager", 1.0, (RouteStop("c", "C", 4.0, 1.0, 5.0),))]


def _walk(crowd: Crowd, periods: int) -> list[tuple[float, float, float]]:
    out: list[tuple[float, float, float]] = []
    for _ in range(periods):
        crowd.step(None)
        out += crowd.positions()
    return out


def test_the_early_legs_are_the_crowds_own(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    grid, specs = _map(), _specs()
    folder = tmp_path / "cspace"
    early = early_builds.forked(lambda: early_builds.keep_walking_legs(specs, grid, folder))
    assert early.pid is not None and early.finish() == 0 and early.finish() == 0
    assert len(list((tmp_path / walk_store.SUBDIR).glob("*.npz"))) == 1
    # the crowd's router is the early one's (the same key: map, clearance, code)
    searched = Crowd(specs, grid, seed=7)
    assert walk_store.key(searched.router) == walk_store.key(early_builds.walking_router(grid))
    reading = Crowd(specs, grid, seed=7)
    calls: list[object] = []
    dijkstra = reading.router._dijkstra

    def counted(s: tuple[int, int], t: tuple[int, int]) -> list[tuple[int, int]]:
        calls.append((s, t))
        return dijkstra(s, t)

    monkeypatch.setattr(reading.router, "_dijkstra", counted)
    with cspace_store.kept_in(folder):
        assert walk_store.read_into(reading.router) == 3 + 2  # three legs of W1, two of W2
    assert _walk(reading, 1500) == _walk(searched, 1500)  # the same walk, bit for bit
    # the legs walked from a stop's cell were kept by the early process; a worker pushed off that cell
    # (by a wall, by another) before setting off walks a leg searched then, as before
    walked = set(searched.router._memo)
    stop_cells = {searched.router._nearest_free(*grid.cell_of(p.x, p.y)) for sp in specs for p in sp.stops}
    assert {leg for leg in walked if leg[0] in stop_cells} <= reading.router.kept_legs
    assert len(walked & reading.router.kept_legs) >= 3
    assert all(s not in stop_cells for s, _ in calls) and len(calls) == len(walked - reading.router.kept_legs)
    for leg, points in searched.router._memo.items():  # searched in the step = kept by the early process
        assert points.tobytes() == reading.router._memo[leg].tobytes()
    for leg in reading.router.kept_legs:  # and every kept leg is the search's
        assert reading.router._memo[leg].tobytes() == early_builds.walking_router(grid).path(
            grid.center_of(*leg[0]), grid.center_of(*leg[1]))[1:-1].tobytes()
    # kept before: read, nothing searched again, the file not written again
    kept = next((tmp_path / walk_store.SUBDIR).glob("*.npz"))
    stamp = kept.stat().st_mtime_ns
    assert early_builds.keep_walking_legs(specs, grid, folder) == 0
    assert kept.stat().st_mtime_ns == stamp


def test_nothing_is_started_without_a_kept_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    project = world = None  # not looked at: no process is started
    grid = _map()
    assert early_builds.start(project, world, grid, None).pid is None  # type: ignore[arg-type]
    monkeypatch.setenv("KBPLANNER_NO_CACHE", "1")
    assert early_builds.start(project, world, grid, tmp_path).pid is None  # type: ignore[arg-type]
    assert early_builds.EarlyBuilds().finish() is None
    assert not list(tmp_path.iterdir())
    # and with the cache off, the legs are neither read nor written
    monkeypatch.setenv("KBPLANNER_NO_CACHE", "1")
    assert early_builds.keep_walking_legs(_specs(), grid, tmp_path / "cspace") == 5
    assert not list(tmp_path.iterdir())


def test_a_process_killed_before_it_wrote_leaves_no_file(tmp_path: Path) -> None:
    early = early_builds.forked(lambda: time.sleep(30))
    assert early.pid is not None
    os.kill(early.pid, signal.SIGKILL)
    assert early.finish() == -signal.SIGKILL
    failed = early_builds.forked(lambda: 1 / 0)  # an error in the work: status 1, nothing written
    assert failed.finish() == 1
    assert not list(tmp_path.iterdir())


def test_the_builds_made_in_this_process_are_the_forked_ones(tmp_path: Path) -> None:
    # (kbplanner simulate makes them in its own process while B4 runs ahead of B5 in another)
    from sim_project_factory import load_sim_case

    case = load_sim_case(tmp_path / "p")
    here, there = tmp_path / "here" / "cspace", tmp_path / "there" / "cspace"
    early_builds.build(case.project, case.world, case.grid, here)
    assert early_builds.start(case.project, case.world, case.grid, there).finish() == 0

    def kept(root: Path) -> dict[str, bytes]:
        return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
                if p.is_file()}

    made = kept(here.parent)
    assert made and made == kept(there.parent)
    assert {name.split("/")[0] for name in made} >= {"walks", "static"}
    early_builds.build(case.project, case.world, case.grid, None)  # no kept folder: nothing made
