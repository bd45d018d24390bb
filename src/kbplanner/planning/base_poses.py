"""B4, where the robot can stand: exact look-ups of the navigation's configuration space, one pose at a time.

Takes an occupancy grid of the task storey (:class:`~kbplanner.world.occupancy.OccupancyGrid`) and a
footprint (:class:`~kbplanner.world.footprint.Footprint`: the base, or the base with its carried
element); gives :class:`PoseChecker` (is the footprint free at a pose, with the navigation's
conservative test, so a pose found free is a valid start or goal for the planner), :func:`escapes`
(is a robot at a pose not shut in), and :func:`element_polygon` / :func:`mark_polygon` (an element's
floor projection marked occupied, for installed elements), :func:`window` (the part of a grid the
navigation plans in) and :func:`nearest_free_pose` (where the navigation moves a robot standing on a
blocked cell). Used by the base-pose search of :mod:`kbplanner.planning.pose_search`, the carry-leg
check of :mod:`kbplanner.planning.carry_reach` and by the executor and navigation (B5).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import shapely

from kbplanner.planning.carry import Matrix
from kbplanner.planning.plan_model import Pose2
from kbplanner.world.footprint import Footprint
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import Bounds

N_YAW_BINS = 72


def element_polygon(bounds: Bounds, frame: Matrix) -> shapely.Geometry:
    """The floor projection (convex hull) of an element's box at ``frame`` (site)."""
    corners = np.c_[bounds.corners(), np.ones(8)] @ frame.T
    return shapely.MultiPoint(corners[:, :2]).convex_hull


def mark_polygon(grid: OccupancyGrid, polygon: shapely.Geometry) -> OccupancyGrid:
    """A copy of ``grid`` with every cell that ``polygon`` overlaps marked occupied."""
    occ = grid.occupied.copy()
    ny, nx = occ.shape
    res = grid.resolution
    x0, y0, x1, y1 = polygon.bounds
    ix0 = max(0, math.floor((x0 - grid.origin[0]) / res))
    iy0 = max(0, math.floor((y0 - grid.origin[1]) / res))
    ix1 = min(nx - 1, math.floor((x1 - grid.origin[0]) / res))
    iy1 = min(ny - 1, math.floor((y1 - grid.origin[1]) / res))
    if ix1 >= ix0 and iy1 >= iy0:
        xs = grid.origin[0] + np.arange(ix0, ix1 + 1) * res
        ys = grid.origin[1] + np.arange(iy0, iy1 + 1) * res
        gx, gy = np.meshgrid(xs, ys)
        boxes = shapely.box(gx, gy, gx + res, gy + res)
        hit = shapely.intersects(boxes, polygon) & ~shapely.touches(boxes, polygon)
        occ[iy0:iy1 + 1, ix0:ix1 + 1] |= hit
    return OccupancyGrid(occupied=occ, origin=grid.origin, resolution=grid.resolution, band=grid.band)


class PoseChecker:
    """Is a footprint at (x, y, yaw) free on a grid? The navigation's conservative test, one pose at a time.

    The look-up is the same as :class:`~kbplanner.world.footprint.ConfigurationSpace` (the footprint swept
    over the pose's yaw bin, grown by a cell), so a pose found free here is a valid start or goal for
    the planner; kernels are cached per footprint and bin.
    """

    def __init__(self, grid: OccupancyGrid, n_bins: int = N_YAW_BINS) -> None:
        self.grid = grid
        self.n_bins = n_bins
        # per footprint and yaw bin: the kernel cut to the rows and columns that hold a cell, and their
        # offsets (dy0, dx0) from the robot's cell (None: an empty kernel, nothing to block)
        self._kernels: dict[tuple[Footprint, int], tuple[npt.NDArray[np.bool_], int, int] | None] = {}

    def with_grid(self, grid: OccupancyGrid) -> PoseChecker:
        """The same checker (and kernel cache) on another grid of the same shape."""
        other = PoseChecker(grid, self.n_bins)
        other._kernels = self._kernels
        return other

    def free(self, footprint: Footprint, x: float, y: float, yaw: float) -> bool:
        """Whether the footprint at the pose touches no occupied cell (cells off the grid are occupied).

        Only the kernel's rows and columns that hold a cell are looked at (the same cells decide)."""
        g = self.grid
        w = 2 * math.pi / self.n_bins
        k = math.floor((yaw + w / 2) / w) % self.n_bins
        key = (footprint, k)
        if key in self._kernels:
            cut = self._kernels[key]
        else:
            cut = _cut(footprint.kernel(g.resolution, k * w - w / 2, k * w + w / 2))
            self._kernels[key] = cut
        ix = math.floor((x - g.origin[0]) / g.resolution)
        iy = math.floor((y - g.origin[1]) / g.resolution)
        ny, nx = g.shape
        if not (0 <= ix < nx and 0 <= iy < ny):
            return False
        if cut is None:
            return True
        kern, dy0, dx0 = cut
        ky, kx = kern.shape
        lo_y, lo_x = iy + dy0, ix + dx0
        hi_y, hi_x = lo_y + ky, lo_x + kx
        if lo_y < 0 or lo_x < 0 or hi_y > ny or hi_x > nx:  # the kernel reaches off the map
            window = np.ones(kern.shape, dtype=bool)
            sy0, sx0 = max(lo_y, 0), max(lo_x, 0)
            sy1, sx1 = min(hi_y, ny), min(hi_x, nx)
            if sy0 < sy1 and sx0 < sx1:
                window[sy0 - lo_y:sy1 - lo_y, sx0 - lo_x:sx1 - lo_x] = g.occupied[sy0:sy1, sx0:sx1]
        else:
            window = g.occupied[lo_y:hi_y, lo_x:hi_x]
        return not bool((window & kern).any())


