"""Occupancy grids (A6): every triangle within the height band blocks its cells; ROS map files round-trip."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from kbplanner.core.errors import InputFileError, KbplannerError
from kbplanner.world.occupancy import Box, OccupancyGrid, occupancy_from_meshes, storey_occupancy

BAND = (0.05, 1.5)


def box(x0: float, y0: float, x1: float, y1: float, z0: float = 0.0, z1: float = 2.7) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=(x1 - x0, y1 - y0, z1 - z0))
    mesh.apply_translation(((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2))
    return mesh


def room_with_door() -> list[trimesh.Trimesh]:
    """A 4 x 3 m room of four 0.2 m walls; the east wall has a 0.9 m door gap at y 1.0-1.9."""
    return [
        box(-0.2, -0.2, 4.2, 0.0),  # south
        box(-0.2, 3.0, 4.2, 3.2),  # north
        box(-0.2, 0.0, 0.0, 3.0),  # west
        box(4.0, 0.0, 4.2, 1.0),  # east, below the door
        box(4.0, 1.9, 4.2, 3.0),  # east, above the door
        box(-0.2, -0.2, 4.2, 3.2, z0=-0.2, z1=0.0),  # floor slab: below the band
    ]


@pytest.fixture(scope="module")
def room_grid() -> OccupancyGrid:
    return occupancy_from_meshes(room_with_door(), BAND, Box(-0.5, -0.5, 4.7, 3.5), 0.05)


def test_walls_are_occupied_and_the_door_gap_and_room_are_free(room_grid: OccupancyGrid) -> None:
    g = room_grid
    for x, y in [(2.0, -0.1), (2.0, 3.1), (-0.1, 1.5), (4.1, 0.5), (4.1, 2.5), (4.1, 0.98), (4.1, 1.92)]:
        assert g.is_occupied(x, y), (x, y)
    for x, y in [(2.0, 1.5), (0.1, 0.1), (3.9, 2.9), (4.1, 1.02), (4.1, 1.45), (4.1, 1.88), (4.5, 1.5)]:
        assert not g.is_occupied(x, y), (x, y)
    # The gap is exactly 0.9 m of free cells: grid-aligned wall faces do not grow into it.
    ix, iy = g.cell_of(4.1, 1.45)
    column = g.occupied[:, ix]
    lo = iy
    while not column[lo - 1]:
        lo -= 1
    hi = iy
    while not column[hi + 1]:
        hi += 1
    assert (hi - lo + 1) * g.resolution == pytest.approx(0.9)


def test_solid_walls_are_filled_not_only_outlined(room_grid: OccupancyGrid) -> None:
    ix0, iy = room_grid.cell_of(-0.2 + 0.01, 1.5)
    ix1, _ = room_grid.cell_of(-0.01, 1.5)
    assert room_grid.occupied[iy, ix0 : ix1 + 1].all() and ix1 - ix0 + 1 == 4  # 0.2 m = 4 cells


def test_the_floor_slab_below_the_band_is_not_an_obstacle(room_grid: OccupancyGrid) -> None:
    assert not room_grid.is_occupied(2.0, 1.5)
    assert room_grid.free_fraction > 0.5


def test_a_wall_that_only_exists_between_1_and_2_m_is_still_caught_by_the_band() -> None:
    high = box(1.0, 1.0, 3.0, 1.2, z0=1.0, z1=2.0)
    g = occupancy_from_meshes([high], BAND, Box(0.0, 0.0, 4.0, 2.0))
    assert g.is_occupied(2.0, 1.1) and g.is_occupied(1.02, 1.02) and g.is_occupied(2.98, 1.18)
    assert not g.is_occupied(2.0, 0.9) and not g.is_occupied(2.0, 1.3)
    # A single slice at mid-band (0.775 m) would have missed it entirely.
    assert high.section(plane_origin=(0, 0, 0.775), plane_normal=(0, 0, 1)) is None


def test_objects_entirely_above_or_below_the_band_are_ignored() -> None:
    g = occupancy_from_meshes([box(1, 1, 2, 2, z0=1.6, z1=2.7), box(2, 0, 3, 1, z0=-0.5, z1=0.04)],
                              BAND, Box(0, 0, 4, 3))
    assert not g.occupied.any()


def test_a_sloped_triangle_crossing_the_band_marks_only_its_in_band_part() -> None:
    # A ramp rising from z=0 at x=0 to z=3 at x=3 (a thin sheet); in band for x in [0.05, 1.5].
    ramp = trimesh.Trimesh(vertices=[[0, 0, 0], [3, 0, 3], [3, 1, 3], [0, 1, 0]],
                           faces=[[0, 1, 2], [0, 2, 3]])
    g = occupancy_from_meshes([ramp], BAND, Box(0, 0, 3, 1), 0.05)
    assert g.is_occupied(1.0, 0.5) and g.is_occupied(0.06, 0.5) and g.is_occupied(1.49, 0.5)
    assert not g.is_occupied(0.02, 0.5) and not g.is_occupied(1.6, 0.5) and not g.is_occupied(2.5, 0.5)


def test_clearance_is_the_distance_to_the_nearest_occupied_cell(room_grid: OccupancyGrid) -> None:
    assert room_grid.clearance_at(2.0, 1.5) == pytest.approx(1.5, abs=0.06)  # to the south/north walls
    assert room_grid.clearance_at(0.3, 1.5) == pytest.approx(0.3, abs=0.06)
    assert room_grid.clearance_at(2.0, -0.1) == 0.0
    assert room_grid.clearance_at(99.0, 99.0) == 0.0


def test_the_map_is_written_in_ros_map_server_format_and_reads_back(
    room_grid: OccupancyGrid, tmp_path: Path
) -> None:
    pgm, yaml = room_grid.to_pgm_yaml(tmp_path)
    raw = pgm.read_bytes()
    ny, nx = room_grid.shape
    assert raw.startswith(b"P5\n") and f"\n{nx} {ny}\n255\n".encode() in raw
    pixels = np.frombuffer(raw[-nx * ny :], dtype=np.uint8).reshape(ny, nx)
    assert set(np.unique(pixels).tolist()) == {0, 254}
    assert pixels[0, 0] == (0 if room_grid.occupied[-1, 0] else 254)  # top row = highest y
    text = yaml.read_text()
    for line in ["image: map.pgm", "resolution: 0.05", "origin: [-0.5, -0.5, 0.0]", "negate: 0",
                 "occupied_thresh: 0.65", "free_thresh: 0.196"]:
        assert line in text
    back = OccupancyGrid.read_pgm_yaml(yaml)
    assert np.array_equal(back.occupied, room_grid.occupied)
    assert back.origin == room_grid.origin and back.resolution == room_grid.resolution
    assert pgm.read_bytes() == raw and room_grid.to_pgm_yaml(tmp_path)[0].read_bytes() == raw


def test_storey_occupancy_sets_the_band_from_the_floor_and_robot_height() -> None:
    upper_floor = [box(0, 0, 3, 0.2, z0=3.0, z1=5.7), box(1, 1, 1.5, 1.5, z0=3.0, z1=3.04)]  # wall, thin mat
    g = storey_occupancy(upper_floor, floor_elevation_m=3.0, robot_height_m=1.4)
    assert g.band == pytest.approx((3.05, 4.4))
    assert g.is_occupied(1.5, 0.1) and not g.is_occupied(1.25, 1.25)
    assert g.extent.xmin == pytest.approx(-0.5) and g.extent.xmax == pytest.approx(3.5)


def test_bad_arguments_raise_errors_that_say_what_to_fix(tmp_path: Path) -> None:
    with pytest.raises(KbplannerError, match="empty height band"):
        occupancy_from_meshes([], (1.0, 1.0), Box(0, 0, 1, 1))
    with pytest.raises(KbplannerError, match="empty extent"):
        Box(0, 0, 0, 1)
    with pytest.raises(KbplannerError, match="resolution"):
        occupancy_from_meshes([], BAND, Box(0, 0, 1, 1), resolution=0.0)
    with pytest.raises(InputFileError, match="cannot read map"):
        OccupancyGrid.read_pgm_yaml(tmp_path / "missing.yaml")
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    (tmp_path / "m.pgm").write_bytes(b"P2\n2 2\n255\n0 0 0 0\n")
    with pytest.raises(InputFileError, match="P5") as err:
        OccupancyGrid.read_pgm_yaml(tmp_path / "m.yaml")
    assert "m.pgm" in str(err.value)
