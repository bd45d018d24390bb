"""Navigation (B5), the cell path: where OMPL finds no path within its budget although free cells
certainly join start and goal, a path through face-adjacent free configuration cells.

Takes a :class:`~kbplanner.world.footprint.ConfigurationSpace` and start and goal poses;
:func:`face_connected` says whether face-adjacent free (x, y, yaw bin) cells join them (asked by the
OMPL query of :mod:`kbplanner.simulation.navigation` once RRTConnect has used its first budget),
:func:`face_path` finds such cells by breadth-first search, and :func:`cell_route` shortens them with
exact motion checks into a :class:`~kbplanner.simulation.nav_path.NavPath`.
"""

from __future__ import annotations

import time

import numpy as np

from kbplanner.simulation.motion_check import ExactMotion, shortcut, turn_drive_turn
from kbplanner.simulation.nav_path import OK, NavPath, NavSettings, Pose2D, failed_path, path_length, wrap
from kbplanner.world.footprint import ConfigurationSpace


def face_connected(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> bool:
    """Whether face-adjacent free cells of (x, y, yaw bin) join start and goal (see :func:`face_path`)."""
    a, b = cs.components_of([start, goal], diagonal=False)
    return a > 0 and a == b


def face_path(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> list[Pose2D] | None:
    """A path through face-adjacent free cells of (x, y, yaw bin) from start to goal, or None.

    Every pose in a free cell is free (the configuration space is conservative), so moving between
    face-adjacent free cells is a collision-free motion: when this finds a path, a path certainly
    exists. Breadth-first search (scipy) over the free cells of the start's component; the yaw axis
    wraps. Returns the cell centres (yaw at the bin centre).
    """
    from scipy import sparse
    from scipy.sparse import csgraph

    g = cs.grid
    ends = []
    for p in (start, goal):
        ix, iy = g.cell_of(p[0], p[1])
        if not (0 <= ix < g.shape[1] and 0 <= iy < g.shape[0]):
            return None
        ends.append((cs.yaw_bin(p[2]), iy, ix))
    if not (cs.free[ends[0]] and cs.free[ends[1]]):
        return None
    index = np.full(cs.free.shape, -1, dtype=np.int64)
    flat = np.flatnonzero(cs.free)
    index.ravel()[flat] = np.arange(len(flat))
    rows, cols = [], []
    for a, b in ((index[:, :, :-1], index[:, :, 1:]), (index[:, :-1, :], index[:, 1:, :]),
                 (index[:-1], index[1:]), (index[-1:], index[:1])):
        both = (a >= 0) & (b >= 0)
        rows.append(a[both])
        cols.append(b[both])
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = sparse.csr_matrix((np.ones(len(r), dtype=np.int8), (r, c)), shape=(len(flat), len(flat)))
    src, dst = int(index[ends[0]]), int(index[ends[1]])
    _order, pred = csgraph.breadth_first_order(graph, src, directed=False, return_predecessors=True)
    if src != dst and pred[dst] < 0:
        return None
    nodes = [dst]
    while nodes[-1] != src:
        nodes.append(int(pred[nodes[-1]]))
    cell = np.asarray(np.unravel_index(flat[nodes[::-1]], cs.free.shape), dtype=np.int64).T
    res, (ox, oy), w = g.resolution, g.origin, cs.bin_width
    return [(ox + (float(x) + 0.5) * res, oy + (float(y) + 0.5) * res, wrap(float(b) * w))
            for b, y, x in cell.tolist()]


def cell_route(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, cells: list[Pose2D],
                settings: NavSettings, t0: float, ompl_reason: str) -> NavPath:
    """The path of :func:`face_path`, shortened by exact motion checks (OMPL found none in its budget)."""
    motion = ExactMotion(cs)
    poses: list[Pose2D] = [(start[0], start[1], wrap(start[2])), *cells, (goal[0], goal[1], wrap(goal[2]))]
    if not motion.path_free(poses):
        return failed_path(f"{ompl_reason}; the cell path failed the exact check", settings.planner,
                       cs.footprint.name, time.perf_counter() - t0)
    poses = shortcut(motion, poses, cs.grid.resolution * 5)
    how = f"cell search over free configuration cells (RRTConnect: {ompl_reason})"
    if settings.base_motion == "turn_drive_turn":
        poses, kept = turn_drive_turn(cs, poses, allow_reverse=settings.allow_reverse)
        how += "; turn-drive-turn" + (f" ({kept} segment(s) partly turning while driving)" if kept else "")
    return NavPath(poses=tuple(poses), length_m=path_length(poses), planning_time_s=time.perf_counter() - t0,
                   planner=f"{settings.planner}+cells", status=OK, reason=how, footprint=cs.footprint.name)
