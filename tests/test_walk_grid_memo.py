"""The workers' ground-floor map kept between a building's upper-storey tasks (issue 14, the 10 x 8
building): the kept map is the map ``storey_map`` builds for each task, a copy of its own per task, and a
change of the ground floor's elements is a new map."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from kbplanner.scale.building_generator import generate_building
from kbplanner.simulation import floors

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def building(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return generate_building(tmp_path_factory.mktemp("walk") / "b4x1", storeys=4, units_per_storey=1,
                             seed=0).directory


def test_the_upper_storeys_tasks_get_the_ground_floor_map_storey_map_builds(building: Path) -> None:
    from kbplanner.project import Project
    from kbplanner.world.build import build_world
    from kbplanner.world.maps import storey_map

    project = Project.load(building, scenario="storage-in-units")
    worlds = [build_world(project, project.world_date(t), t) for t in ("T-FRAME-L03", "T-FRAME-L04")]
    ground = floors.ground_storey(worlds[0])
    assert ground is not None and worlds[0].task_storey != ground.iri
    assert floors._ground_key(worlds[0], ground) == floors._ground_key(worlds[1], ground)  # one map for both
    floors._kept.clear()
    got = []
    for world in worlds:
        upper = storey_map(world).grid
        grid = floors.walk_grid(world, upper)
        built = storey_map(world, ground.iri).grid
        assert np.array_equal(grid.occupied, built.occupied) and grid.occupied.dtype == built.occupied.dtype
        assert (grid.origin, grid.resolution, grid.band, grid.notes) == (
            built.origin, built.resolution, built.band, built.notes)
        got.append(grid)
    assert got[0].occupied is not got[1].occupied  # each task its own array
    got[0].occupied[:] = True
    assert not floors.walk_grid(worlds[1], storey_map(worlds[1]).grid).occupied.all()

    # an element of the ground floor elsewhere: another map
    moved = next(e for e in worlds[1].static if e.storey == ground.iri and e.mesh_path is not None
                 and e.bounds is not None)
    shifted = dataclasses.replace(moved, bounds=dataclasses.replace(moved.bounds, xmin=moved.bounds.xmin - 1))
    static = tuple(shifted if e is moved else e for e in worlds[1].static)
    other = dataclasses.replace(worlds[1], static=static)
    assert floors._ground_key(other, ground) != floors._ground_key(worlds[1], ground)
