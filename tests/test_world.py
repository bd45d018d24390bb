"""A6 world at a date, on the small generated project (tests/world_project_factory.py)."""

from __future__ import annotations

import itertools
import math
from datetime import datetime

import pytest

from kbplanner.core.errors import KbplannerError, WorldError
from kbplanner.model.dates import parse_date
from kbplanner.project import Project
from kbplanner.world.build import build_world
from kbplanner.world.meshes import element_mesh
from kbplanner.world.world_types import BUILT, IN_PROGRESS, NOT_STARTED, World
from world_project_factory import DATE, STORAGE, STORAGE_SIZE, WorldProject, make_world_project


@pytest.fixture(scope="module")
def wp(tmp_path_factory: pytest.TempPathFactory) -> WorldProject:
    return make_world_project(tmp_path_factory.mktemp("worldproj"))


@pytest.fixture(scope="module")
def project(wp: WorldProject) -> Project:
    return Project.load(wp.directory, scenario="stored")


@pytest.fixture(scope="module")
def world(project: Project) -> World:
    return build_world(project, parse_date(DATE))


def _by_label(world: World) -> dict[str, str]:
    return {e.label: e.state for e in world.static}


def test_an_element_built_by_a_later_task_is_absent(world: World, wp: WorldProject) -> None:
    later = [gid for gid, w in wp.building.walls.items()
             if not w.is_external and wp.building.storeys[w.storey][0] == "Level 2"]
    assert later
    for gid in later:
        iri = wp.iri(gid)
        assert world.element(iri) is None
        omitted = next(o for o in world.omitted if o.iri == iri)
        assert omitted.state == NOT_STARTED and omitted.reason.startswith("not started")


def test_built_and_in_progress_elements_of_other_tasks_are_static(world: World, wp: WorldProject) -> None:
    states = _by_label(world)
    assert states["Interior partition L1 p1"] == BUILT
    tables = [label for label in states if label.startswith("Table")]
    assert len(tables) == len(wp.building.furniture) == 4
    assert all(states[t] == IN_PROGRESS for t in tables)  # T7 runs 2022-05-01 .. 05-20
    assert world.summary()["in_progress_static"] == 4


def test_doors_are_open_so_never_static_geometry(world: World, wp: WorldProject) -> None:
    door_iris = {wp.iri(gid) for gid in wp.building.doors}
    assert {d.iri for d in world.open_doors} == door_iris
    assert not door_iris & {e.iri for e in world.static}


def test_a_task_element_is_at_its_storage_not_at_its_installed_pose(world: World, wp: WorldProject) -> None:
    x, y, z, _yaw = STORAGE
    sx, sy, sz = STORAGE_SIZE
    assert {e.iri for e in world.task_elements} == {wp.iri(g) for g in wp.panels}
    for e in world.task_elements:
        assert e.bounds is not None and e.installed_pose is not None and e.pose is not None
        cx, cy, _cz = e.bounds.center
        assert math.hypot(cx - x, cy - y) < 1e-6  # centred on the storage footprint
        # storage yaw 90 degrees: its local x (2.8 m) runs along site y
        assert e.bounds.ymax - e.bounds.ymin <= sx + 1e-9 and e.bounds.xmax - e.bounds.xmin <= sy + 1e-9
        assert e.bounds.zmin >= z + sz - 1e-9  # on top of the storage, not on the floor
        assert math.hypot(e.pose.x - e.installed_pose.x, e.pose.y - e.installed_pose.y) > 5.0
        mesh = element_mesh(e)
        assert mesh is not None
        assert mesh.bounds[0] == pytest.approx(e.bounds.as_list()[:3], abs=1e-5)
        assert mesh.bounds[1] == pytest.approx(e.bounds.as_list()[3:], abs=1e-5)


def test_task_elements_lie_flat_with_their_thickness_vertical(world: World) -> None:
    for e in world.task_elements:
        assert e.bounds is not None and e.local_bounds is not None
        thickness = min(e.local_bounds.size)
        assert thickness == pytest.approx(0.09, abs=1e-6)
        assert e.bounds.size[2] == pytest.approx(thickness, abs=1e-6)


def test_stacked_elements_do_not_overlap_and_follow_the_stack_index(world: World, wp: WorldProject) -> None:
    elements = list(world.task_elements)
    for a, b in itertools.combinations(elements, 2):
        assert a.bounds is not None and b.bounds is not None
        assert a.bounds.overlap_volume(b.bounds) < 1e-9
    by_index = sorted(elements, key=lambda e: e.stack_index or 0)
    assert [e.stack_index for e in by_index] == [0, 1, 2]
    assert [e.iri for e in by_index] == [wp.iri(g) for g in sorted(wp.panels, key=wp.stack.__getitem__)]
    zs = [e.bounds.zmin for e in by_index if e.bounds is not None]
    assert zs == sorted(zs)
    assert zs[0] == pytest.approx(STORAGE[2] + STORAGE_SIZE[2])
    for lower, upper in itertools.pairwise(by_index):
        assert lower.bounds is not None and upper.bounds is not None
        assert upper.bounds.zmin == pytest.approx(lower.bounds.zmax, abs=1e-6)


