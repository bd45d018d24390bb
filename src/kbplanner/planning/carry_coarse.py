"""B4, the carry leg: joins proven on merged yaw bins, before any part of a window is built at 72 bins.

The carry-leg check (:mod:`kbplanner.planning.carry_reach`) asks whether the robot holding an element
joins two poses in the configuration space of a window (26-connected, the yaw axis a ring), with one
carry footprint or switching between both where both fit (joint components,
:func:`~kbplanner.planning.carry_parts.joint_components`). Most answers are "joined"; proving it on a
part of the window (:class:`~kbplanner.world.cspace_join.PartJoin`) builds and labels 72 yaw bins.

:class:`CoarseJoin` proves it on :data:`GROUP` yaw bins merged into one (a cell free in the merged bin
only where the footprint is free in each of its bins, :func:`~kbplanner.world.cspace_join.grouped_free`):
a sixth of the correlations and of the cells to label. Merged cells are joined on the window whenever
they are joined here: every bin of a free merged cell is free, consecutive bins of one cell are
neighbours, and neighbouring merged cells hold neighbouring bins; a merged cell free for both footprints
is a place to switch. A pose reaches the merged cells next to its own cell and bin (the 26 neighbours),
and where that does not join it, those its component reaches on a small box of cells around it at the
72 bins (:data:`BOX_CELLS`; the pick base pose often fits only a few bins). So ``joined`` answers True
(the window's answer) or None: not proven here, the caller asks the parts and the window as before.
The answers, and so the plans, are the same; only the cost changes.

Example:
    >>> import numpy as np
    >>> from kbplanner.world.footprint import Footprint, Rect
    >>> from kbplanner.world.occupancy import OccupancyGrid
    >>> occ = np.zeros((80, 200), dtype=bool); occ[:, 100] = True; occ[25:55, 100] = False  # a door
    >>> grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
    >>> fp = Footprint((Rect(0, 0, 0.4, 0.3),))
    >>> free = lambda k, pose: True  # the caller's exact test of each pose (both are free here)
    >>> join = CoarseJoin(grid, (fp,), [(4.0, 2.0), (6.0, 2.0)], margin_cells=25, free_at=free, n_bins=24)
    >>> join.joined((4.0, 2.0, 0.0), (6.0, 2.0, 0.0))     # through the door
    True
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from kbplanner.planning.carry_parts import joint_components
from kbplanner.world.cspace_join import grouped_free, part_region, ring_labels
from kbplanner.world.footprint import Footprint
from kbplanner.world.occupancy import OccupancyGrid

Pose = tuple[float, float, float]

#: Yaw bins merged into one (72 bins: 12 merged bins of 30 degrees).
GROUP = 6
#: Half-size (cells) of the box around a pose labelled at every yaw bin when its neighbours do not
#: reach a merged cell that joins.
BOX_CELLS = 10
_NEIGHBOURS = np.array([(db, dy, dx) for db in (-1, 0, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)],
                       dtype=np.int64)


class CoarseJoin:
    """Merged-bin components of ``footprints`` on the part of ``grid`` around ``points`` grown by
    ``margin_cells`` (module docstring); with several footprints, joined where a merged cell is free
    for two. ``free_at(k, pose)``: whether footprint ``k`` is free at the pose on ``grid`` (the exact
    test, :class:`~kbplanner.planning.base_poses.PoseChecker`)."""

    def __init__(self, grid: OccupancyGrid, footprints: Sequence[Footprint],
                 points: list[tuple[float, float]], *, margin_cells: int,
                 free_at: Callable[[int, Pose], bool], n_bins: int = 72,
                 group: int = GROUP, box_cells: int = BOX_CELLS) -> None:
        self.grid = grid
        self.footprints = tuple(footprints)
        self.free_at = free_at
        self.n_bins = n_bins
        self.group = group
        self.box_cells = box_cells
        self.region = self.y0, self.y1, self.x0, self.x1 = part_region(grid, points, margin_cells)
        self.layers: list[tuple[npt.NDArray[np.bool_], npt.NDArray[np.int32], npt.NDArray[np.int64]]] = []
        self.offsets: tuple[int, ...] = (0,)
        self.joint: npt.NDArray[np.int64] | None = None
        self._near: dict[tuple[int, int, int, int, bool], frozenset[int]] = {}
        if self.y0 >= self.y1 or self.x0 >= self.x1:
            return  # every point off the grid
        for fp in self.footprints:
            free = grouped_free(grid, fp, self.region, group, n_bins)
            labels, roots = ring_labels(free)
            self.layers.append((free, labels, roots))
        if len(self.layers) > 1:
            self.offsets, self.joint = joint_components([(lab, roots) for _f, lab, roots in self.layers])

    def holds(self, pose: Pose) -> bool:
        """Whether the pose's cell lies in the part."""
        ix, iy = self.grid.cell_of(pose[0], pose[1])
        return self.y0 <= iy < self.y1 and self.x0 <= ix < self.x1

    def joined(self, a: Pose, b: Pose) -> bool | None:
        """True when ``a`` and ``b`` are proven joined (then they are on the grid's space, with these
        footprints), else None."""
        if not self.layers or not (self.holds(a) and self.holds(b)):
            return None
        for boxed in (False, True):
            if self._reached(a, boxed) & self._reached(b, boxed):
                return True
        return None

    def _cell(self, pose: Pose) -> tuple[int, int, int]:
        """(bin, iy, ix) of a pose on the grid (the configuration space's bins)."""
        ix, iy = self.grid.cell_of(pose[0], pose[1])
        w = 2 * math.pi / self.n_bins
        return math.floor((pose[2] + w / 2) / w) % self.n_bins, iy, ix

    def _reached(self, pose: Pose, boxed: bool) -> frozenset[int]:
        """The (joint) merged components the pose reaches: from its neighbours, and with ``boxed`` also
        through its component on the box around it (kept per footprint and cell)."""
        b, iy, ix = self._cell(pose)
        out: set[int] = set()
        for k in range(len(self.layers)):
            key = (k, b, iy, ix, boxed)
            got = self._near.get(key)
            if got is None:
                got = frozenset()
                if self.free_at(k, pose):
                    got = self._near_cells(k, b, iy, ix) if not boxed else self._box_cells(k, b, iy, ix)
                self._near[key] = got
            out |= got
        return frozenset(out)

    def _components(self, k: int, cells: npt.NDArray[np.int64]) -> frozenset[int]:
        """The joint components of footprint ``k``'s free merged cells among ``cells`` (bin, iy, ix) of
        the grid's fine bins (those off the part are left out)."""
        bb, yy, xx = cells[:, 0] % self.n_bins, cells[:, 1] - self.y0, cells[:, 2] - self.x0
        on = (yy >= 0) & (yy < self.y1 - self.y0) & (xx >= 0) & (xx < self.x1 - self.x0)
        free, labels, roots = self.layers[k]
        jj, yy, xx = bb[on] // self.group, yy[on], xx[on]
        ok = free[jj, yy, xx]
        comps = np.unique(roots[labels[jj[ok], yy[ok], xx[ok]]])
        if self.joint is not None:
            comps = self.joint[self.offsets[k] + comps]
        return frozenset(int(c) for c in comps)

    def _near_cells(self, k: int, b: int, iy: int, ix: int) -> frozenset[int]:
        """Merged components holding a fine cell next to the (free) pose cell, or the cell itself."""
        return self._components(k, _NEIGHBOURS + np.array([b, iy, ix], dtype=np.int64))

    def _box_cells(self, k: int, b: int, iy: int, ix: int) -> frozenset[int]:
        """Merged components holding a fine cell of the pose's component on the box around it."""
        region = part_region(self.grid, [self.grid.center_of(ix, iy)], self.box_cells)
        free = grouped_free(self.grid, self.footprints[k], region, 1, self.n_bins)
        labels, roots = ring_labels(free)
        mine = roots[labels[b, iy - region[0], ix - region[2]]]
        if not mine:
            return frozenset()
        cells = np.argwhere(roots[labels] == mine)
        cells[:, 1] += region[0]
        cells[:, 2] += region[2]
        return self._components(k, cells)
