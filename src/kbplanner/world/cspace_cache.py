"""Configuration spaces kept per process (B4 carry-leg checks, B5 navigation): each built and labelled once.

B4 (the carry leg, :mod:`kbplanner.planning.carry_reach`; the escape test of
:func:`~kbplanner.planning.base_poses.escapes`) and B5 (the navigation skill and the carry modes of
:mod:`kbplanner.simulation.carry_paths`) build the configuration space of a footprint on windows of the
same map states, often more than once. :func:`configuration_space` returns a
:class:`~kbplanner.world.footprint.ConfigurationSpace` equal to ``ConfigurationSpace.build(grid,
footprint, n_yaw_bins, margin_m)``, from an in-process LRU cache:

- the same grid (occupancy content hash, shape, origin, resolution), footprint rectangles, yaw bins
  and margin: the kept free maps, and the labels of
  :meth:`~kbplanner.world.footprint.ConfigurationSpace.labels_and_roots` computed on them (memoised on
  the space's ``memo``, shared by every space returned for that key);
- a window of a grid kept (same resolution, cells aligned, the same occupancy where they overlap): the
  kept free maps cropped, where the footprint swept over a yaw bin stays within the window (its
  kernel's extent), else blocked - exactly what a build on the window gives, since a window's cells off
  it count as occupied. (The labels are the window's own: connectivity is not cropped.) Where the
  window's occupancy differs in a few cells (B5's map of a state rasterises an installed element a
  cell or so differently from B4's), only the cells within the footprint's reach of them are built
  again;
- the same grid cells, footprint, yaw bins and margin kept on disk by an earlier command
  (:mod:`kbplanner.world.cspace_store`, when a folder is given): the free maps read back. A space
  built or cropped here is written there.

Memory is bounded: the least recently used spaces go once the kept free maps and labels exceed
:data:`BUDGET_BYTES`. Returned arrays are read-only (shared).

Example:
    >>> import numpy as np
    >>> from kbplanner.world.footprint import Footprint, Rect
    >>> occ = np.zeros((60, 80), dtype=bool); occ[:, 50] = True
    >>> grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
    >>> fp = Footprint((Rect(0, 0, 0.5, 0.3),))
    >>> clear()
    >>> a = configuration_space(grid, fp)
    >>> sub = OccupancyGrid(occ[10:50, 5:70].copy(), origin=(0.25, 0.5), resolution=0.05)
    >>> b = configuration_space(sub, fp)
    >>> bool((b.free == ConfigurationSpace.build(sub, fp).free).all()), stats()["cropped"]
    (True, 1)
"""

from __future__ import annotations

import functools
import hashlib
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kbplanner.world import cspace_store
from kbplanner.world.cspace_fft import block_off_grid, kernel_set
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect, kernel_half_size
from kbplanner.world.occupancy import OccupancyGrid

#: Bytes of free maps and labels kept at most, checked as a space is added (a 600 x 600 cell window,
#: 72 yaw bins: 26 MB of free maps, 104 MB of labels per connectivity).
BUDGET_BYTES = 320 * 1024 * 1024
#: A kept grid whose occupancy differs from the one asked for is used when the cells to build again,
#: with their kernels' reach, are at most this share of the grid asked for.
PATCH_MAX_SHARE = 0.5

_Key = tuple[tuple[Rect, ...], int, float, float]  # footprint rectangles, yaw bins, margin, resolution


@dataclass
class _Entry:
    space: ConfigurationSpace
    occupied: npt.NDArray[np.bool_]  # a copy of the grid's cells as built (the caller's may change later)
    digest: bytes
    ix0: float  # cell offset of the grid's origin (origin / resolution), for windows
    iy0: float


