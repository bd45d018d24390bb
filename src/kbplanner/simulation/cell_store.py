"""Navigation (B5), the grid shortest cell paths kept on disk: by a content hash of the map searched.

:func:`kbplanner.simulation.grid_yardstick.shortest_cells` (the carry legs' cell route,
:mod:`~kbplanner.simulation.corridor_cells`) and the path-quality yardstick search the cells where the
footprint fits at some yaw with scipy's Dijkstra, each configuration space's graph built first: on the
case study some fifty searches over thirty maps, about 0.45 s of the simulation step's CPU, in every
run. A path depends on the map (its free cells) and the two end cells only, so a run keeps the paths it
searched, per map, and the next run that meets the same map (``kbplanner simulate`` again, another seed
or scenario) reads them instead of building the graph and searching.

- Where: ``cells/`` beside the configuration spaces' folder (:func:`kbplanner.world.cspace_store.folder`,
  given by the executor around the run), so on, off and placed as those are (``kbplanner --no-cache``,
  ``KBPLANNER_NO_CACHE=1``: neither read nor written).
- Key: SHA-256 of the format, the versions of NumPy and SciPy (the search), the source of the search and
  this module (:data:`_CODE`), the map's shape and its free cells.
- And the carry legs' corridor routes (:func:`kbplanner.simulation.corridor_cells.corridor_cells`: a
  breadth-first search over the free (bin, y, x) cells near the grid shortest path; some 0.35 s of the
  case study's step): ``corridor-KEY.npz`` per configuration space, by a hash of its free cells and cell
  size, per start and goal cell and corridor radius the route's cells.
- Value: ``KEY.npz`` (no pickle): per search its end cells and the path's cells (none: no path), and the
  yardstick's lengths (:func:`~kbplanner.simulation.grid_yardstick.grid_shortest_path_length`: the path
  shortened by line of sight) per start, goal and the grid's origin and resolution; read back the paths
  are the very cells a search gives and the lengths the very numbers (``tests/test_cell_store.py``), so
  every output of a run is byte-identical with or without them.
- A file that cannot be read is ignored (searched again); one that cannot be written is logged, never an
  error (written atomically). The newest :data:`KEEP` files are kept.
"""

from __future__ import annotations

import hashlib
import logging
from pathlib import Path

import numpy as np
import numpy.typing as npt

from kbplanner.core.kept_folder import code_digest, keep_newest, read_arrays, write_arrays
from kbplanner.world import cspace_store

log = logging.getLogger(__name__)

FORMAT = "1"
SUBDIR = "cells"
KEEP = 512  # maps kept (the newest)
_CODE = ("grid_yardstick.py", "cell_store.py", "corridor_cells.py", "cell_path.py")

Ends = tuple[tuple[int, int], tuple[int, int]]
Cells = tuple[tuple[int, int], ...] | None

_code_memo: list[bytes] = []
counts = {"read": 0, "written": 0}
LengthKey = tuple[float, float, float, float, float, float, float]  # start, goal, origin x y, resolution
# per folder and map key: the paths read or searched, whether some were searched (to be written), the
# yardstick's lengths (per start, goal and the grid's origin and resolution)
_known: dict[tuple[Path, str], tuple[dict[Ends, Cells], list[bool], dict[LengthKey, float]]] = {}


def _code_digest() -> bytes:
    if not _code_memo:
        import scipy

        prefix = f"{FORMAT} numpy {np.__version__} scipy {scipy.__version__}"
        _code_memo.append(code_digest(prefix, Path(__file__).resolve().parent, _CODE))
    return _code_memo[0]


def key(free: npt.NDArray[np.bool_]) -> str:
    """The content hash the paths over ``free`` are kept under (see module docstring)."""
    h = hashlib.sha256(_code_digest())
    h.update(repr(tuple(free.shape)).encode())
    h.update(np.ascontiguousarray(free, dtype=bool).tobytes())
    return h.hexdigest()


def _paths(free: npt.NDArray[np.bool_], map_key: str | None
           ) -> tuple[dict[Ends, Cells], list[bool], dict[LengthKey, float]] | None:
    """The kept paths of this map (read from the folder the first time), or None without a folder."""
    where = cspace_store.folder()
    if where is None:
        return None
    folder = where.parent / SUBDIR
    k = (folder, map_key if map_key is not None else key(free))
    got = _known.get(k)
    if got is None:
        if len(_known) >= 1024:  # (a long process: those written forgotten)
            for old in [o for o, (_, new, _) in _known.items() if not new[0]]:
                del _known[old]
        paths, lengths = _read(folder / f"{k[1]}.npz")
        got = (paths, [False], lengths)
        _known[k] = got
    return got


