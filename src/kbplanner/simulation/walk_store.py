"""B5 reactive workers, walking routes kept on disk: the router's paths by a content hash of the walking map.

The reactive workers' router (:class:`kbplanner.simulation.workers._Router`) finds each route leg on the
walking map with a Dijkstra search over every free cell (the case study's 520 x 420 cells: the graph
built once, about 70 ms, then some 45 ms per start cell, four starts in a run: a quarter of a second of
the simulation step's CPU). The legs depend on the map and the two cells only, so a run keeps them in a
folder and the next run on the same map (``kbplanner simulate`` again, another scenario or seed) reads
them instead; a leg not kept (a new start or goal cell) is searched as before and kept at the end.

- Where: ``walks/`` beside the configuration spaces' folder (:func:`kbplanner.world.cspace_store.folder`,
  given by the executor around the run), so on, off and placed as those are (``kbplanner --no-cache``,
  ``KBPLANNER_NO_CACHE=1``: neither read nor written).
- Key: SHA-256 of the format, the versions of NumPy and SciPy (the search), the source of the router and
  this module (:data:`_CODE`), the walking map's shape, origin and resolution and its free cells.
- Value: ``KEY.npz`` (no pickle): per leg the start and goal cells and the simplified polyline; read back
  the polylines are the very arrays a search gives (``tests/test_walk_store.py``), so every output of a
  run is byte-identical with or without them.
- And the walking map itself (:func:`walk_cells_kept`: the cells a person walks on, from a distance
  transform of the storey's map, some 0.07 s of every run's step on the case study): ``maps/KEY.npz`` by a
  hash of the format, the code, the map's shape, origin, resolution and cells and the clearance; read back
  the very cells :func:`kbplanner.simulation.workers.walk_cells` gives.
- A file that cannot be read is ignored (the legs searched again); one that cannot be written is logged,
  never an error (written atomically). The newest :data:`KEEP` files are kept.
"""

from __future__ import annotations

import hashlib
import logging
from pathlib import Path

import numpy as np

from kbplanner.core.kept_folder import code_digest, read_arrays, write_arrays
from kbplanner.simulation.workers import _Router, walk_cells
from kbplanner.world import cspace_store
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

FORMAT = "2"
SUBDIR = "walks"
KEEP = 32  # walking maps kept (the newest), their legs and (in MAPS) their walkable cells
MAPS = "maps"
_CODE = ("workers.py", "walk_store.py")

_code_memo: list[bytes] = []
counts = {"read": 0, "written": 0}


def _code_digest() -> bytes:
    if not _code_memo:
        import scipy

        prefix = f"{FORMAT} numpy {np.__version__} scipy {scipy.__version__}"
        _code_memo.append(code_digest(prefix, Path(__file__).resolve().parent, _CODE))
    return _code_memo[0]


def key(router: _Router) -> str | None:
    """The content hash a router's legs are kept under (None: a router without a map)."""
    grid, free = router.grid, router.free
    if grid is None or free is None:
        return None
    h = hashlib.sha256(_code_digest())
    h.update(repr((tuple(free.shape), tuple(float(v) for v in grid.origin), float(grid.resolution))).encode())
    h.update(np.ascontiguousarray(free, dtype=bool).tobytes())
    return h.hexdigest()


def _path(router: _Router) -> Path | None:
    where = cspace_store.folder()
    k = key(router) if where is not None else None
    return None if where is None or k is None else where.parent / SUBDIR / f"{k}.npz"


def read_into(router: _Router) -> int:
    """Put the kept legs of this router's map into its memo (those it has not got); how many were read."""
    path = _path(router)
    if path is None:
        return 0
    got = read_arrays(path, {"cells": np.int64, "starts": np.int64, "points": np.float64}, "walking routes")
    if got is None:
        return 0
    cells, starts, points = got
    if cells.ndim != 2 or cells.shape[1] != 4 or starts.shape != (len(cells) + 1,) or points.ndim != 2 \
            or points.shape[1] != 2 or (len(cells) and int(starts[-1]) != len(points)):
        log.warning("ignoring the kept walking routes %s: not a set of legs", path.name)
        return 0
    memo = router._memo
    for n, (sx, sy, tx, ty) in enumerate(cells.tolist()):
        memo.setdefault(((sx, sy), (tx, ty)), points[int(starts[n]):int(starts[n + 1])].copy())
    counts["read"] += 1
    router.kept_legs = frozenset(memo)
    return len(cells)


def write_from(router: _Router) -> None:
    """Keep the router's legs when it searched a leg not read from the folder (when a folder is given)."""
    memo = router._memo
    if not memo or set(memo) <= router.kept_legs:
        return
    path = _path(router)
    if path is None:
        return
    legs = sorted(memo)
    cells = np.array([[s[0], s[1], t[0], t[1]] for s, t in legs], dtype=np.int64).reshape(-1, 4)
    sizes = [len(memo[k]) for k in legs]
    starts = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    points = np.concatenate([np.asarray(memo[k], dtype=np.float64).reshape(-1, 2) for k in legs])
    if write_arrays(path, "walking routes", KEEP, cells=cells, starts=starts, points=points):
        counts["written"] += 1
        router.kept_legs = frozenset(memo)


def walk_cells_kept(grid: OccupancyGrid, clearance_m: float) -> tuple[np.ndarray, int]:
    """:func:`kbplanner.simulation.workers.walk_cells` of the map, read from the folder given now when an
    earlier run (or the early builds' process) kept it, else made and kept there."""
    where = cspace_store.folder()
    if where is None:
        return walk_cells(grid, clearance_m)
    h = hashlib.sha256(_code_digest())
    occupied = np.ascontiguousarray(grid.occupied, dtype=bool)
    h.update(b"walking map " + repr((tuple(occupied.shape), tuple(float(v) for v in grid.origin),
                                     float(grid.resolution), float(clearance_m))).encode())
    h.update(np.packbits(occupied).tobytes())
    path = where.parent / SUBDIR / MAPS / f"{h.hexdigest()}.npz"
    got = read_arrays(path, {"cells": np.uint8, "shape": np.int64, "k": np.int64}, "walking map")
    if got is not None:
        packed, shape, coarser = got
        n = int(np.prod(shape)) if shape.shape == (2,) else -1
        if n >= 0 and coarser.shape == () and int(coarser) >= 1 and packed.ndim == 1 \
                and packed.size == (n + 7) // 8:
            counts["read"] += 1
            kept = np.unpackbits(packed, count=n).astype(bool).reshape(int(shape[0]), int(shape[1]))
            return kept, int(coarser)
        log.warning("ignoring the kept walking map %s: not a walking map", path.name)
    free, k = walk_cells(grid, clearance_m)
    if write_arrays(path, "walking map", KEEP, cells=np.packbits(free),
                    shape=np.array(free.shape, dtype=np.int64), k=np.array(k)):
        counts["written"] += 1
    return free, k
