"""Navigation (B5, NV-2), the narrow-passage test: whether a carry leg must pass where the carried load
fits at only a few headings, which RRTConnect's uniform samples rarely hit and the cell route handles.

Takes a :class:`~kbplanner.world.footprint.ConfigurationSpace` (the normal carry's footprint on the
planning window) and start and goal poses; :func:`narrow_passage` says whether every route of
8-connected cells from start to goal (cells where the footprint fits at some heading, those within
``end_radius_m`` of start and goal left out of the question) crosses a cell where the footprint fits at
fewer than ``max_deg`` of headings: a narrow passage in the configuration space. It answers from the
free maps of the space alone (two 2-D labellings of the per-cell count of free yaw bins, a few
milliseconds), before any planner runs. :func:`kbplanner.simulation.carry_paths.plan_with_carry_modes`
asks it (``NavSettings.carry_cells_first``) to take the cell route without RRTConnect's doomed or
costly attempt (docs/scale.md "Session 9: carryroute").
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.nav_path import Pose2D
from kbplanner.world.footprint import ConfigurationSpace

NARROW_PASSAGE_DEG = 45.0  # a passage where the footprint fits at fewer headings than this is narrow
END_RADIUS_M = 0.5  # start and goal are left out of the question within this radius


def heading_counts(cs: ConfigurationSpace) -> npt.NDArray[np.int16]:
    """Per cell (iy, ix), at how many yaw bins the footprint is free."""
    return np.asarray(cs.free.sum(axis=0, dtype=np.int16))


def narrow_passage(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, max_deg: float = NARROW_PASSAGE_DEG,
                   end_radius_m: float = END_RADIUS_M) -> bool:
    """Whether start and goal are joined by 8-connected cells where the footprint fits at some heading,
    but only through a cell where it fits at fewer than ``max_deg`` of headings (the cells within
    ``end_radius_m`` of start and goal count as wide). False when they are not joined at all (or an
    end is off the map or blocked at every heading): the planners say so then."""
    from scipy import ndimage

    g = cs.grid
    ny, nx = g.shape
    counts = heading_counts(cs)
    ends: list[tuple[int, int]] = []
    for p in (start, goal):
        ix, iy = g.cell_of(p[0], p[1])
        if not (0 <= ix < nx and 0 <= iy < ny) or counts[iy, ix] == 0:
            return False
        ends.append((iy, ix))
    wide_at = max(1, int(np.ceil(max_deg / 360.0 * cs.n_bins)))
    wide = counts >= wide_at
    r = end_radius_m / g.resolution
    reach = int(np.ceil(r))
    for iy, ix in ends:  # the ends' discs: wide where the footprint fits at all
        y0, y1 = max(0, iy - reach), min(ny, iy + reach + 1)
        x0, x1 = max(0, ix - reach), min(nx, ix + reach + 1)
        yy, xx = np.ogrid[y0:y1, x0:x1]
        disc = (yy - iy) ** 2 + (xx - ix) ** 2 <= r * r
        wide[y0:y1, x0:x1] |= disc & (counts[y0:y1, x0:x1] > 0)
    eight = np.ones((3, 3), dtype=bool)

    def joined(cells: npt.NDArray[np.bool_]) -> bool:
        labels, _ = ndimage.label(cells, structure=eight)
        a, b = labels[ends[0]], labels[ends[1]]
        return bool(a != 0 and a == b)

    if joined(wide):
        return False
    return joined(counts > 0)
