"""A6 on the case study (data/case_study): the Duplex on 2022-05-10 with the 11 frames at their storage."""

from __future__ import annotations

import itertools
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pybullet as p
import pytest
from rdflib import Literal, URIRef

from kbplanner.core.iris import element_iri
from kbplanner.core.vocab import BOT, KBP
from kbplanner.model.dates import parse_date
from kbplanner.project import Project
from kbplanner.simulation.sim_world import load_world, settle
from kbplanner.world.build import build_world
from kbplanner.world.maps import StoreyMap, storey_map
from kbplanner.world.meshes import site_object_mesh
from kbplanner.world.world_types import NOT_STARTED, World

Expected = dict[str, Any]
CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"
pytestmark = pytest.mark.skipif(not (CASE / "project.toml").is_file(), reason="case study not present")


@pytest.fixture(scope="module")
def expected() -> Expected:
    return tomllib.loads((CASE / "expected.toml").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def outside() -> Iterator[tuple[Project, World]]:
    project = Project.load(CASE, scenario="storage-outside")
    yield project, build_world(project, parse_date(str(project.manifest.simulation["date"])))


@pytest.fixture(scope="module")
def level1(outside: tuple[Project, World]) -> StoreyMap:
    return storey_map(outside[1])


def _storage_of(world: World) -> tuple[float, float, float, float]:
    (iri,) = {e.storage for e in world.task_elements}
    storage = next(o for o in world.site_objects if o.iri == iri)
    (x0, y0, _), (x1, y1, _) = site_object_mesh(storage).bounds
    return float(x0), float(y0), float(x1), float(y1)


def test_the_eleven_frames_wait_at_the_outside_storage(outside: tuple[Project, World],
                                                      expected: Expected) -> None:
    _, world = outside
    assert world.task_id == "T-FRAME" and world.at.isoformat() == "2022-05-10T07:00:00"
    assert len(world.task_elements) == expected["frames"]["count"] == 11
    assert {e.storage for e in world.task_elements} == {
        "https://w3id.org/kbplanner/data/duplex/site/frame-storage-outside"}
    x0, y0, x1, y1 = _storage_of(world)
    for e in world.task_elements:
        assert e.bounds is not None
        cx, cy, _ = e.bounds.center
        assert x0 <= cx <= x1 and y0 <= cy <= y1
        assert e.bounds.size[2] == pytest.approx(expected["frames"]["thickness_m"], abs=1e-4)
    for a, b in itertools.combinations(world.task_elements, 2):
        assert a.bounds is not None and b.bounds is not None
        assert a.bounds.overlap_volume(b.bounds) < 1e-9
    bottom_up = [e.label for e in sorted(world.task_elements, key=lambda e: e.bounds.zmin if e.bounds else 0)]
    assert bottom_up == [f"Stud frame panel F{n:02d}" for n in range(11, 0, -1)]  # F01, first, on top
    masses = sorted(e.mass_kg or 0.0 for e in world.task_elements)
    assert masses == pytest.approx(sorted(expected["frames"]["masses_kg"]))


def test_interior_level_1_partitions_are_absent_on_2022_05_10(outside: tuple[Project, World],
                                                             expected: Expected) -> None:
    project, world = outside
    level1 = next(s for s in world.storeys if s.label == "Level 1")
    interior = {str(el) for el in project.model.objects(URIRef(level1.iri), BOT.containsElement)
                if (el, KBP.isExternal, Literal(False)) in project.model
                and (el, KBP.ifcClass, None) in project.model
                and str(project.model.value(el, KBP.ifcClass)).startswith("IfcWall")}
    assert len(interior) == expected["ifc"]["level1_interior_walls"] == 14
    present = {e.iri for e in world.static}
    assert not interior & present
    omitted = {o.iri: o for o in world.omitted}
    assert all(omitted[iri].state == NOT_STARTED for iri in interior)
    # the exterior and party walls of Level 1 (T-EXT1, finished in March) stand
    exterior = {str(el) for el in project.model.objects(URIRef(level1.iri), BOT.containsElement)
                if (el, KBP.isExternal, Literal(True)) in project.model
                and str(project.model.value(el, KBP.ifcClass)).startswith("IfcWall")}
    assert exterior and exterior <= present


def test_the_roof_in_progress_is_present_and_furniture_is_not(outside: tuple[Project, World]) -> None:
    _, world = outside
    in_progress = {e.kind for e in world.static if e.state == "in progress"}
    assert in_progress and "Furniture" not in {e.kind for e in world.static}
    storey = world.storey(world.task_storey)
    assert storey is not None and storey.label == "Level 1"


def test_the_unit_entrance_is_open_and_the_exterior_walls_block(outside: tuple[Project, World],
                                                               level1: StoreyMap,
                                                               expected: Expected) -> None:
    project, _world = outside
    door = element_iri(project.base, str(expected["route"]["entrance_door"]))
    box = project.model.value(door, KBP.bounds)
    cx = (float(project.model.value(box, KBP.minX)) + float(project.model.value(box, KBP.maxX))) / 2
    cy = (float(project.model.value(box, KBP.minY)) + float(project.model.value(box, KBP.maxY))) / 2
    grid = level1.grid
    assert not grid.is_occupied(cx, cy)  # the front door opening (the door leaf is not even hung yet)
    assert grid.is_occupied(cx, cy + 1.2) or grid.is_occupied(cx, cy - 1.2)  # the facade beside it
    assert not grid.is_occupied(*expected["site"]["robot_start"])
    assert grid.is_occupied(7.9, -18.95)  # the scaffold's no-go zone


def test_the_inside_scenario_stacks_the_frames_in_the_living_room() -> None:
    project = Project.load(CASE, scenario="storage-inside")
    world = build_world(project, parse_date("2022-05-10T07:00"))
    assert len(world.task_elements) == 11
    (storage,) = {e.storage for e in world.task_elements}
    assert storage is not None and storage.endswith("frame-storage-inside")
    x0, y0, x1, y1 = _storage_of(world)
    assert 0.0 < x0 < x1 < 8.8 and -17.8 < y0 < y1 < 0.0  # inside the building footprint


def test_the_case_study_loads_in_pybullet_and_the_frames_stay(outside: tuple[Project, World]) -> None:
    _, world = outside
    client = p.connect(p.DIRECT)
    try:
        sim = load_world(world, client)
        assert sim.body_count == 1 + len(world.static_groups()) + 11 + len(world.solid_site_objects)
        assert sim.body_count < 50  # merged: 73 static elements in 15 bodies
        assert settle(sim, seconds=1.0) < 0.02
    finally:
        p.disconnect(client)