class _Cache:
    def __init__(self) -> None:
        self.entries: OrderedDict[tuple[_Key, bytes, tuple[float, float]], _Entry] = OrderedDict()
        self.counts = {"built": 0, "hits": 0, "cropped": 0, "patched": 0, "read": 0, "evicted": 0}

    def bytes(self) -> int:
        return sum(e.space.nbytes() for e in self.entries.values())

    def trim(self) -> None:
        """Over the budget: the labels of the least recently used spaces go first (4 bytes a cell and
        yaw bin, and only asked again of the same window), then the least recently used spaces."""
        total = self.bytes()
        for e in list(self.entries.values())[:-1]:
            if total <= BUDGET_BYTES:
                return
            if e.space.memo or e.space.path_memo:
                total -= e.space.nbytes() - int(e.space.free.nbytes)
                e.space.memo.clear()
                e.space.path_memo.clear()
        while len(self.entries) > 1 and total > BUDGET_BYTES:
            _, e = self.entries.popitem(last=False)
            total -= e.space.nbytes()
            self.counts["evicted"] += 1


_CACHE = _Cache()


def _digest(grid: OccupancyGrid) -> bytes:
    h = hashlib.sha1(np.ascontiguousarray(grid.occupied).tobytes())
    h.update(repr(grid.shape).encode())
    return h.digest()


def configuration_space(grid: OccupancyGrid, footprint: Footprint, n_yaw_bins: int = 72,
                        margin_m: float = 0.0) -> ConfigurationSpace:
    """``ConfigurationSpace.build(grid, footprint, n_yaw_bins, margin_m)``, kept (module docstring)."""
    key: _Key = (footprint.rects, int(n_yaw_bins), float(margin_m), float(grid.resolution))
    digest = _digest(grid)
    full = (key, digest, (float(grid.origin[0]), float(grid.origin[1])))
    entry = _CACHE.entries.get(full)
    if entry is not None:
        _CACHE.entries.move_to_end(full)
        _CACHE.counts["hits"] += 1
        _CACHE.trim()
        return _view(entry.space, grid, footprint)
    kept_free = cspace_store.read(grid, footprint, n_yaw_bins, margin_m)
    if kept_free is not None:
        cs = ConfigurationSpace(grid=grid, footprint=footprint, free=kept_free, margin_m=margin_m)
        _CACHE.counts["read"] += 1
    else:
        crop = _cropped(key, grid, footprint)
        if crop is None:
            cs = ConfigurationSpace.build(grid, footprint, n_yaw_bins, margin_m)
            _CACHE.counts["built"] += 1
        else:
            cs = crop
            _CACHE.counts["cropped"] += 1
        cspace_store.write(grid, footprint, n_yaw_bins, margin_m, cs.free)
    cs.free.setflags(write=False)
    res = grid.resolution
    kept = grid.occupied.copy()
    kept.setflags(write=False)
    _CACHE.entries[full] = _Entry(cs, kept, digest, grid.origin[0] / res, grid.origin[1] / res)
    _CACHE.trim()
    return cs


def _view(kept: ConfigurationSpace, grid: OccupancyGrid, footprint: Footprint) -> ConfigurationSpace:
    """The kept space for the caller's grid and footprint objects (same free maps and labels memo)."""
    if kept.grid is grid and kept.footprint is footprint:
        return kept
    return ConfigurationSpace(grid=grid, footprint=footprint, free=kept.free, margin_m=kept.margin_m,
                              memo=kept.memo, open_memo=kept.open_memo, near_memo=kept.near_memo,
                              path_memo=kept.path_memo)