def _read(path: Path) -> tuple[dict[Ends, Cells], dict[LengthKey, float]]:
    got = read_arrays(path, {"ends": np.int64, "starts": np.int64, "cells": np.int64,
                         "length_keys": np.float64, "lengths": np.float64}, "cell paths")
    if got is None:
        return {}, {}
    ends, starts, cells, length_keys, lengths = got
    if ends.ndim != 2 or ends.shape[1] != 4 or starts.shape != (len(ends) + 1,) or cells.ndim != 2 \
            or cells.shape[1] != 2 or int(starts[-1]) != len(cells) or int(starts[0]) != 0 \
            or length_keys.ndim != 2 or length_keys.shape[1] != 7 or lengths.shape != (len(length_keys),):
        log.warning("ignoring the kept cell paths %s: not a set of paths", path.name)
        return {}, {}
    out: dict[Ends, Cells] = {}
    flat = cells.tolist()
    bounds = starts.tolist()
    for n, (sy, sx, ty, tx) in enumerate(ends.tolist()):
        a, b = bounds[n], bounds[n + 1]
        out[((sy, sx), (ty, tx))] = tuple((y, x) for y, x in flat[a:b]) if b > a else None
    counts["read"] += 1
    return out, {tuple(k): v for k, v in zip(length_keys.tolist(), lengths.tolist(), strict=True)}


def active() -> bool:
    """Whether a folder is given now (paths are read and kept)."""
    return cspace_store.folder() is not None


def lookup(free: npt.NDArray[np.bool_], s: tuple[int, int], t: tuple[int, int],
           map_key: str | None = None) -> tuple[bool, Cells]:
    """(True, the kept path from cell ``s`` to ``t`` over ``free``, None: none) or (False, None) when it
    is not kept (or no folder is given); ``map_key``: :func:`key` of ``free`` when the caller keeps it."""
    got = _paths(free, map_key)
    if got is None or (s, t) not in got[0]:
        return False, None
    return True, got[0][(s, t)]


def keep(free: npt.NDArray[np.bool_], s: tuple[int, int], t: tuple[int, int], cells: Cells,
         map_key: str | None = None) -> None:
    """Note a searched path, written by :func:`flush` (when a folder is given)."""
    got = _paths(free, map_key)
    if got is not None and (s, t) not in got[0]:
        got[0][(s, t)] = cells
        got[1][0] = True


def lookup_length(free: npt.NDArray[np.bool_], map_key: str, ends: LengthKey) -> float | None:
    """The kept yardstick length over ``free`` between the ends (start x, y, goal x, y, the grid's origin
    x, y and resolution), or None."""
    got = _paths(free, map_key)
    return None if got is None else got[2].get(ends)


def keep_length(free: npt.NDArray[np.bool_], map_key: str, ends: LengthKey, length: float) -> None:
    """Note a yardstick length, written by :func:`flush` (when a folder is given)."""
    got = _paths(free, map_key)
    if got is not None and ends not in got[2]:
        got[2][ends] = length
        got[1][0] = True


CorridorEnds = tuple[int, int, int, int, int, int, float]  # (bin, y, x) of start and goal, the radius
Route = tuple[tuple[int, int, int], ...] | None  # (bin, y, x) of each cell, or None: no route
# per folder and configuration space key: the corridor routes read or searched, whether some are new
_corridors: dict[tuple[Path, str], tuple[dict[CorridorEnds, Route], list[bool]]] = {}


def space_key(free: npt.NDArray[np.bool_], resolution: float) -> str:
    """The content hash of a configuration space's free cells (bin, y, x) and cell size the corridor routes
    over it are kept under (its cells packed 8 a byte, then hashed)."""
    h = hashlib.sha256(_code_digest())
    h.update(b"corridor " + repr((tuple(free.shape), float(resolution))).encode())
    h.update(np.packbits(np.ascontiguousarray(free, dtype=bool)).tobytes())
    return h.hexdigest()