def test_task_elements_carry_the_mass_of_the_model(world: World) -> None:
    for e in world.task_elements:
        assert e.mass_kg is not None and e.mass_kg > 0
        assert e.body_mass_kg == e.mass_kg
        assert e.mass_assumption and "kg/m3" in e.mass_assumption


def test_site_areas_are_areas_and_solid_objects_are_bodies(world: World) -> None:
    kinds = {o.kind: o for o in world.site_objects}
    assert set(kinds) == {"SiteOffice", "NoGoZone", "Workspace", "MaterialStorage"}
    assert {o.kind for o in world.areas} == {"NoGoZone", "Workspace"}
    assert {o.kind for o in world.solid_site_objects} == {"SiteOffice", "MaterialStorage"}
    assert kinds["MaterialStorage"].pickup is not None


def test_workers_stand_at_the_first_stop_of_their_route(world: World) -> None:
    (worker,) = world.workers
    assert worker.role == "carpenter" and worker.speed_mps == 1.2
    assert [s.order for s in worker.route] == [1, 2]
    assert worker.position == (12.0, 8.0, 0.0)  # the work area


def test_storeys_have_elevations_and_the_task_storey_is_the_panels_one(world: World) -> None:
    assert [(s.label, s.elevation_m) for s in world.storeys] == [("Level 1", 0.0), ("Level 2", 3.0)]
    storey = world.storey(world.task_storey)
    assert storey is not None and storey.label == "Level 1"


def test_every_static_element_has_a_mesh_pose_bounds_and_group(world: World) -> None:
    for e in world.static:
        assert e.mesh_path is not None and e.mesh_path.is_file()
        assert e.pose == e.installed_pose and e.bounds is not None
        assert e.group.startswith(("level-1_", "level-2_"))
    groups = world.static_groups()
    assert sorted(groups) == ["level-1_furniture", "level-1_slab", "level-1_wall",
                              "level-2_furniture", "level-2_slab", "level-2_wall"]


def test_a_bare_model_reports_the_task_elements_it_cannot_place(wp: WorldProject) -> None:
    bare = build_world(Project.load(wp.directory), datetime(2022, 5, 10, 8))
    assert bare.task_elements == ()
    unplaced = bare.unplaced()
    assert len(unplaced) == len(wp.panels)
    assert all("kbp:storedIn" in o.reason for o in unplaced)


def test_the_world_is_the_same_when_built_twice(project: Project, world: World) -> None:
    again = build_world(project, parse_date(DATE))
    assert again.to_dict() == world.to_dict()


def test_an_unknown_task_is_an_error_naming_the_known_tasks(project: Project) -> None:
    with pytest.raises(WorldError) as err:
        build_world(project, parse_date(DATE), task_id="T99")
    assert "T99" in str(err.value) and "T1, T2" in str(err.value) and "project.toml" in str(err.value)


@pytest.mark.parametrize("text", ["10/05/2022", "2022-13-01", "2022-05-10T08:00+02:00"])
def test_a_date_that_is_not_local_iso_is_an_error(text: str) -> None:
    with pytest.raises(KbplannerError) as err:
        parse_date(text)
    assert "--date" in str(err.value) and "fix:" in str(err.value)


def test_another_task_can_be_simulated(project: Project, wp: WorldProject) -> None:
    """With T3 (Level-1 partitions) as the task, its wall has no storage: reported, not placed."""
    w = build_world(project, parse_date(DATE), task_id="T3")
    assert w.task_id == "T3" and w.task_elements == ()
    partition = next(g for g, info in wp.building.walls.items()
                     if not info.is_external and wp.building.storeys[info.storey][0] == "Level 1")
    assert [o.iri for o in w.unplaced()] == [wp.iri(partition)]
    # the panels are now ordinary elements of a later task: the robotized T5 starts on 05-10 00:00
    assert all(w.element(wp.iri(g)) is not None for g in wp.panels)


def test_mesh_files_of_the_import_are_used_as_they_are(world: World) -> None:
    e = world.static[0]
    assert e.mesh_path is not None and e.mesh_file is not None
    assert e.mesh_path == world.import_dir / e.mesh_file