def _cropped(key: _Key, grid: OccupancyGrid, footprint: Footprint) -> ConfigurationSpace | None:
    """The space of ``grid`` from a kept space of a grid it is a window of, or None.

    Where the occupancy differs in a few cells (an element rasterised a little differently), the
    cells within a kernel's reach of them are built again, on the window around them grown by that
    reach: used when that window is under :data:`PATCH_MAX_SHARE` of ``grid``.
    """
    res = grid.resolution
    ox, oy = grid.origin[0] / res, grid.origin[1] / res
    sy, sx = grid.shape
    n_bins, margin = key[1], key[2]
    reach = kernel_reach(footprint, res, n_bins, margin)
    best: tuple[int, int, _Entry, int, int, tuple[int, int, int, int] | None] | None = None
    for (k, _d, _o), e in _CACHE.entries.items():
        if k != key:
            continue
        ny, nx = e.occupied.shape
        fx, fy = ox - e.ix0, oy - e.iy0
        ix, iy = round(fx), round(fy)
        if abs(fx - ix) > 1e-6 or abs(fy - iy) > 1e-6:
            continue
        if ix < 0 or iy < 0 or ix + sx > nx or iy + sy > ny:
            continue
        diff = e.occupied[iy:iy + sy, ix:ix + sx] != grid.occupied
        box = None
        cost = 0
        if diff.any():
            rows, cols = np.nonzero(diff.any(axis=1))[0], np.nonzero(diff.any(axis=0))[0]
            # the cells to build again (y0, y1, x0, x1): within reach of a changed cell
            box = (max(0, int(rows[0]) - reach), min(sy, int(rows[-1]) + reach + 1),
                   max(0, int(cols[0]) - reach), min(sx, int(cols[-1]) + reach + 1))
            cost = (min(sy, box[1] + reach) - max(0, box[0] - reach)) * \
                (min(sx, box[3] + reach) - max(0, box[2] - reach))
            if cost > PATCH_MAX_SHARE * sy * sx:
                continue
        if best is None or (cost, ny * nx) < best[:2]:
            best = (cost, ny * nx, e, ix, iy, box)
    if best is None:
        return None
    _, _, e, ix, iy, box = best
    free = e.space.free[:, iy:iy + sy, ix:ix + sx].copy()
    # cells whose swept footprint leaves the window blocked (a build on the window counts off it occupied)
    block_off_grid(free, kernel_set(footprint.rects, float(res), int(n_bins), float(margin)).bin_extents())
    if box is not None:
        y0, y1, x0, x1 = box
        wy0, wy1, wx0, wx1 = max(0, y0 - reach), min(sy, y1 + reach), max(0, x0 - reach), min(sx, x1 + reach)
        part = OccupancyGrid(grid.occupied[wy0:wy1, wx0:wx1].copy(),
                             origin=(grid.origin[0] + wx0 * res, grid.origin[1] + wy0 * res), resolution=res)
        again = ConfigurationSpace.build(part, footprint, n_bins, margin)
        free[:, y0:y1, x0:x1] = again.free[:, y0 - wy0:y1 - wy0, x0 - wx0:x1 - wx0]
        _CACHE.counts["patched"] += 1
    return ConfigurationSpace(grid=grid, footprint=footprint, free=np.ascontiguousarray(free),
                              margin_m=margin)


def kernel_reach(footprint: Footprint, res: float, n_bins: int, margin_m: float) -> int:  # noqa: ARG001
    """The largest kernel half-size in cells: how far an occupied cell changes the free maps. Every yaw
    bin's kernel has the same size (its half-size depends on the footprint's radius only), so this is
    found without rasterising any, whatever ``n_bins`` (tests/test_cspace_store.py)."""
    return _kernel_reach(footprint.rects, float(res), float(margin_m))


@functools.lru_cache(maxsize=1024)
def _kernel_reach(rects: tuple[Rect, ...], res: float, margin_m: float) -> int:
    return kernel_half_size(rects, res, margin_m)


def clear() -> None:
    """Forget every kept space and reset the counts."""
    _CACHE.entries.clear()
    _CACHE.counts = dict.fromkeys(_CACHE.counts, 0)


def stats() -> dict[str, int]:
    """Counts since the last :func:`clear`: built, hits (same grid), cropped (a window of a kept grid;
    patched: of those, with a few cells built again), read (from :mod:`~kbplanner.world.cspace_store`),
    evicted; and the spaces and bytes kept now."""
    return {**_CACHE.counts, "kept": len(_CACHE.entries), "bytes": _CACHE.bytes()}
