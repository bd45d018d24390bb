"""Site locations are checked, not ignored (issue 17): a pickup location that cannot be used stops the run."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from kbplanner.core.errors import SiteLocationError
from kbplanner.model.dates import parse_date
from kbplanner.project import Project
from kbplanner.world.build import build_world
from kbplanner.world.maps import storey_map
from kbplanner.world.site_checks import check_pickup_locations
from sim_project_factory import DATE, PICKUP, make_sim_project


def _move_pickup(directory: Path, x: float, y: float) -> None:
    stored = directory / "stored.ttl"
    px, py = PICKUP[0], PICKUP[1]
    text = stored.read_text()
    old = f"site:pickup a kbp:Pose ; kbp:x {px!r} ; kbp:y {py!r} ;"
    assert old in text
    stored.write_text(text.replace(old, f"site:pickup a kbp:Pose ; kbp:x {x!r} ; kbp:y {y!r} ;"))


def _check(directory: Path) -> None:
    project = Project.load(directory, scenario="stored")
    world = build_world(project, parse_date(DATE))
    check_pickup_locations(world, storey_map(world).grid)


def test_the_declared_pickup_location_passes(tmp_path: Path) -> None:
    make_sim_project(tmp_path / "p")
    _check(tmp_path / "p")


@pytest.mark.parametrize(("x", "y", "words"), [
    (50.0, -2.5, "off the site"),
    (2.5, -3.5, "inside 'Panel storage'"),
    (0.0, 0.15, "occupied cell"),  # in the building's front wall
])
def test_an_unusable_pickup_location_is_an_error(tmp_path: Path, x: float, y: float, words: str) -> None:
    make_sim_project(tmp_path / "p")
    _move_pickup(tmp_path / "p", x, y)
    with pytest.raises(SiteLocationError, match=words) as err:
        _check(tmp_path / "p")
    assert "kbp:pickupLocation" in str(err.value) and "fix:" in str(err.value)


def test_simulate_stops_with_exit_2(tmp_path: Path) -> None:
    make_sim_project(tmp_path / "p")
    _move_pickup(tmp_path / "p", 50.0, -2.5)
    proc = subprocess.run([sys.executable, "-m", "kbplanner", "simulate", str(tmp_path / "p"), "--scenario",
                           "stored", "--no-keyframes", "--out", str(tmp_path / "run")],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 2, proc.stderr
    assert "off the site" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "run").exists()


def test_a_pickup_walled_off_from_the_robot_start_is_no_input_error(tmp_path: Path) -> None:
    import dataclasses

    from kbplanner.world.site_checks import pickup_problem

    make_sim_project(tmp_path / "p")
    project = Project.load(tmp_path / "p", scenario="stored")
    world = build_world(project, parse_date(DATE))
    grid = storey_map(world).grid
    storage = next(o for o in world.site_objects if o.pickup is not None)
    assert world.robot_start is not None and storage.pickup is not None
    assert pickup_problem(world, grid, storage) is None
    occ = grid.occupied.copy()
    ix, iy = grid.cell_of(storage.pickup.x, storage.pickup.y)
    occ[iy - 2:iy + 3, ix - 2:ix + 3] = True  # a closed ring of occupied cells around the pickup
    occ[iy - 1:iy + 2, ix - 1:ix + 2] = False
    walled = dataclasses.replace(grid, occupied=occ)
    problem = pickup_problem(world, walled, storage)
    # valid ground, only walled off: an infeasible plan reported per element (exit 1), not bad input
    assert problem is None