def _cut(kern: npt.NDArray[np.bool_]) -> tuple[npt.NDArray[np.bool_], int, int] | None:
    """A kernel (robot's cell at its centre) cut to its rows and columns that hold a cell, with the
    offsets of the first of them from the robot's cell; None when it holds none."""
    rows, cols = np.flatnonzero(kern.any(axis=1)), np.flatnonzero(kern.any(axis=0))
    if not len(rows):
        return None
    h = kern.shape[0] // 2
    r0, r1, c0, c1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    return np.ascontiguousarray(kern[r0:r1, c0:c1]), r0 - h, c0 - h


def window(grid: OccupancyGrid, points: list[tuple[float, float]], margin_m: float | None) -> OccupancyGrid:
    """The part of ``grid`` around ``points`` plus ``margin_m`` (None: the whole grid).

    The navigation (B5) plans in such windows (cells off a window count as occupied, so what is free
    and connected in a window is so on the whole grid); B4's carry-leg check uses the same windows.
    """
    if margin_m is None:
        return grid
    res = grid.resolution
    ny, nx = grid.shape
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    ix0 = max(0, math.floor((min(xs) - margin_m - grid.origin[0]) / res))
    iy0 = max(0, math.floor((min(ys) - margin_m - grid.origin[1]) / res))
    ix1 = min(nx, math.ceil((max(xs) + margin_m - grid.origin[0]) / res))
    iy1 = min(ny, math.ceil((max(ys) + margin_m - grid.origin[1]) / res))
    return OccupancyGrid(occupied=grid.occupied[iy0:iy1, ix0:ix1].copy(),
                         origin=(grid.origin[0] + ix0 * res, grid.origin[1] + iy0 * res), resolution=res,
                         band=grid.band)


UNSTICK_RADIUS_M = 0.5  # how far the robot may move straight to leave a blocked start pose


def nearest_free_pose(checker: PoseChecker, start: tuple[float, float, float],
                      footprints: list[Footprint]) -> tuple[float, float, float] | None:
    """The nearest pose (rings of 2.5 cm, 16 bearings, same heading) where any of the footprints is free.

    Where the navigation (B5) moves a robot that stands on a cell its configuration space calls
    blocked before it plans (at most :data:`UNSTICK_RADIUS_M`); B4's carry-leg check starts there too.
    """
    for k in range(1, int(UNSTICK_RADIUS_M / 0.025) + 1):
        r = 0.025 * k
        for j in range(16):
            x = start[0] + r * math.cos(j * math.pi / 8)
            y = start[1] + r * math.sin(j * math.pi / 8)
            if any(checker.free(f, x, y, start[2]) for f in footprints):
                return (x, y, start[2])
    return None


