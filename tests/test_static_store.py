"""The static bodies' triangles kept on disk (B5 set-up, simulation/static_store.py): read back, the very
arrays made from the mesh files, and the same PyBullet world loaded from them (no mesh file read); another
world, a changed mesh file or a damaged file is not read; nothing is kept without a folder, nor for a big
world."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from kbplanner.model.dates import parse_date
from kbplanner.project import Project
from kbplanner.simulation import sim_world, static_store
from kbplanner.simulation.sim_world import SimWorld, load_world, static_chunks
from kbplanner.world import cspace_store
from kbplanner.world.build import build_world
from kbplanner.world.world_types import World
from world_project_factory import DATE, WorldProject, make_world_project


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> World:
    wp: WorldProject = make_world_project(tmp_path_factory.mktemp("worldproj"))
    return build_world(Project.load(wp.directory, scenario="stored"), parse_date(DATE))


def _bodies(world: World) -> tuple[SimWorld, list[tuple[object, ...]]]:
    """The world loaded in a new client: its bodies and, per static body, its mesh shape's vertices."""
    client = p.connect(p.DIRECT)
    try:
        sim = load_world(world, client)
        shapes = []
        for group, bodies in sorted(sim.static_bodies.items()):
            for body in bodies:
                shape = p.getCollisionShapeData(body, -1, physicsClientId=client)[0]
                mesh = p.getMeshData(body, -1, physicsClientId=client)
                shapes.append((group, body, shape[2], mesh[0], tuple(map(tuple, mesh[1]))))
        return sim, shapes
    finally:
        p.disconnect(client)


def test_kept_chunks_are_the_made_ones_and_load_the_same_world(world: World, tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    made = static_chunks(world)  # no folder: made, nothing kept
    assert made and not tmp_path.joinpath(static_store.SUBDIR).exists()
    assert {c.group for c in made} == set(world.static_groups())
    plain, plain_shapes = _bodies(world)
    folder = tmp_path / "cspace"
    with cspace_store.kept_in(folder):
        first = static_chunks(world)
        assert len(list((tmp_path / static_store.SUBDIR).glob("*.npz"))) == 1

        def no_mesh(_e: object) -> None:
            raise AssertionError("a mesh file was read")

        monkeypatch.setattr(sim_world, "element_mesh", no_mesh)
        read = static_chunks(world)
        kept, kept_shapes = _bodies(world)
    monkeypatch.undo()
    for a, b, c in zip(made, first, read, strict=True):
        assert a.group == b.group == c.group and a.iris == b.iris == c.iris
        assert a.vertices.dtype == c.vertices.dtype == np.float64 and a.faces.dtype == c.faces.dtype
        assert a.vertices.tobytes() == c.vertices.tobytes() and a.faces.tobytes() == c.faces.tobytes()
    assert kept.element_bodies == plain.element_bodies and kept.static_bodies == plain.static_bodies
    assert kept.triangles == plain.triangles and kept_shapes == plain_shapes


def test_another_world_a_changed_file_or_a_damaged_file_is_not_read(world: World, tmp_path: Path) -> None:
    folder = tmp_path / "cspace"
    with cspace_store.kept_in(folder):
        static_chunks(world)
        (kept,) = (tmp_path / static_store.SUBDIR).glob("*.npz")
        key = static_store.key(world)
        assert kept.stem == key
        some = next(e for members in world.static_groups().values() for e in members)
        assert some.mesh_path is not None
        stat = os.stat(some.mesh_path)
        os.utime(some.mesh_path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))  # a rewritten file
        try:
            assert static_store.key(world) != key and static_store.read(world) is None
        finally:
            os.utime(some.mesh_path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
        assert static_store.read(world) is not None
        kept.write_bytes(b"not a zip file")
        assert static_store.read(world) is None
        again = static_chunks(world)  # made again and kept again
        assert static_store.read(world) is not None and len(again) == len(static_store.read(world) or [])


def test_a_big_world_is_not_kept(world: World, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "cspace"
    with cspace_store.kept_in(folder):
        monkeypatch.setattr(static_store, "MAX_ELEMENTS", 1)
        assert static_store.key(world) is None
        made = static_chunks(world)
        monkeypatch.setattr(static_store, "MAX_ELEMENTS", 10_000)
        monkeypatch.setattr(static_store, "MAX_BYTES", 100)
        assert static_chunks(world)[0].vertices.tobytes() == made[0].vertices.tobytes()
    assert not (tmp_path / static_store.SUBDIR).exists()
