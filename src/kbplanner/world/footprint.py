"""Footprints and configuration space (B3 fit checks, B5 navigation): what a robot and its load cover.

A :class:`Footprint` is a union of oriented rectangles in the robot frame (x forward, y left): the
base, plus the carried object in its current carry pose. :class:`ConfigurationSpace` turns an
occupancy grid and a footprint into one free/blocked map per yaw bin (72 by default), built by FFT
correlation of the grid with the footprint rasterised over the whole bin, so that checking a pose
(x, y, yaw) is a single array look-up. The check is conservative: a cell is blocked when any pose in
that cell (any position within the cell, any yaw within the bin) could touch an occupied cell.

Example:
    >>> import numpy as np
    >>> from kbplanner.world.occupancy import OccupancyGrid
    >>> occ = np.zeros((40, 40), dtype=bool); occ[:, 30] = True        # a wall at x = 1.5 m
    >>> grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
    >>> cs = ConfigurationSpace.build(grid, Footprint((Rect(0, 0, 0.99, 0.67),)))
    >>> cs.is_free(0.9, 1.0, 0.0), cs.is_free(1.1, 1.0, 0.0)
    (True, False)
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely

from kbplanner.core.errors import KbplannerError
from kbplanner.world.cspace_fft import free_maps, rasterised_kernel
from kbplanner.world.cspace_fft import kernel_half_size as kernel_half_size
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

BoolArray = npt.NDArray[np.bool_]
#: Half-size (cells) of the box around a pose in which :meth:`ConfigurationSpace.joined` looks for
#: cells free in every yaw bin (1.5 m at 5 cm cells).
JOIN_BOX_CELLS = 30


@dataclass(frozen=True)
class Rect:
    """A rectangle in the robot frame: centre (cx, cy), ``length`` along its x, ``width`` along its y."""

    cx: float
    cy: float
    length: float
    width: float
    yaw: float = 0.0

    def corners(self, yaw: float = 0.0) -> npt.NDArray[np.float64]:
        """The 4 corners (4, 2) in the robot frame, turned with the robot by ``yaw``."""
        hl, hw = self.length / 2, self.width / 2
        local = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        pts = local @ np.array([[c, s], [-s, c]]) + np.array([self.cx, self.cy])
        c, s = math.cos(yaw), math.sin(yaw)
        return np.asarray(pts @ np.array([[c, s], [-s, c]]), dtype=np.float64)


@dataclass(frozen=True)
class Footprint:
    """A union of oriented rectangles in the robot frame (base, carried load, ...)."""

    rects: tuple[Rect, ...]
    name: str = "footprint"

    def __post_init__(self) -> None:
        if not self.rects:
            raise KbplannerError("a footprint needs at least one rectangle", element=self.name,
                                 fix="give the base rectangle, e.g. Rect(0, 0, 0.99, 0.67)")
        for r in self.rects:
            if not (r.length > 0 and r.width > 0):
                raise KbplannerError(f"rectangle with non-positive size {r}", element=self.name,
                                     fix="give length and width in metres, both > 0")

    def with_rect(self, rect: Rect, name: str | None = None) -> Footprint:
        """This footprint plus one more rectangle (e.g. the carried load)."""
        return Footprint((*self.rects, rect), name=name or self.name)

    @property
    def radius_m(self) -> float:
        """Largest distance of any corner from the robot origin."""
        return float(max(np.hypot(*r.corners().T).max() for r in self.rects))

    def polygon(self, x: float = 0.0, y: float = 0.0, yaw: float = 0.0) -> shapely.Geometry:
        """The footprint placed at (x, y, yaw) in the site frame, as a shapely geometry."""
        polys = [shapely.Polygon(r.corners(yaw) + np.array([x, y])) for r in self.rects]
        return shapely.union_all(polys)

    def bounds_m(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the footprint in the robot frame."""
        pts = np.concatenate([r.corners() for r in self.rects])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    def kernel(self, resolution: float, yaw_lo: float, yaw_hi: float, margin_m: float = 0.0) -> BoolArray:
        """Offsets (dx, dy) in cells from the robot's cell to obstacle cells it may touch, as a mask.

        The mask has shape (2h+1, 2h+1) with the robot's cell at [h, h]; entry [h+dy, h+dx] is True
        when an obstacle cell at that offset can overlap the footprint for some yaw in
        [yaw_lo, yaw_hi] and some robot position within its cell: the footprint, grown by
        ``margin_m``, is swept over the yaw interval and Minkowski-summed with a square of half-side
        one cell (half a cell for the robot's position, half a cell for the obstacle cell).
        """
        return rasterised_kernel(self.rects, float(resolution), float(yaw_lo), float(yaw_hi),
                                 float(margin_m)).copy()


