"""Two poses joined in a configuration space, decided on a part of the grid (B4 carry-leg check).

:meth:`~kbplanner.world.footprint.ConfigurationSpace.joined` on a whole grid needs the configuration
space of the grid built (one FFT per yaw bin) and, where the boxes around the poses do not decide, its
free cells labelled whole. :class:`PartJoin` gives the same answer, when it can, from a part of the
grid: the rectangle of cells around some poses grown by ``margin_cells`` (clipped to the grid).

- Its free maps are the grid's exactly (:func:`part_free`: the occupied cells under each yaw bin's
  kernel counted by FFT on the part grown by the kernels' reach, cells off the grid occupied; only the
  part's own cells are computed).
- Its components are labelled on the part alone (cells round it count as blocked), with the
  connectivity and the yaw ring of the whole: two cells joined in the part are joined on the grid (a
  subset of the free cells), and a component with no cell on the part's rim (its cells next to the
  grid's other cells) is the same on the grid.

So two poses in one component of the part are joined (True); when the component of either has no cell
on the rim, they are joined exactly when the components are the same (False otherwise); else the part
does not decide (None) and the caller asks the whole space.

Example:
    >>> import numpy as np
    >>> from kbplanner.world.footprint import Footprint, Rect
    >>> occ = np.zeros((80, 200), dtype=bool); occ[:, 100] = True; occ[30:50, 100] = False  # a door
    >>> grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
    >>> fp = Footprint((Rect(0, 0, 0.4, 0.3),))
    >>> part = PartJoin(grid, fp, [(4.0, 2.0), (6.0, 2.0)], margin_cells=25, diagonal=True, n_bins=24)
    >>> part.joined((4.0, 2.0, 0.0), (6.0, 2.0, 0.0))     # through the door
    True
    >>> part.joined((4.0, 2.0, 0.0), (5.0, 1.0, 0.0))     # in the wall: blocked
    False
    >>> part.joined((4.0, 2.0, 0.0), (9.0, 2.0, 0.0)) is None     # outside the part
    True
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy import fft as sp_fft

from kbplanner.world.cspace_fft import kernel_hits, kernel_set
from kbplanner.world.footprint import ConfigurationSpace, Footprint
from kbplanner.world.occupancy import OccupancyGrid

Pose = tuple[float, float, float]


def part_region(grid: OccupancyGrid, points: list[tuple[float, float]], margin_cells: int
                ) -> tuple[int, int, int, int]:
    """(y0, y1, x0, x1): the cells of ``grid`` around ``points`` grown by ``margin_cells``, clipped."""
    ny, nx = grid.shape
    cells = [grid.cell_of(x, y) for x, y in points]
    ys, xs = [c[1] for c in cells], [c[0] for c in cells]
    return (max(0, min(ys) - margin_cells), min(ny, max(ys) + margin_cells + 1),
            max(0, min(xs) - margin_cells), min(nx, max(xs) + margin_cells + 1))


class PartJoin:
    """The components of ``footprint``'s configuration space on the part of ``grid`` around ``points``
    (module docstring): ``joined(a, b)`` is True, False, or None where the part does not decide.
    ``region`` (y0, y1, x0, x1), when given, is the part instead (that of another footprint's part).
    """

    def __init__(self, grid: OccupancyGrid, footprint: Footprint, points: list[tuple[float, float]], *,
                 margin_cells: int, diagonal: bool, n_bins: int = 72,
                 region: tuple[int, int, int, int] | None = None) -> None:
        self.grid = grid
        ny, nx = grid.shape
        if region is None:
            region = part_region(grid, points, margin_cells)
        self.region = self.y0, self.y1, self.x0, self.x1 = region
        self.n_bins = n_bins
        self.labels: npt.NDArray[np.int32] | None = None
        self.roots: npt.NDArray[np.int64] | None = None
        self.rim: frozenset[int] = frozenset()  # components with a cell on the rim
        if self.y0 >= self.y1 or self.x0 >= self.x1:
            return  # every point off the grid
        sy, sx = self.y1 - self.y0, self.x1 - self.x0
        box = np.zeros((n_bins, sy + 2, sx + 2), dtype=bool)  # a blocked cell all round
        box[:, 1:-1, 1:-1] = part_free(grid, footprint, region, n_bins)
        sub = ConfigurationSpace(grid=grid, footprint=footprint, free=box)
        labels, roots = sub._labels_and_roots(diagonal)
        self.labels, self.roots = labels[:, 1:-1, 1:-1], roots
        rim = np.zeros((sy, sx), dtype=bool)  # the part's cells next to grid cells outside it
        if self.y0 > 0:
            rim[0, :] = True
        if self.y1 < ny:
            rim[-1, :] = True
        if self.x0 > 0:
            rim[:, 0] = True
        if self.x1 < nx:
            rim[:, -1] = True
        on_rim = np.unique(self.labels[:, rim])
        self.rim = frozenset(int(r) for r in np.unique(roots[on_rim[on_rim > 0]]))

    def holds(self, pose: Pose) -> bool:
        """Whether the pose's cell lies in the part."""
        ix, iy = self.grid.cell_of(pose[0], pose[1])
        return self.y0 <= iy < self.y1 and self.x0 <= ix < self.x1

    def component(self, pose: Pose) -> int:
        """The pose's component in the part (0: blocked); the pose must lie in it (:meth:`holds`)."""
        assert self.labels is not None and self.roots is not None
        ix, iy = self.grid.cell_of(pose[0], pose[1])
        w = 2 * math.pi / self.n_bins
        k = math.floor((pose[2] + w / 2) / w) % self.n_bins  # ConfigurationSpace.yaw_bin
        return int(self.roots[self.labels[k, iy - self.y0, ix - self.x0]])

    def joined(self, a: Pose, b: Pose) -> bool | None:
        """True/False as ``joined`` on the whole grid's space, or None where the part does not decide
        (a pose outside the part, or both components reaching its rim in different components)."""
        if self.labels is None or not (self.holds(a) and self.holds(b)):
            return None
        ca, cb = self.component(a), self.component(b)
        if ca == 0 or cb == 0:
            return False  # blocked on the grid too
        if ca == cb:
            return True
        if ca not in self.rim or cb not in self.rim:
            return False  # one of them is the same component on the grid
        return None


def part_free(grid: OccupancyGrid, footprint: Footprint, region: tuple[int, int, int, int],
              n_bins: int = 72) -> npt.NDArray[np.bool_]:
    """The free maps of ``footprint`` on the cells ``region`` (y0, y1, x0, x1) of ``grid``: (n_bins, y1 -
    y0, x1 - x0), what :meth:`~kbplanner.world.footprint.ConfigurationSpace.build` on the whole grid gives
    there (cells off the grid occupied; the same kernels, a cell free where fewer than 0.5 occupied cells
    lie under its bin's kernel, counted by FFT in float32: integers far from 0.5).

    The correlation runs on the region grown by the kernels' reach only, the real cells around it: a
    build on a grid around the region (:func:`~kbplanner.world.cspace_cache.configuration_space`) pads
    that grid by the reach again and computes its free maps in the band the region is grown by, which
    the part throws away (about 30 % more transform work on B4's parts, and a copy kept). The kernels are
    the build's (:func:`~kbplanner.world.cspace_fft.kernel_set`: each distinct one once, turned half a
    turn), transformed as the build does (:func:`~kbplanner.world.cspace_fft.kernel_hits`: each kernel
    centred on cell 0, those turned over from another read off its transform), keeping the rows and
    columns ``h ..`` of the grown region.
    """
    y0, y1, x0, x1 = region
    sy, sx = y1 - y0, x1 - x0
    kset = kernel_set(footprint.rects, float(grid.resolution), int(n_bins), 0.0)
    h = kset.h
    ny, nx = grid.shape
    occ = np.ones((sy + 2 * h, sx + 2 * h), dtype=np.float32)
    gy0, gy1, gx0, gx1 = max(0, y0 - h), min(ny, y1 + h), max(0, x0 - h), min(nx, x1 + h)
    occ[gy0 - (y0 - h):gy1 - (y0 - h), gx0 - (x0 - h):gx1 - (x0 - h)] = grid.occupied[gy0:gy1, gx0:gx1]
    # A circular correlation at least as long as the grown region keeps every wrapped-around term out
    # of the cells kept: rows and columns h .. h + size - 1 of the correlation with the centred kernel.
    shape = (sp_fft.next_fast_len(sy + 2 * h, real=True), sp_fft.next_fast_len(sx + 2 * h, real=True))
    occ_f = sp_fft.fft(sp_fft.rfft(occ, n=shape[1], axis=1), n=shape[0], axis=0, overwrite_x=True)
    free = np.empty((n_bins, sy, sx), dtype=bool)
    for j, hits in kernel_hits(occ_f, kset, shape, (h, sy), (h, sx)):
        np.less(hits, 0.5, out=free[kset.first[j]])
    for k, j in enumerate(kset.index):  # a kernel met before: the same free map
        if kset.first[j] != k:
            free[k] = free[kset.first[j]]
    return free
