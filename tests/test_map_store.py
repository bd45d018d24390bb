"""Occupancy maps kept on disk (world/map_store.py, issue 14): a kept map is the map the meshes give, read
back exactly (cells, origin, band, notes and their types); another world or setting makes another key; a
damaged file is ignored; nothing is kept without a folder or with the cache off."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from conftest import CASE_STUDY
from kbplanner.project import Project
from kbplanner.world import map_store
from kbplanner.world.build import build_world
from kbplanner.world.map_settings import MapSettings
from kbplanner.world.maps import StoreyMap, storey_map
from kbplanner.world.world_types import World

_WORLDS: dict[str, World] = {}


def _world(scenario: str = "storage-inside") -> World:
    if scenario not in _WORLDS:
        project = Project.load(CASE_STUDY, scenario=scenario)
        _WORLDS[scenario] = build_world(project, project.world_date(None), None)
    return _WORLDS[scenario]


def _same(a: StoreyMap, b: StoreyMap) -> None:
    assert np.array_equal(a.grid.occupied, b.grid.occupied) and a.grid.occupied.dtype == b.grid.occupied.dtype
    for x, y in ((a.grid.origin, b.grid.origin), (a.grid.band, b.grid.band),
                 (a.grid.resolution, b.grid.resolution), (a.grid.notes, b.grid.notes)):
        assert repr(x) == repr(y)  # the same numbers of the same types (a NumPy float stays one)
    assert (a.storey, a.band, a.ground_level, a.obstacles, a.levels) == (
        b.storey, b.band, b.ground_level, b.obstacles, b.levels)


def test_a_kept_map_is_the_map_the_meshes_give(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    world = _world()
    made = storey_map(world)
    with map_store.kept_in(tmp_path):
        first = storey_map(world)  # made and written
        kept = list(tmp_path.glob("*.npz"))
        assert len(kept) == 1
        monkeypatch.setattr("kbplanner.world.maps._grid_of_meshes",
                            lambda *a, **k: pytest.fail("the kept map was not read"))
        again = storey_map(world)
    _same(made, first)
    _same(made, again)
    assert made.obstacles > 0 and made.grid.occupied.any() and (~made.grid.occupied).any()


def test_another_world_or_setting_makes_another_key() -> None:
    inside, outside = _world("storage-inside"), _world("storage-outside")
    storey = inside.storey(inside.task_storey)
    assert storey is not None
    base = map_store.key(inside, storey, MapSettings())
    assert base == map_store.key(inside, storey, MapSettings())
    assert base != map_store.key(outside, storey, MapSettings())
    assert base != map_store.key(inside, storey, MapSettings(resolution_m=0.1))
    moved = dataclasses.replace(storey, elevation_m=storey.elevation_m + 0.5)
    assert base != map_store.key(inside, moved, MapSettings())


def test_a_damaged_file_is_ignored_and_replaced(tmp_path: Path) -> None:
    world = _world()
    storey = world.storey(world.task_storey)
    assert storey is not None
    with map_store.kept_in(tmp_path):
        made = storey_map(world)
        (path,) = tmp_path.glob("*.npz")
        path.write_bytes(b"not a map")
        assert map_store.read(world, storey, MapSettings()) is None
        again = storey_map(world)  # made again and written over the damaged file
        assert map_store.read(world, storey, MapSettings()) is not None
    _same(made, again)


def test_nothing_kept_without_a_folder_or_with_the_cache_off(tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    world = _world()
    storey_map(world)
    monkeypatch.setenv("KBPLANNER_NO_CACHE", "1")
    with map_store.kept_in(tmp_path):
        storey_map(world)
    assert not list(tmp_path.iterdir())
    assert map_store.folder_for(None) is None
    assert map_store.folder_for(tmp_path / "entry") == tmp_path / "entry" / map_store.SUBDIR