@dataclass(frozen=True, eq=False)
class ConfigurationSpace:
    """Free/blocked maps of a footprint on a grid, one per yaw bin: ``free[bin, iy, ix]``.

    Bin ``k`` covers yaw in [k*w - w/2, k*w + w/2) with w = 2*pi / n_bins.
    """

    grid: OccupancyGrid
    footprint: Footprint
    free: BoolArray
    margin_m: float = 0.0
    #: labels_and_roots per ``diagonal``, computed once (shared by the spaces of one free map,
    #: :mod:`kbplanner.world.cspace_cache`)
    memo: dict[bool, tuple[npt.NDArray[np.int32], npt.NDArray[np.int64]]] = field(
        default_factory=dict, repr=False, compare=False)
    open_memo: dict[tuple[str, bool], npt.NDArray[np.int32]] = field(default_factory=dict, repr=False,
                                                                     compare=False)
    #: :meth:`_groups_near` per (diagonal, bin, iy, ix): the carry-leg check asks it of one start cell
    #: for every goal
    near_memo: dict[tuple[bool, int, int, int], frozenset[int]] = field(default_factory=dict, repr=False,
                                                                        compare=False)
    #: what path searches on the free maps keep (:mod:`kbplanner.simulation.grid_yardstick`: the cells
    #: free at some yaw, their graph, shortest cell paths), shared as ``memo`` is; their bytes, under
    #: ``"bytes"``, counted in :meth:`nbytes`
    path_memo: dict[Any, Any] = field(default_factory=dict, repr=False, compare=False)

    def nbytes(self) -> int:
        """Bytes of the free maps and the labels computed so far."""
        return (int(self.free.nbytes) + sum(int(a.nbytes + b.nbytes) for a, b in self.memo.values())
                + int(self.path_memo.get("bytes", 0)))

    @property
    def n_bins(self) -> int:
        """Number of yaw bins."""
        return int(self.free.shape[0])

    @property
    def bin_width(self) -> float:
        """Width of a yaw bin in radians."""
        return 2 * math.pi / self.n_bins

    @classmethod
    def build(
        cls, grid: OccupancyGrid, footprint: Footprint, n_yaw_bins: int = 72, margin_m: float = 0.0
    ) -> ConfigurationSpace:
        """Precompute the free maps; cells off the grid count as occupied."""
        if n_yaw_bins < 4:
            raise KbplannerError(f"n_yaw_bins must be at least 4, got {n_yaw_bins}", element="n_yaw_bins",
                                 fix="use e.g. 72 (5 degree bins)")
        free = free_maps(grid.occupied, footprint.rects, float(grid.resolution), int(n_yaw_bins),
                         float(margin_m))
        log.debug("configuration space %s: %d bins, %.1f %% free at yaw 0", footprint.name, n_yaw_bins,
                  100.0 * free[0].mean())
        return cls(grid=grid, footprint=footprint, free=free, margin_m=margin_m)

    def yaw_bin(self, yaw: float) -> int:
        """The bin index of a yaw angle (radians, any range)."""
        w = self.bin_width
        return math.floor((yaw + w / 2) / w) % self.n_bins

    def is_free(self, x: float, y: float, yaw: float) -> bool:
        """Whether the footprint at (x, y, yaw) is clear of every occupied cell (conservatively)."""
        g = self.grid
        ix = math.floor((x - g.origin[0]) / g.resolution)
        iy = math.floor((y - g.origin[1]) / g.resolution)
        ny, nx = g.shape
        if not (0 <= ix < nx and 0 <= iy < ny):
            return False
        return bool(self.free[self.yaw_bin(yaw), iy, ix])

    def is_free_many(
        self, poses: Sequence[tuple[float, float, float]] | npt.NDArray[np.float64]
    ) -> BoolArray:
        """Vectorised :meth:`is_free` for an (N, 3) array of poses."""
        p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        g = self.grid
        ix = np.floor((p[:, 0] - g.origin[0]) / g.resolution).astype(np.int64)
        iy = np.floor((p[:, 1] - g.origin[1]) / g.resolution).astype(np.int64)
        w = self.bin_width
        k = np.floor((p[:, 2] + w / 2) / w).astype(np.int64) % self.n_bins
        ny, nx = g.shape
        ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        out = np.zeros(len(p), dtype=bool)
        out[ok] = self.free[k[ok], iy[ok], ix[ok]]
        return out

    def components(self, *, diagonal: bool = False) -> npt.NDArray[np.int64]:
        """Connected components of the free cells (bin, iy, ix), the yaw axis closed into a ring.

        ``diagonal=False``: face-adjacent cells only - every pose in a free cell is free, so cells of
        one component are certainly joined by a collision-free motion. ``diagonal=True``: 26-connected
        (across the wrap too), which over-connects, so different components are certainly apart.
        0 is blocked; labels are joined across the wrap (bin n-1 next to bin 0).
        """
        labels, roots = self.labels_and_roots(diagonal)
        return np.asarray(roots[labels], dtype=np.int64)

    def components_of(
        self, poses: Sequence[tuple[float, float, float]], *, diagonal: bool = False
    ) -> list[int]:
        """:meth:`component_of` of each pose under :meth:`components`, without mapping every cell."""
        labels, roots = self.labels_and_roots(diagonal)
        ny, nx = self.grid.shape
        out = []
        for x, y, yaw in poses:
            ix, iy = self.grid.cell_of(x, y)
            inside = 0 <= ix < nx and 0 <= iy < ny
            out.append(int(roots[labels[self.yaw_bin(yaw), iy, ix]]) if inside else 0)
        return out

    def joined(self, a: tuple[float, float, float], b: tuple[float, float, float], *, diagonal: bool) -> bool:
        """Whether poses ``a`` and ``b`` are both free and in one component of :meth:`components`.

        The same answer as comparing :meth:`components_of`, often without labelling the whole space: a
        pose's component on a small box of cells around it (:data:`JOIN_BOX_CELLS` each way, all yaw
        bins; boxes are padded with blocked cells, so what joins there joins on the grid) that reaches
        a cell free in every yaw bin is that cell's; such cells next to one another (8 or 4 neighbours)
        are joined. Two poses that reach one group of such cells are joined; else the whole space is
        labelled (once, :meth:`labels_and_roots`).
        """
        cells = [self._cell(*a), self._cell(*b)]
        if any(c is None or not self.free[c] for c in cells):
            return False
        if diagonal not in self.memo:
            groups, touched = self._open_groups(diagonal), []
            for c in cells:
                assert c is not None
                touched.append(self._groups_near(c, groups, diagonal))
            if touched[0] & touched[1]:
                return True
        ca, cb = self.components_of([a, b], diagonal=diagonal)
        return ca > 0 and ca == cb

    def _cell(self, x: float, y: float, yaw: float) -> tuple[int, int, int] | None:
        """(bin, iy, ix) of a pose; None off the grid."""
        ix, iy = self.grid.cell_of(x, y)
        ny, nx = self.grid.shape
        if not (0 <= ix < nx and 0 <= iy < ny):
            return None
        return (self.yaw_bin(yaw), iy, ix)

    def _open_groups(self, diagonal: bool) -> npt.NDArray[np.int32]:
        """2D labels of the cells free in every yaw bin (8- or 4-connected); 0 elsewhere (memoised)."""
        key = ("open", diagonal)
        got = self.open_memo.get(key)
        if got is None:
            from scipy import ndimage

            structure = np.ones((3, 3), dtype=bool) if diagonal else ndimage.generate_binary_structure(2, 1)
            got = ndimage.label(self.free.all(axis=0), structure=structure)[0].astype(np.int32)
            self.open_memo[key] = got
        return got

    def _groups_near(self, cell: tuple[int, int, int], groups: npt.NDArray[np.int32],
                     diagonal: bool) -> frozenset[int]:
        """The groups of :meth:`_open_groups` that the component of ``cell`` reaches within a box
        (memoised per cell)."""
        key = (diagonal, *cell)
        got = self.near_memo.get(key)
        if got is None:
            got = self._groups_near_of(cell, groups, diagonal)
            self.near_memo[key] = got
        return got

    def _groups_near_of(self, cell: tuple[int, int, int], groups: npt.NDArray[np.int32],
                        diagonal: bool) -> frozenset[int]:
        k, iy, ix = cell
        ny, nx = self.grid.shape
        r = JOIN_BOX_CELLS
        y0, y1, x0, x1 = max(0, iy - r), min(ny, iy + r + 1), max(0, ix - r), min(nx, ix + r + 1)
        box = np.zeros((self.n_bins, y1 - y0 + 2, x1 - x0 + 2), dtype=bool)  # a blocked cell all round
        box[:, 1:-1, 1:-1] = self.free[:, y0:y1, x0:x1]
        sub = ConfigurationSpace(grid=self.grid, footprint=self.footprint, free=box)
        labels, roots = sub._labels_and_roots(diagonal)
        mine = roots[labels[k, iy - y0 + 1, ix - x0 + 1]]
        near = groups[y0:y1, x0:x1]
        here = (roots[labels[0, 1:-1, 1:-1]] == mine) & (near > 0)  # an open cell is free in bin 0
        return frozenset(int(g) for g in np.unique(near[here]))

    def labels_and_roots(
        self, diagonal: bool
    ) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int64]]:
        """``ndimage.label`` of the free cells and, per label, the smallest label it is joined to.

        ``roots[labels]`` is :meth:`components`; kept apart, the (bin, iy, ix) array stays int32 and
        only the cells looked up are mapped (:meth:`components_of`, the carry-leg check of B4).
        Computed once per space (``memo``); the arrays returned are read-only.
        """
        got = self.memo.get(diagonal)
        if got is None:
            got = self._labels_and_roots(diagonal)
            for a in got:
                a.setflags(write=False)
            self.memo[diagonal] = got
        return got

    def _labels_and_roots(
        self, diagonal: bool
    ) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int64]]:
        from kbplanner.world.cspace_labels import label_runs

        labels, n = label_runs(self.free, diagonal)  # ndimage.label's labels, from the runs of cells
        # Join labels across the wrap; each label maps to the smallest label of its class (what a
        # union-find that keeps the smaller root gives), found with sparse connected components.
        first, last = labels[0], labels[-1]
        shifts = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1)] if diagonal else [(0, 0)]
        pairs = []
        for dy, dx in shifts:
            b = np.roll(np.roll(last, dy, axis=0), dx, axis=1)
            both = (first > 0) & (b > 0)
            pairs.append(np.stack([first[both], b[both]], axis=1))
        edges = np.concatenate(pairs).astype(np.int64) if pairs else np.zeros((0, 2), dtype=np.int64)
        if not len(edges):
            return labels, np.arange(n + 1, dtype=np.int64)
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        graph = coo_matrix((np.ones(len(edges), dtype=np.int8), (edges[:, 0], edges[:, 1])),
                           shape=(n + 1, n + 1))
        n_cls, cls = connected_components(graph, directed=False)
        smallest = np.full(n_cls, n + 1, dtype=np.int64)
        np.minimum.at(smallest, cls, np.arange(n + 1, dtype=np.int64))
        return labels, np.asarray(smallest[cls], dtype=np.int64)

    def component_of_labels(self, labels: npt.NDArray[np.int32], roots: npt.NDArray[np.int64], x: float,
                            y: float, yaw: float) -> int:
        """The component of a pose under (``labels``, ``roots``) of :meth:`labels_and_roots`; 0 when blocked
        or off the grid."""
        ix, iy = self.grid.cell_of(x, y)
        ny, nx = self.grid.shape
        if not (0 <= ix < nx and 0 <= iy < ny):
            return 0
        return int(roots[labels[self.yaw_bin(yaw), iy, ix]])

    def component_of(self, labels: npt.NDArray[np.int64], x: float, y: float, yaw: float) -> int:
        """The component (of :meth:`components`) of a pose; 0 when blocked or off the grid."""
        ix, iy = self.grid.cell_of(x, y)
        ny, nx = self.grid.shape
        if not (0 <= ix < nx and 0 <= iy < ny):
            return 0
        return int(labels[self.yaw_bin(yaw), iy, ix])

    def free_any_yaw(self) -> BoolArray:
        """Cells where at least one yaw bin is free (where the robot's centre can be at all)."""
        return np.asarray(self.free.any(axis=0))