def _routes(space: str) -> tuple[dict[CorridorEnds, Route], list[bool]] | None:
    where = cspace_store.folder()
    if where is None:
        return None
    folder = where.parent / SUBDIR
    k = (folder, space)
    got = _corridors.get(k)
    if got is None:
        if len(_corridors) >= 1024:
            for old in [o for o, (_, new) in _corridors.items() if not new[0]]:
                del _corridors[old]
        got = (_read_routes(folder / f"corridor-{space}.npz"), [False])
        _corridors[k] = got
    return got


def _read_routes(path: Path) -> dict[CorridorEnds, Route]:
    got = read_arrays(path, {"ends": np.int64, "radii": np.float64, "starts": np.int64, "cells": np.int64},
                  "corridor routes")
    if got is None:
        return {}
    ends, radii, starts, cells = got
    if ends.ndim != 2 or ends.shape[1] != 6 or radii.shape != (len(ends),) \
            or starts.shape != (len(ends) + 1,) or cells.ndim != 2 or cells.shape[1] != 3 \
            or int(starts[0]) != 0 or int(starts[-1]) != len(cells):
        log.warning("ignoring the kept corridor routes %s: not a set of routes", path.name)
        return {}
    out: dict[CorridorEnds, Route] = {}
    flat, bounds = cells.tolist(), starts.tolist()
    for n, (e, r) in enumerate(zip(ends.tolist(), radii.tolist(), strict=True)):
        a, b = bounds[n], bounds[n + 1]
        out[(e[0], e[1], e[2], e[3], e[4], e[5], r)] = tuple((c[0], c[1], c[2]) for c in flat[a:b]) \
            if b > a else None
    counts["read"] += 1
    return out


def lookup_route(space: str, ends: CorridorEnds) -> tuple[bool, Route]:
    """(True, the kept corridor route's cells, None: none) or (False, None) when it is not kept (or no
    folder is given); ``space``: :func:`space_key` of the configuration space's free cells."""
    got = _routes(space)
    if got is None or ends not in got[0]:
        return False, None
    return True, got[0][ends]


def keep_route(space: str, ends: CorridorEnds, route: Route) -> None:
    """Note a searched corridor route, written by :func:`flush` (when a folder is given)."""
    got = _routes(space)
    if got is not None and ends not in got[0]:
        got[0][ends] = route
        got[1][0] = True


def _flush_routes(folder: Path) -> bool:
    wrote = False
    for (f, k), (routes, new) in _corridors.items():
        if f != folder or not new[0]:
            continue
        ends = sorted(routes)
        seqs = [routes[e] or () for e in ends]
        if not write_arrays(
                folder / f"corridor-{k}.npz", "corridor routes", None,
                ends=np.array([e[:6] for e in ends], dtype=np.int64).reshape(-1, 6),
                radii=np.array([e[6] for e in ends], dtype=np.float64),
                starts=np.concatenate([[0], np.cumsum([len(c) for c in seqs])]).astype(np.int64),
                cells=np.array([c for seq in seqs for c in seq], dtype=np.int64).reshape(-1, 3)):
            return wrote
        counts["written"] += 1
        new[0] = False
        wrote = True
    return wrote


def flush() -> None:
    """Write the maps of the folder given now that got new paths (a whole file per map)."""
    where = cspace_store.folder()
    if where is None:
        return
    folder = where.parent / SUBDIR
    wrote = _flush_routes(folder)
    for (f, k), (paths, new, lengths) in _known.items():
        if f != folder or not new[0]:
            continue
        ends = sorted(paths)
        seqs = [paths[e] or () for e in ends]
        starts = np.concatenate([[0], np.cumsum([len(c) for c in seqs])]).astype(np.int64)
        cells = np.array([c for seq in seqs for c in seq], dtype=np.int64).reshape(-1, 2)
        pairs = np.array([[*s, *t] for s, t in ends], dtype=np.int64).reshape(-1, 4)
        length_keys = sorted(lengths)
        if not write_arrays(folder / f"{k}.npz", "cell paths", None, ends=pairs, starts=starts, cells=cells,
                            length_keys=np.array(length_keys, dtype=np.float64).reshape(-1, 7),
                            lengths=np.array([lengths[k] for k in length_keys], dtype=np.float64)):
            return
        counts["written"] += 1
        new[0] = False
        wrote = True
    if wrote:
        keep_newest(folder, KEEP)
