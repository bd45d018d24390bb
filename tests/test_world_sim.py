"""A6 -> B5: the world loaded into PyBullet (DIRECT) on the small generated project."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pybullet as p
import pytest

from kbplanner.core.errors import KbplannerError
from kbplanner.model.dates import parse_date
from kbplanner.project import Project
from kbplanner.simulation.sim_world import SimWorld, element_frame, load_world, settle
from kbplanner.world.build import build_world
from kbplanner.world.world_types import World, pose_matrix
from world_project_factory import DATE, WorldProject, make_world_project


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> World:
    wp: WorldProject = make_world_project(tmp_path_factory.mktemp("worldproj"))
    return build_world(Project.load(wp.directory, scenario="stored"), parse_date(DATE))


@pytest.fixture
def sim(world: World) -> Iterator[SimWorld]:
    client = p.connect(p.DIRECT)
    try:
        yield load_world(world, client)
    finally:
        p.disconnect(client)


def _drop_box(sim: SimWorld, x: float, y: float, z: float, half: float = 0.1) -> int:
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[half] * 3, physicsClientId=sim.client)
    return int(p.createMultiBody(baseMass=5.0, baseCollisionShapeIndex=shape, basePosition=[x, y, z],
                                 physicsClientId=sim.client))


def _position(sim: SimWorld, body: int) -> np.ndarray:
    return np.array(p.getBasePositionAndOrientation(body, physicsClientId=sim.client)[0])


def test_static_geometry_is_merged_into_few_concave_bodies(world: World, sim: SimWorld) -> None:
    assert set(sim.static_bodies) == set(world.static_groups())
    assert sim.body_count == 1 + len(world.static_groups()) + len(world.task_elements) + len(
        world.solid_site_objects)
    assert p.getNumBodies(physicsClientId=sim.client) == sim.body_count
    for bodies in sim.static_bodies.values():
        for body in bodies:
            assert p.getDynamicsInfo(body, -1, physicsClientId=sim.client)[0] == 0.0  # mass 0: static
            shape = p.getCollisionShapeData(body, -1, physicsClientId=sim.client)[0]
            assert shape[2] == p.GEOM_MESH
    for e in world.static:
        assert sim.body_of(e.iri) in sim.static_bodies[e.group]


def test_task_elements_are_separate_bodies_with_the_model_mass(world: World, sim: SimWorld) -> None:
    assert len(set(sim.task_bodies.values())) == len(world.task_elements) == 3
    for e in world.task_elements:
        body = sim.task_bodies[e.iri]
        assert p.getDynamicsInfo(body, -1, physicsClientId=sim.client)[0] == pytest.approx(e.body_mass_kg)
        assert e.pose is not None
        assert np.allclose(element_frame(sim, e), pose_matrix(e.pose), atol=1e-6)


def test_stacked_task_elements_stay_on_their_storage(world: World, sim: SimWorld) -> None:
    moved = settle(sim, seconds=2.0)
    assert moved < 0.02  # metres, over 2 s of simulated time
    for e in world.task_elements:
        assert e.pose is not None
        assert np.allclose(element_frame(sim, e)[:3, 3], [e.pose.x, e.pose.y, e.pose.z], atol=0.02)


def test_a_body_dropped_on_the_ground_stays_on_it(sim: SimWorld) -> None:
    body = _drop_box(sim, -2.0, -2.0, 1.0)
    settle(sim, seconds=2.0)
    x, y, z = _position(sim, body)
    assert z == pytest.approx(0.1, abs=0.01) and abs(x + 2.0) < 0.01 and abs(y + 2.0) < 0.01


def test_a_body_dropped_inside_rests_on_the_level_2_slab(sim: SimWorld) -> None:
    body = _drop_box(sim, 2.5, 3.0, 4.0)
    settle(sim, seconds=2.0)
    assert _position(sim, body)[2] == pytest.approx(3.1, abs=0.01)  # slab top at 3.0 m


def test_solid_site_objects_are_static_boxes_and_areas_no_bodies(world: World, sim: SimWorld) -> None:
    assert set(sim.site_object_bodies) == {o.iri for o in world.solid_site_objects}
    for area in world.areas:
        with pytest.raises(KbplannerError):
            sim.body_of(area.iri)


def test_visual_shapes_can_be_added_for_rendering(world: World) -> None:
    client = p.connect(p.DIRECT)
    try:
        sim = load_world(world, client, visuals=True)
        shapes = p.getVisualShapeData(sim.task_bodies[world.task_elements[0].iri], physicsClientId=client)
        assert shapes and shapes[0][2] == p.GEOM_MESH
    finally:
        p.disconnect(client)
