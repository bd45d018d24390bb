"""Navigation (B5), the cell path: where OMPL finds no path within its budget although free cells
certainly join start and goal, a path through face-adjacent free configuration cells.

Takes a :class:`~kbplanner.world.footprint.ConfigurationSpace` and start and goal poses;
:func:`face_connected` says whether face-adjacent free (x, y, yaw bin) cells join them (asked by the
OMPL query of :mod:`kbplanner.simulation.navigation` once RRTConnect has used its first budget),
:func:`face_path` finds such cells by breadth-first search (:func:`bfs_cells`), and :func:`cell_route`
shortens them with exact motion checks into a :class:`~kbplanner.simulation.nav_path.NavPath`.
"""

from __future__ import annotations

import time

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.motion_check import ExactMotion, shortcut, turn_drive_turn
from kbplanner.simulation.nav_path import OK, NavPath, NavSettings, Pose2D, failed_path, path_length, wrap
from kbplanner.world.footprint import ConfigurationSpace


def face_connected(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> bool:
    """Whether face-adjacent free cells of (x, y, yaw bin) join start and goal (see :func:`face_path`)."""
    return cs.joined(start, goal, diagonal=False)


def face_path(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> list[Pose2D] | None:
    """A path through face-adjacent free cells of (x, y, yaw bin) from start to goal, or None.

    Every pose in a free cell is free (the configuration space is conservative), so moving between
    face-adjacent free cells is a collision-free motion: when this finds a path, a path certainly
    exists. Breadth-first search from the start's cell (:func:`bfs_cells`); the yaw axis wraps.
    Returns the cell centres (yaw at the bin centre).
    """
    g = cs.grid
    ends = []
    for p in (start, goal):
        ix, iy = g.cell_of(p[0], p[1])
        if not (0 <= ix < g.shape[1] and 0 <= iy < g.shape[0]):
            return None
        ends.append((cs.yaw_bin(p[2]), iy, ix))
    if not (cs.free[ends[0]] and cs.free[ends[1]]):
        return None
    nodes = bfs_cells(cs.free, ends[0], ends[1])
    if nodes is None:
        return None
    cell = np.asarray(np.unravel_index(np.asarray(nodes, dtype=np.int64), cs.free.shape), dtype=np.int64).T
    res, (ox, oy), w = g.resolution, g.origin, cs.bin_width
    return [(ox + (float(x) + 0.5) * res, oy + (float(y) + 0.5) * res, wrap(float(b) * w))
            for b, y, x in cell.tolist()]


def bfs_cells(free: npt.NDArray[np.bool_], src: tuple[int, int, int], dst: tuple[int, int, int]
              ) -> list[int] | None:
    """Breadth-first search over face-adjacent free cells of ``free[bin, y, x]`` (the bin axis wraps):
    the flat indices of the cells from ``src`` to ``dst``, or None when they are not joined.

    Layer by layer, vectorised, stopping when ``dst`` is reached. Each cell is reached from the first
    cell of the previous layer (in the order cells were reached) that has it as a neighbour, the
    neighbours taken in the order +x, +y, +bin, -bin, -y, -x (with the wrap from the last bin to the
    first one before them, and from the first bin to the last one after them): the order in which
    scipy's ``breadth_first_order`` on the undirected graph of these cells, indexed in array order,
    visits them, so the path is the one that search gives.
    """
    nb, ny, nx = free.shape
    plane = ny * nx
    flat = free.ravel()
    s = (src[0] * ny + src[1]) * nx + src[2]
    d = (dst[0] * ny + dst[1]) * nx + dst[2]
    if s == d:
        return [s]
    if not flat[d]:
        return None  # a blocked cell is never reached
    parent = np.full(flat.size, -1, dtype=np.int32 if flat.size < 2**31 else np.int64)
    open_ = np.append(flat, False)  # free and not reached yet; the last entry, at index -1: "no neighbour"
    open_[s] = False
    frontier = np.array([s], dtype=np.int64)
    wrap_span = (nb - 1) * plane
    unset = np.iinfo(np.int32).max
    earliest = np.full(flat.size, unset, dtype=np.int32)  # per cell, its first place among the candidates
    while frontier.size and open_[d]:
        b = frontier // plane
        rem = frontier - b * plane
        y = rem // nx
        x = rem - y * nx
        cand = np.full((8, frontier.size), -1, dtype=np.int64)
        for row, (mask, step) in enumerate(((b == nb - 1, -wrap_span), (x < nx - 1, 1), (y < ny - 1, nx),
                                            (b < nb - 1, plane), (b > 0, -plane), (y > 0, -nx),
                                            (x > 0, -1), (b == 0, wrap_span))):
            cand[row, mask] = frontier[mask] + step
        order = cand.T.ravel()  # cell by cell in queue order, each cell's neighbours in order
        at = np.flatnonzero(open_[order])
        order = order[at]
        # Each new cell once, at its first place (np.unique's first occurrences, without sorting).
        place = np.arange(order.size, dtype=np.int32)
        np.minimum.at(earliest, order, place)
        first = np.flatnonzero(earliest[order] == place)
        earliest[order] = unset
        new = order[first]
        parent[new] = frontier[at[first] // 8]
        open_[new] = False
        frontier = new
    if open_[d]:
        return None
    nodes = [d]
    while nodes[-1] != s:
        nodes.append(int(parent[nodes[-1]]))
    return nodes[::-1]


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
