"""Occupancy maps (A6 world at a date, input of B5 navigation): 2D grids per storey from triangle meshes.

Takes triangle meshes in the site frame (``trimesh.Trimesh``, metres), a height band ``(zmin, zmax)``
(e.g. storey elevation + 0.05 m up to the robot's height with its load) and an extent; returns an
:class:`OccupancyGrid`: a boolean array where a cell is occupied when any triangle of any mesh
overlaps it *within the band*. Triangles are clipped to the band (two Sutherland-Hodgman planes) and
their xy projections are rasterised conservatively (separating axis test per cell), so a wall that
only exists between z = 1.0 and 2.0 m, a table top or a beam inside the band is caught, not only
what a single horizontal slice cuts. A vertical face lying exactly on a cell boundary is given to
the cell on its solid side (opposite its normal), so grid-aligned walls do not grow by a cell.

Doors are open: the caller passes only the meshes that should block (no door panels).

The grid writes the ROS map_server format (``map.pgm`` P5 + ``map.yaml``) and offers a Euclidean
distance transform for clearance look-ups.

Example:
    >>> import trimesh
    >>> wall = trimesh.creation.box(extents=(4.0, 0.2, 2.5))
    >>> _ = wall.apply_translation((2.0, 1.0, 1.25))
    >>> grid = occupancy_from_meshes([wall], band=(0.05, 1.5), extent=Box(0.0, 0.0, 4.0, 2.0))
    >>> grid.is_occupied(2.0, 1.0), grid.is_occupied(2.0, 0.5)
    (True, False)
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from kbplanner.core.errors import InputFileError, KbplannerError
from kbplanner.core.outputs import atomic_write_bytes, atomic_write_text
from kbplanner.world.raster import clip, fill_section, rasterise

log = logging.getLogger(__name__)

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]

# ROS map_server conventions (negate 0): a pixel value v means occupancy (255 - v) / 255.
PGM_OCCUPIED = 0
PGM_FREE = 254
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196

_FACE_SHIFT_M = 1e-6  # moves each face into its solid before rasterising (see module docstring)


@dataclass(frozen=True)
class Box:
    """An axis-aligned 2D extent in the site frame, metres."""

    xmin: float
    ymin: float
    xmax: float
    ymax: float

    def __post_init__(self) -> None:
        if not (self.xmax > self.xmin and self.ymax > self.ymin):
            raise KbplannerError(
                f"empty extent {self}", element="Box", fix="give xmin < xmax and ymin < ymax in metres"
            )

    @classmethod
    def around(cls, meshes: Sequence[Any], margin_m: float = 0.5) -> Box:
        """The xy bounding box of some meshes, grown by ``margin_m`` on every side."""
        if not meshes:
            raise KbplannerError("no meshes to take an extent from", element="Box.around",
                                 fix="pass at least one mesh or give the extent explicitly")
        lo = np.min([np.asarray(m.bounds)[0] for m in meshes], axis=0)
        hi = np.max([np.asarray(m.bounds)[1] for m in meshes], axis=0)
        return cls(float(lo[0] - margin_m), float(lo[1] - margin_m),
                   float(hi[0] + margin_m), float(hi[1] + margin_m))


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """A 2D occupancy grid: ``occupied[iy, ix]``, cell (0, 0) has its lower-left corner at ``origin``.

    Row ``iy`` covers y in ``[origin_y + iy * resolution, origin_y + (iy + 1) * resolution)``; the
    array is stored bottom row first (the PGM file is written top row first, as ROS expects).
    """

    occupied: BoolArray
    origin: tuple[float, float]
    resolution: float
    band: tuple[float, float] | None = None
    notes: tuple[str, ...] = ()  # meshes whose section or triangles could not be used, and how
    _cache: dict[str, FloatArray] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.occupied.ndim != 2 or self.occupied.dtype != np.bool_:
            raise KbplannerError("occupied must be a 2D bool array", element="OccupancyGrid",
                                 fix="pass np.asarray(..., dtype=bool) of shape (ny, nx)")
        if not self.resolution > 0:
            raise KbplannerError(f"resolution must be positive, got {self.resolution}",
                                 element="OccupancyGrid", fix="give the cell size in metres, e.g. 0.05")

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx)."""
        ny, nx = self.occupied.shape
        return (int(ny), int(nx))

    @property
    def extent(self) -> Box:
        """The area covered by the grid."""
        ny, nx = self.shape
        ox, oy = self.origin
        return Box(ox, oy, ox + nx * self.resolution, oy + ny * self.resolution)

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(ix, iy) of the cell containing a point (may lie outside the grid)."""
        return (math.floor((x - self.origin[0]) / self.resolution),
                math.floor((y - self.origin[1]) / self.resolution))

    def center_of(self, ix: int, iy: int) -> tuple[float, float]:
        """Site coordinates of a cell centre."""
        return (self.origin[0] + (ix + 0.5) * self.resolution, self.origin[1] + (iy + 0.5) * self.resolution)

    def contains(self, x: float, y: float) -> bool:
        """Whether a point lies on the grid."""
        ix, iy = self.cell_of(x, y)
        ny, nx = self.shape
        return 0 <= ix < nx and 0 <= iy < ny

    def is_occupied(self, x: float, y: float) -> bool:
        """Whether the cell at a point is occupied; points off the grid count as occupied."""
        if not self.contains(x, y):
            return True
        ix, iy = self.cell_of(x, y)
        return bool(self.occupied[iy, ix])

    @property
    def free_fraction(self) -> float:
        """Share of free cells."""
        return float(1.0 - self.occupied.mean())

    def clearance_m(self) -> FloatArray:
        """Distance (m) from each cell centre to the nearest occupied cell centre (0 on obstacles)."""
        if "edt" not in self._cache:
            if not self.occupied.any():
                self._cache["edt"] = np.full(self.shape, np.inf)
            else:
                self._cache["edt"] = np.asarray(
                    ndimage.distance_transform_edt(~self.occupied), dtype=np.float64) * self.resolution
        return self._cache["edt"]

    def clearance_at(self, x: float, y: float) -> float:
        """Clearance (m) at a point: distance to the nearest occupied cell; 0 off the grid."""
        if not self.contains(x, y):
            return 0.0
        ix, iy = self.cell_of(x, y)
        return float(self.clearance_m()[iy, ix])

    def to_pgm_yaml(self, directory: Path, name: str = "map") -> tuple[Path, Path]:
        """Write ``{name}.pgm`` (binary P5) and ``{name}.yaml`` in ROS map_server format; returns both paths.

        Occupied cells are 0 (black), free cells 254; the image's top row is the grid's highest y.
        """
        directory = Path(directory)
        ny, nx = self.shape
        pixels = np.where(self.occupied[::-1, :], PGM_OCCUPIED, PGM_FREE).astype(np.uint8)
        header = f"P5\n# kbplanner occupancy grid, resolution {self.resolution} m\n{nx} {ny}\n255\n"
        pgm = directory / f"{name}.pgm"
        yaml = directory / f"{name}.yaml"
        atomic_write_bytes(pgm, header.encode("ascii") + pixels.tobytes())
        text = (
            f"image: {name}.pgm\n"
            f"resolution: {_fmt(self.resolution)}\n"
            f"origin: [{_fmt(self.origin[0])}, {_fmt(self.origin[1])}, 0.0]\n"
            "negate: 0\n"
            f"occupied_thresh: {OCCUPIED_THRESH}\n"
            f"free_thresh: {FREE_THRESH}\n"
            "mode: trinary\n"
        )
        atomic_write_text(yaml, text)
        return pgm, yaml

    @classmethod
    def read_pgm_yaml(cls, yaml_path: Path) -> OccupancyGrid:
        """Read a map written by :meth:`to_pgm_yaml` (or any trinary ROS map with P5 image, negate 0).

        Raises:
            InputFileError: a file is missing or not in the expected format.
        """
        yaml_path = Path(yaml_path)
        try:
            meta = _parse_map_yaml(yaml_path.read_text(encoding="utf-8"))
        except OSError as exc:
            raise InputFileError(f"cannot read map: {exc.strerror}", file=yaml_path,
                                 fix="pass the map.yaml written next to map.pgm") from exc
        for key in ("image", "resolution", "origin"):
            if key not in meta:
                raise InputFileError(f"map yaml has no '{key}'", file=yaml_path, element=key,
                                     fix="write the map with OccupancyGrid.to_pgm_yaml")
        if meta.get("negate", "0") not in ("0", "false", "False"):
            raise InputFileError("negate maps are not supported", file=yaml_path, element="negate",
                                 fix="write the map with negate: 0")
        pgm_path = yaml_path.parent / meta["image"]
        try:
            raw = pgm_path.read_bytes()
        except OSError as exc:
            raise InputFileError(f"cannot read map image: {exc.strerror}", file=pgm_path,
                                 fix="keep the .pgm next to its .yaml") from exc
        pixels = _parse_pgm(raw, pgm_path)
        occ_prob = (255.0 - pixels.astype(np.float64)) / 255.0
        origin_vals = [float(v) for v in meta["origin"].strip("[] ").split(",")]
        return cls(
            occupied=(occ_prob > float(meta.get("occupied_thresh", OCCUPIED_THRESH)))[::-1, :].copy(),
            origin=(origin_vals[0], origin_vals[1]),
            resolution=float(meta["resolution"]),
        )


def _fmt(v: float) -> str:
    return repr(round(float(v), 9))


def _parse_map_yaml(text: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if ":" in line:
            key, value = line.split(":", 1)
            out[key.strip()] = value.strip()
    return out


def _parse_pgm(raw: bytes, path: Path) -> npt.NDArray[np.uint8]:
    tokens: list[bytes] = []
    pos = 0
    while len(tokens) < 4:
        while pos < len(raw) and raw[pos : pos + 1].isspace():
            pos += 1
        if raw[pos : pos + 1] == b"#":
            pos = raw.index(b"\n", pos) + 1
            continue
        start = pos
        while pos < len(raw) and not raw[pos : pos + 1].isspace():
            pos += 1
        tokens.append(raw[start:pos])
    if tokens[0] != b"P5" or int(tokens[3]) != 255:
        raise InputFileError("not an 8-bit binary PGM (P5, maxval 255)", file=path,
                             fix="write the map with OccupancyGrid.to_pgm_yaml")
    nx, ny = int(tokens[1]), int(tokens[2])
    data = np.frombuffer(raw[pos + 1 : pos + 1 + nx * ny], dtype=np.uint8)
    if data.size != nx * ny:
        raise InputFileError(f"PGM image truncated: expected {nx * ny} pixels, got {data.size}", file=path,
                             fix="rewrite the map")
    return data.reshape(ny, nx)


def occupancy_from_meshes(
    meshes: Sequence[Any],
    band: tuple[float, float],
    extent: Box,
    resolution: float = 0.05,
    names: Sequence[str] | None = None,
) -> OccupancyGrid:
    """Rasterise every triangle of ``meshes`` that lies (partly) within ``band`` onto a grid over ``extent``.

    Args:
        meshes: ``trimesh.Trimesh`` objects in the site frame (metres): the obstacles only.
        band: (zmin, zmax) in metres, e.g. (floor + 0.05, floor + robot height with its load).
        extent: the area to cover; cells number ceil(width / resolution) by ceil(depth / resolution).
        resolution: cell size in metres.
        names: what each mesh is (for the grid's ``notes``); default "mesh <index>".

    A mesh whose geometry cannot be used (non-finite coordinates, a section that cannot be made
    into polygons) never stops the map: it is named in the grid's ``notes`` with what was done.

    Raises:
        KbplannerError: an empty band or a non-positive resolution.
    """
    zmin, zmax = float(band[0]), float(band[1])
    if not zmax > zmin:
        raise KbplannerError(f"empty height band {band}", element="band",
                             fix="give (zmin, zmax) with zmin < zmax in metres")
    if not resolution > 0:
        raise KbplannerError(f"resolution must be positive, got {resolution}", element="resolution",
                             fix="give the cell size in metres, e.g. 0.05")
    nx = max(1, math.ceil((extent.xmax - extent.xmin) / resolution - 1e-9))
    ny = max(1, math.ceil((extent.ymax - extent.ymin) / resolution - 1e-9))
    grid = np.zeros((ny, nx), dtype=bool)
    origin = (extent.xmin, extent.ymin)
    n_tri = 0
    notes: list[str] = []
    for index, mesh in enumerate(meshes):
        name = names[index] if names is not None and index < len(names) else f"mesh {index}"
        tris = np.asarray(mesh.triangles, dtype=np.float64)
        if len(tris) == 0:
            continue
        finite = np.isfinite(tris).all(axis=(1, 2))
        if not finite.all():
            notes.append(f"{name}: {int((~finite).sum())} triangles with non-finite coordinates left out")
            tris = tris[finite]
        z = tris[:, :, 2]
        near = (z.max(axis=1) >= zmin) & (z.min(axis=1) <= zmax)
        near &= (tris[:, :, 0].max(axis=1) >= extent.xmin) & (tris[:, :, 0].min(axis=1) <= extent.xmax)
        near &= (tris[:, :, 1].max(axis=1) >= extent.ymin) & (tris[:, :, 1].min(axis=1) <= extent.ymax)
        if not near.any():
            continue
        tris = tris[near]
        normals = np.nan_to_num(np.asarray(mesh.face_normals, dtype=np.float64)[finite][near])
        n_tri += len(tris)
        # Into the solid by a micrometre, so a face on a cell border marks the solid side only.
        tris = tris - _FACE_SHIFT_M * np.concatenate(
            [normals[:, None, :2], np.zeros((len(tris), 1, 1))], axis=2)
        counts = np.full(len(tris), 3, dtype=np.int64)
        polys, counts = clip(tris, counts, zmin, keep_above=True)
        polys, counts = clip(polys, counts, zmax, keep_above=False)
        rasterise(polys[:, :, :2], grid, origin, resolution)
        if finite.all():
            problem = fill_section(mesh, 0.5 * (zmin + zmax), grid, origin, resolution)
            if problem is not None:
                notes.append(f"{name}: {problem}")
    for note in notes:
        log.warning("occupancy: %s", note)
    log.info("occupancy: %d triangles in band %.2f-%.2f m, %d x %d cells, %.1f %% occupied",
             n_tri, zmin, zmax, nx, ny, 100.0 * grid.mean())
    return OccupancyGrid(occupied=grid, origin=origin, resolution=float(resolution), band=(zmin, zmax),
                         notes=tuple(notes))


def storey_occupancy(
    meshes: Sequence[Any],
    floor_elevation_m: float,
    robot_height_m: float,
    extent: Box | None = None,
    resolution: float = 0.05,
    floor_clearance_m: float = 0.05,
) -> OccupancyGrid:
    """The occupancy grid of one storey for a robot (with its load) ``robot_height_m`` tall.

    The band runs from ``floor_elevation_m + floor_clearance_m`` (so the floor slab itself is not an
    obstacle) to ``floor_elevation_m + robot_height_m``; ``extent`` defaults to the meshes' box + 0.5 m.
    """
    if extent is None:
        extent = Box.around(meshes)
    band = (floor_elevation_m + floor_clearance_m, floor_elevation_m + robot_height_m)
    return occupancy_from_meshes(meshes, band, extent, resolution)