def escapes(grid: OccupancyGrid, footprint: Footprint, pose: Pose2, *, radius_m: float = 3.0,
            n_bins: int = N_YAW_BINS) -> bool:
    """Whether a robot at ``pose`` is not shut in: its free configurations reach ``radius_m`` away.

    The configuration space of ``footprint`` is built on the grid around the pose; free
    (x, y, yaw-bin) cells are labelled with face connectivity only (6 neighbours, the yaw axis closed
    into a ring), which under-connects, so "reaches the window border" means the robot can get out
    of the neighbourhood (a 26-connected labelling would let it squeeze through diagonal gaps). A
    straight row of free cells from the pose to the border (:func:`straight_out`) decides it first,
    without the build and the labels (the same answer).

    Example:
        >>> occ = np.zeros((80, 80), dtype=bool); occ[20:60, [20, 59]] = True; occ[[20, 59], 20:60] = True
        >>> g = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
        >>> from kbplanner.world.footprint import Rect
        >>> escapes(g, Footprint((Rect(0, 0, 0.5, 0.3),)), Pose2(2.0, 2.0, 0.0), radius_m=1.5)
        False
    """
    from kbplanner.world.cspace_cache import configuration_space

    res = grid.resolution
    ny, nx = grid.shape
    ix0 = max(0, math.floor((pose.x - radius_m - grid.origin[0]) / res))
    iy0 = max(0, math.floor((pose.y - radius_m - grid.origin[1]) / res))
    ix1 = min(nx, math.ceil((pose.x + radius_m - grid.origin[0]) / res))
    iy1 = min(ny, math.ceil((pose.y + radius_m - grid.origin[1]) / res))
    sub = OccupancyGrid(occupied=grid.occupied[iy0:iy1, ix0:ix1], origin=(grid.origin[0] + ix0 * res,
                        grid.origin[1] + iy0 * res), resolution=res, band=grid.band)
    # Off the window counts as occupied, so free cells stop a footprint radius short of its border:
    # the band of that width (plus two cells) along the border is "away". The map's own edges are not.
    band = math.ceil((footprint.radius_m + 2 * res) / res)
    border = np.zeros(sub.shape, dtype=bool)
    if ix0 > 0:
        border[:, :band] = True
    if ix1 < nx:
        border[:, -band:] = True
    if iy0 > 0:
        border[:band, :] = True
    if iy1 < ny:
        border[-band:, :] = True
    if straight_out(sub, footprint, pose, border, n_bins):
        return True
    cs = configuration_space(sub, footprint, n_bins)
    labels = cs.components()
    root = cs.component_of(labels, pose.x, pose.y, pose.yaw)
    if root == 0:
        return False
    return bool((labels[:, border] == root).any())


def straight_out(grid: OccupancyGrid, footprint: Footprint, pose: Pose2, border: npt.NDArray[np.bool_],
                 n_bins: int = N_YAW_BINS) -> bool:
    """Whether the footprint, at the pose's heading, is free on every cell from the pose's cell straight
    along +x, -x, +y or -y up to a cell of ``border`` (cells off the grid occupied).

    Such a row of cells is face-connected in the pose's yaw bin of the configuration space, so then the
    pose's component (6-connected, :func:`escapes`) reaches ``border``: the same answer without building
    and labelling the space. The free test is :class:`PoseChecker`'s (the configuration space's).
    """
    res = grid.resolution
    ny, nx = grid.shape
    ix = math.floor((pose.x - grid.origin[0]) / res)
    iy = math.floor((pose.y - grid.origin[1]) / res)
    if not (0 <= ix < nx and 0 <= iy < ny) or not border.any():
        return False
    w = 2 * math.pi / n_bins
    k = math.floor((pose.yaw + w / 2) / w) % n_bins
    kern = footprint.kernel(res, k * w - w / 2, k * w + w / 2)
    h = kern.shape[0] // 2
    padded = np.pad(grid.occupied, h, constant_values=True)
    from numpy.lib.stride_tricks import sliding_window_view

    # the cells of the pose's row and column: free where no occupied cell lies under the kernel
    across: npt.NDArray[np.bool_] = sliding_window_view(padded[iy:iy + 2 * h + 1, :], kern.shape)[0]
    along: npt.NDArray[np.bool_] = sliding_window_view(padded[:, ix:ix + 2 * h + 1], kern.shape)[:, 0]
    row = np.asarray(~(across & kern).any(axis=(1, 2)), dtype=bool)
    col = np.asarray(~(along & kern).any(axis=(1, 2)), dtype=bool)
    for free, edge, i in ((row, border[iy, :], ix), (col, border[:, ix], iy)):
        for step in (1, -1):
            line, out = (free[i:], edge[i:]) if step == 1 else (free[i::-1], edge[i::-1])
            hits = np.flatnonzero(out)
            if len(hits) and line[:hits[0] + 1].all():
                return True
    return False

