"""A6, occupancy maps kept on disk: a storey's grid by a content hash of the world it was made from.

:func:`kbplanner.world.maps.storey_map` rasterises the meshes of a storey (reading every mesh file,
sectioning each at the robot's height band): about 0.15 s of CPU on the case study, in every command.
This module keeps the part made from meshes (the grid: occupied cells, origin, resolution, band, notes;
and how many meshes it holds) in a folder, so that a second command on the same project, scenario and
date (``kbplanner plan`` then ``simulate``; ``simulate`` again) reads it instead.

- Where: a folder given with :func:`kept_in` (:func:`folder_for` the project's cache entry:
  ``ENTRY/maps/``; given by ``kbplanner plan`` and ``simulate``); none given: nothing is read or
  written. Off with the project cache (``kbplanner --no-cache``, ``KBPLANNER_NO_CACHE=1``).
- Key: SHA-256 of the format, the versions of Python and the packages (``core.outputs.versions``),
  the source of the modules that make a map (:data:`_CODE`), the world (its ``repr``: every element,
  pose, box, mesh path, storey and site object), each mesh file's size and modification time, the
  storey and the map settings. Any change makes another key.
- Value: ``KEY.npz`` (no pickle): the occupied cells and the figures as JSON text; read back, the grid
  is the very grid a build gives (``tests/test_map_store.py``), so every output is byte-identical.
- A file that cannot be read is ignored and the map is made; one that cannot be written is logged, never
  an error (written atomically). The newest :data:`KEEP` files are kept.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
from pathlib import Path

import numpy as np

from kbplanner.core.kept_folder import KeptFolder, code_digest, read_arrays, write_arrays
from kbplanner.core.outputs import versions
from kbplanner.world.map_settings import MapSettings
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import StoreyInfo, World

log = logging.getLogger(__name__)

FORMAT = "1"
SUBDIR = "maps"
KEEP = 32  # maps kept per project cache entry (the newest)
_CODE = ("maps.py", "occupancy.py", "raster.py", "meshes.py", "levels.py", "map_settings.py",
         "world_types.py", "build.py", "map_store.py")

_kept = KeptFolder()
_code_memo: list[bytes] = []
counts = {"read": 0, "written": 0}


kept_in = _kept.kept_in


def folder_for(cache_entry: Path | None) -> Path | None:
    """``ENTRY/maps`` of a project cache entry; None for a project without one (``--no-cache``)."""
    return None if cache_entry is None else Path(cache_entry) / SUBDIR


def _code_digest() -> bytes:
    if not _code_memo:
        prefix = f"{FORMAT} {sorted(versions().items())!r}"
        _code_memo.append(code_digest(prefix, Path(__file__).resolve().parent, _CODE))
    return _code_memo[0]


def key(world: World, storey: StoreyInfo, settings: MapSettings) -> str:
    """The content hash a storey's map is kept under (see module docstring)."""
    h = hashlib.sha256(_code_digest())
    for part in (repr(world), repr(storey), repr(settings)):
        h.update(part.encode("utf-8"))
        h.update(b"\0")
    for path in sorted({str(e.mesh_path) for e in world.static if e.mesh_path is not None}):
        try:
            st = os.stat(path)
            h.update(f"{path} {st.st_size} {st.st_mtime_ns}\0".encode())
        except OSError:
            h.update(f"{path} missing\0".encode())
    return h.hexdigest()


def _num(v: float) -> list[object]:
    """A number and whether it is a NumPy float (its ``repr`` differs: kept as it was made)."""
    return [float(v), isinstance(v, np.floating)]


def _float(v: list[object]) -> float:
    x = float(v[0])  # type: ignore[arg-type]
    return np.float64(x) if v[1] else x


def _path(world: World, storey: StoreyInfo, settings: MapSettings) -> Path | None:
    where = _kept.current()
    return None if where is None else where / f"{key(world, storey, settings)}.npz"


def read(world: World, storey: StoreyInfo, settings: MapSettings) -> tuple[OccupancyGrid, int] | None:
    """The kept grid of this storey and the number of meshes it holds, or None."""
    path = _path(world, storey, settings)
    if path is None:
        return None
    got = read_arrays(path, {"occupied": None, "meta": None}, "map")
    if got is None:
        return None
    occupied = got[0]
    try:
        meta = json.loads(str(got[1]))
        band = meta["band"]
        grid = OccupancyGrid(occupied=occupied.astype(bool, copy=False),
                             origin=(_float(meta["origin"][0]), _float(meta["origin"][1])),
                             resolution=_float(meta["resolution"]),
                             band=None if band is None else (_float(band[0]), _float(band[1])),
                             notes=tuple(str(n) for n in meta["notes"]))
        obstacles = int(meta["obstacles"])
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        log.warning("ignoring the kept map %s: %s", path.name, exc)
        return None
    counts["read"] += 1
    return grid, obstacles


def write(world: World, storey: StoreyInfo, settings: MapSettings, grid: OccupancyGrid,
          obstacles: int) -> None:
    """Keep a storey's grid (when a folder is given)."""
    path = _path(world, storey, settings)
    if path is None:
        return
    meta = {"origin": [_num(v) for v in grid.origin], "resolution": _num(grid.resolution),
            "band": None if grid.band is None else [_num(v) for v in grid.band],
            "notes": list(grid.notes), "obstacles": obstacles}
    if write_arrays(path, "map", KEEP, occupied=np.ascontiguousarray(grid.occupied, dtype=bool),
                    meta=np.array(json.dumps(meta))):
        counts["written"] += 1
