"""A6 exports: occupancy maps (ROS map_server), SDF, glTF, world.json and the ``world`` command."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh

from kbplanner.cli import main
from kbplanner.model.dates import parse_date
from kbplanner.project import Project
from kbplanner.world.build import build_world
from kbplanner.world.exports import export_world, write_element_sdf, write_world_existing_sdf
from kbplanner.world.maps import MapSettings, StoreyMap, storey_map
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import World
from world_project_factory import DATE, EXTENT, NO_GO, WORKSPACE, WorldProject, make_world_project


@pytest.fixture(scope="module")
def wp(tmp_path_factory: pytest.TempPathFactory) -> WorldProject:
    return make_world_project(tmp_path_factory.mktemp("worldproj"))


@pytest.fixture(scope="module")
def world(wp: WorldProject) -> World:
    return build_world(Project.load(wp.directory, scenario="stored"), parse_date(DATE))


@pytest.fixture(scope="module")
def level1(world: World) -> StoreyMap:
    return storey_map(world)


@pytest.fixture(scope="module")
def exported(world: World, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("exports")
    export_world(world, out)
    return out


def _door(world: World, label: str) -> tuple[float, float]:
    door = next(d for d in world.open_doors if d.label == label)
    assert door.bounds is not None
    return door.bounds.center[0], door.bounds.center[1]


def test_the_map_is_of_the_task_storey_over_a_height_band(level1: StoreyMap) -> None:
    assert level1.storey.label == "Level 1" and level1.ground_level
    assert level1.band == pytest.approx((0.05, 1.8))
    x0, y0, x1, y1 = EXTENT
    ext = level1.grid.extent
    assert (ext.xmin, ext.ymin) == (x0, y0) and ext.xmax >= x1 and ext.ymax >= y1


def test_a_wall_is_occupied_and_an_open_doors_opening_is_free(world: World, level1: StoreyMap) -> None:
    grid = level1.grid
    assert grid.is_occupied(1.0, 0.15)  # exterior south wall, 0.3 m thick
    assert grid.is_occupied(5.0, 4.0)  # Level-1 partition at x = 5
    assert not grid.is_occupied(*_door(world, "Door front L1"))
    assert not grid.is_occupied(*_door(world, "Door p1 L1"))
    # the whole doorway is passable: a line through the partition door is free from room to room
    y = _door(world, "Door p1 L1")[1]
    assert not any(grid.is_occupied(x, y) for x in np.arange(4.5, 5.5, 0.02))


def test_outside_the_building_at_ground_level_is_free_ground(level1: StoreyMap) -> None:
    grid = level1.grid
    assert not grid.is_occupied(-2.0, -2.0)
    assert not grid.is_occupied(13.0, 0.0)


def test_site_objects_and_no_go_zones_are_occupied_workspaces_free(world: World, level1: StoreyMap) -> None:
    grid = level1.grid
    assert grid.is_occupied(-6.0, 3.0)  # office
    assert grid.is_occupied(11.0, 3.0)  # material storage
    assert grid.is_occupied(NO_GO[0], NO_GO[1])
    assert not grid.is_occupied(WORKSPACE[0], WORKSPACE[1])
    without = storey_map(world, settings=MapSettings(no_go_occupied=False)).grid
    assert not without.is_occupied(NO_GO[0], NO_GO[1])


def test_an_in_progress_table_is_an_obstacle_and_a_task_panel_position_is_free(
    world: World, level1: StoreyMap
) -> None:
    table = next(e for e in world.static if e.label == "Table 1.1.1")
    assert table.bounds is not None
    cx, cy, _ = table.bounds.center
    assert level1.grid.is_occupied(cx, cy)
    panel = world.task_elements[0]
    assert panel.installed_pose is not None
    # panels are at their storage, so where they will be installed is still free
    assert not level1.grid.is_occupied(panel.installed_pose.x + 0.3, panel.installed_pose.y)


def test_an_upper_storey_map_blocks_where_there_is_no_floor(world: World) -> None:
    m = storey_map(world, "Level 2")
    assert not m.ground_level and m.band == pytest.approx((3.05, 4.8))
    assert m.grid.is_occupied(-2.0, -2.0)  # outside the building: no floor up here
    assert not m.grid.is_occupied(2.5, 3.0)  # inside, on the Level-2 slab
    assert m.grid.is_occupied(1.0, 0.15)  # exterior wall


def test_an_unknown_storey_is_an_error(world: World) -> None:
    with pytest.raises(Exception, match="unknown storey") as err:
        storey_map(world, "Level 9")
    assert "Level 1, Level 2" in str(err.value)


def test_map_yaml_and_pgm_are_valid_ros_map_server_files(exported: Path, level1: StoreyMap) -> None:
    yaml = dict(line.split(": ", 1) for line in (exported / "map.yaml").read_text().splitlines())
    assert yaml["image"] == "map.pgm" and yaml["negate"] == "0" and yaml["mode"] == "trinary"
    assert float(yaml["resolution"]) == 0.05
    origin = [float(v) for v in yaml["origin"].strip("[]").split(",")]
    assert origin == [EXTENT[0], EXTENT[1], 0.0]
    raw = (exported / "map.pgm").read_bytes()
    lines = raw.split(b"\n", 4)
    assert lines[0] == b"P5" and lines[1].startswith(b"#")
    nx, ny = (int(v) for v in lines[2].split())
    assert lines[3] == b"255" and len(lines[4]) == nx * ny
    assert set(np.frombuffer(lines[4], dtype=np.uint8).tolist()) <= {0, 254}
    back = OccupancyGrid.read_pgm_yaml(exported / "map.yaml")
    assert np.array_equal(back.occupied, level1.grid.occupied)


def test_world_existing_sdf_has_ground_static_groups_and_solid_site_objects(
    world: World, exported: Path
) -> None:
    root = ET.parse(exported / "world_existing.sdf").getroot()
    assert root.tag == "sdf" and root.get("version") == "1.6"
    models = root.findall("./world/model")
    names = [m.get("name") for m in models]
    expected = 1 + len(world.static_groups()) + len(world.solid_site_objects)
    assert len(models) == expected == 1 + 6 + 2
    assert "ground_plane" in names and "static_level-1_wall" in names
    assert not any("no-go" in str(n) or "work" in str(n) for n in names)  # areas are no bodies
    for model in models:
        assert model.findtext("static") == "true"
        for uri in model.iter("uri"):
            assert uri.text is not None and not uri.text.startswith("/")
            mesh = trimesh.load(exported / uri.text, force="mesh")
            assert len(mesh.faces) > 0


def test_one_sdf_model_per_element_to_install_at_its_storage(world: World, exported: Path) -> None:
    files = sorted(exported.glob("element_*.sdf"))
    assert [f.name for f in files] == sorted(f"element_{e.global_id}.sdf" for e in world.task_elements)
    for e in world.task_elements:
        model = ET.parse(exported / f"element_{e.global_id}.sdf").getroot().find("model")
        assert model is not None and model.findtext("static") == "false"
        assert e.pose is not None
        pose = [float(v) for v in (model.findtext("pose") or "").split()]
        assert pose == pytest.approx([e.pose.x, e.pose.y, e.pose.z, e.pose.roll, e.pose.pitch, e.pose.yaw],
                                     abs=1e-6)
        assert float(model.findtext("link/inertial/mass") or 0) == pytest.approx(e.body_mass_kg)
        size = [float(v) for v in (model.findtext("link/collision/geometry/box/size") or "").split()]
        assert e.local_bounds is not None and size == pytest.approx(list(e.local_bounds.size), abs=1e-6)


def test_world_glb_holds_every_body(world: World, exported: Path) -> None:
    scene = trimesh.load(exported / "world.glb", force="scene")
    assert len(scene.geometry) == len(world.static_groups()) + len(world.task_elements) + len(
        world.solid_site_objects)
    # glTF is y-up: the site's height (z) is the scene's y: from the ground slab's underside
    # (-0.2 m) to the top of the Level-2 walls (6.0 m)
    lo, hi = scene.bounds
    assert (lo[1], hi[1]) == pytest.approx((-0.2, 6.0), abs=1e-5)


def test_world_json_lists_counts_and_element_states(world: World, exported: Path) -> None:
    data = json.loads((exported / "world.json").read_text())
    assert data["counts"]["task_elements_at_storage"] == 3
    assert data["counts"]["static_elements"] == len(data["static_elements"]) == len(world.static)
    assert {e["state"] for e in data["static_elements"]} == {"built", "in progress"}
    assert data["map"]["storey_label"] == "Level 1"
    assert data["task"]["id"] == "T5"


def test_exports_are_byte_identical_when_written_twice(world: World, exported: Path, tmp_path: Path) -> None:
    export_world(world, tmp_path)
    first = sorted(p.relative_to(exported) for p in exported.rglob("*") if p.is_file())
    second = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    assert first == second
    for rel in first:
        assert (exported / rel).read_bytes() == (tmp_path / rel).read_bytes(), rel


def test_sdf_writers_return_what_they_wrote(world: World, tmp_path: Path) -> None:
    files = write_world_existing_sdf(world, tmp_path)
    files += write_element_sdf(world.task_elements[0], tmp_path)
    assert all(f.is_file() for f in files)
    assert sorted(files) == sorted(p for p in tmp_path.rglob("*") if p.is_file())


def test_the_world_command_writes_the_exports(wp: WorldProject, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "w"
    code = main(["world", str(wp.directory), "--scenario", "stored", "--date", DATE, "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 0
    assert "task elements at storage: 3" in text and "map: Level 1" in text
    for name in ("world_existing.sdf", "world.glb", "map.pgm", "map.yaml", "world.json"):
        assert (out / name).is_file()
    assert not out.with_name("w.partial").exists()


@pytest.mark.parametrize(("args", "message"), [
    (["--date", "10.05.2022"], "not an ISO date"),
    (["--task", "T99"], "unknown task"),
    (["--storey", "Level 9"], "unknown storey"),
])
def test_the_world_command_exits_2_on_bad_input(wp: WorldProject, tmp_path: Path, args: list[str],
                                                message: str, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "w"
    code = main(["world", str(wp.directory), "--scenario", "stored", "--out", str(out), *args])
    err = capsys.readouterr().err
    assert code == 2 and message in err and "fix:" in err and "Traceback" not in err
    assert not out.exists()


def test_the_world_command_runs_as_a_console_script(wp: WorldProject, tmp_path: Path) -> None:
    kbplanner = Path(sys.executable).with_name("kbplanner")
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    run = subprocess.run([str(kbplanner), "world", str(wp.directory), "--out", str(tmp_path / "w")],
                         capture_output=True, text=True, env=env, timeout=120, check=False)
    assert run.returncode == 0, run.stderr
    assert "not placed: 3" in run.stdout  # the bare model has no storage
    assert (tmp_path / "w" / "map.yaml").is_file()
