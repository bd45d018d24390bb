"""Navigation (B5), the cell path: where OMPL finds no path within its budget although free cells
certainly join start and goal, a path through face-adjacent free configuration cells.

Takes a :class:`~kbplanner.world.footprint.ConfigurationSpace` and start and goal poses;
:func:`face_connected` says whether face-adjacent free (x, y, yaw bin) cells join them (asked by the
OMPL query of :mod:`kbplanner.simulation.navigation` once RRTConnect has used its first budget),
:func:`face_path` finds such cells by breadth-first search (:func:`bfs_cells`), and :func:`cell_route`
shortens them with exact motion checks into a :class:`~kbplanner.simulation.nav_path.NavPath` (kept per
read-only space and query: the cell path does not depend on the planner's seed).
"""

from __future__ import annotations

import time
import weakref

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.motion_check import ExactMotion, shortcut
from kbplanner.simulation.nav_path import OK, NavPath, NavSettings, Pose2D, failed_path, path_length, wrap
from kbplanner.simulation.turn_around import skid_steer
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

    The path of a breadth-first search from ``src`` in which each cell is reached from the first cell
    of the previous layer (in the order cells were reached) that has it as a neighbour, the neighbours
    taken in the order +x, +y, +bin, -bin, -y, -x (with the wrap from the last bin to the first one
    before them and from the first bin to the last one after them): the order in
    which scipy's ``breadth_first_order`` on the undirected graph of these cells, indexed in array
    order, visits them, so the path is the one that search gives.

    That path is, of all shortest paths, the one whose steps, ranked in that order, come first
    lexicographically (each cell's place in the search is its parent's place, then its step's rank).
    So it is found without ordering the search: layers of distance to ``dst`` (vectorised, from
    ``dst`` until ``src`` is reached; ``src`` counts as free), then a walk from ``src`` that takes at
    each cell the first-ranked step to a cell one layer nearer. The same answers as the ordered search
    (tests/test_sim_speedups.py, against scipy), several times faster.
    """
    nb, ny, nx = free.shape
    s = (src[0] * ny + src[1]) * nx + src[2]
    d = (dst[0] * ny + dst[1]) * nx + dst[2]
    if s == d:
        return [s]
    if not free.ravel()[d]:
        return None  # a blocked cell is never reached
    # a blocked border round each plane: a step in x or y never leaves its plane
    nyp, nxp = ny + 2, nx + 2
    planep = nyp * nxp
    padded = np.zeros((nb, nyp, nxp), dtype=bool)
    padded[:, 1:-1, 1:-1] = free
    open_ = padded.ravel()  # free and not reached yet
    sp = (src[0] * nyp + src[1] + 1) * nxp + src[2] + 1
    dp = (dst[0] * nyp + dst[1] + 1) * nxp + dst[2] + 1
    open_[sp] = True  # the search from the start leaves it even where it is blocked
    open_[dp] = False
    # each reached cell's layer + 1 (0: not reached); zeros, not a fill, so that only the pages of the
    # cells reached are ever written (a window's array is tens of megabytes)
    layer_of = np.zeros(open_.size, dtype=np.int32)
    layer_of[dp] = 1
    frontier = np.array([dp], dtype=np.int64)
    span = nb * planep
    layer = 0
    while open_[sp]:
        layer += 1
        b = frontier // planep
        up = frontier + planep
        up[b == nb - 1] -= span
        down = frontier - planep
        down[b == 0] += span
        parts = []
        for cand in (frontier + 1, frontier - 1, frontier + nxp, frontier - nxp, up, down):
            cand = cand[open_[cand]]  # one step is one-to-one: no cell twice within a part
            open_[cand] = False  # nor in a later part
            parts.append(cand)
        frontier = np.concatenate(parts)
        if frontier.size == 0:
            return None
        layer_of[frontier] = layer + 1
    wrap_span = (nb - 1) * planep
    nodes = [s]
    here = sp
    for nearer in range(layer - 1, -1, -1):
        b = here // planep
        for step in (-wrap_span if b == nb - 1 else 0, 1, nxp, planep if b < nb - 1 else 0,
                     -planep if b > 0 else 0, -nxp, -1, wrap_span if b == 0 else 0):
            if step and layer_of[here + step] == nearer + 1:
                here += step
                break
        else:  # pragma: no cover - a cell of layer k > 0 always has a neighbour in layer k - 1
            raise AssertionError("breadth-first layers without a step nearer")
        k, rest = divmod(here, planep)
        y, x = divmod(rest, nxp)
        nodes.append((k * ny + y - 1) * nx + x - 1)
    return nodes


def cell_route(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, settings: NavSettings, t0: float,
               ompl_reason: str, cells: list[Pose2D] | None = None) -> NavPath | None:
    """The path of :func:`face_path` (or of the given ``cells``, e.g. a corridor's), shortened by exact
    motion checks (OMPL found none in its budget or was not tried); None where no face-adjacent free cells
    join start and goal.

    Without ``cells`` the path depends on the space, start, goal and base motion only, not on the seed:
    where the free maps cannot change (read-only, those of the space cache) it is kept per space and query,
    so a leg planned again with other seeds (:mod:`kbplanner.simulation.skills.navigation`) that again ends
    on the cell path takes it without searching again.
    """
    if cells is not None:
        got: _CellPoses = _poses_of_cells(cs, start, goal, settings, cells)
    else:
        key = (float(cs.grid.origin[0]), float(cs.grid.origin[1]), float(cs.grid.resolution),
               tuple(start), tuple(goal), settings.base_motion, settings.allow_reverse,
               settings.base_limits, settings.reverse_s_per_m)
        kept = _kept_routes(cs)
        found = kept.get(key) if kept is not None else None
        if found is None:
            found = _cell_poses(cs, start, goal, settings)
            if kept is not None:
                kept[key] = found
        got = found
    planner, name = settings.planner, cs.footprint.name
    if got == "none":
        return None
    if isinstance(got, str):  # "blocked"
        return failed_path(f"{ompl_reason}; the cell path failed the exact check", planner, name,
                           time.perf_counter() - t0)
    poses, kept_mixed = got
    how = f"cell search over free configuration cells (RRTConnect: {ompl_reason})"
    if kept_mixed is not None:
        how += "; turn-drive-turn" + (f" ({kept_mixed} segment(s) partly turning while driving)"
                                      if kept_mixed else "")
    return NavPath(poses=poses, length_m=path_length(poses), planning_time_s=time.perf_counter() - t0,
                   planner=f"{planner}+cells", status=OK, reason=how, footprint=name)


_CellPoses = tuple[tuple[Pose2D, ...], int | None] | str
# Per read-only free map (by id, dropped with the map): cell paths by (origin, resolution, start, goal,
# base motion, reversing, the base's limits).
_ROUTES: dict[int, dict[tuple[object, ...], _CellPoses]] = {}


def _kept_routes(cs: ConfigurationSpace) -> dict[tuple[object, ...], _CellPoses] | None:
    free = cs.free
    if free.flags.writeable:
        return None  # the maps may still change
    got = _ROUTES.get(id(free))
    if got is None:
        got = _ROUTES[id(free)] = {}
        weakref.finalize(free, _ROUTES.pop, id(free), None)
    return got


def _cell_poses(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, settings: NavSettings) -> _CellPoses:
    """:func:`cell_route`'s waypoints and its count of segments partly turning while driving (None
    without turn-drive-turn); ``"none"`` without face-joined cells, ``"blocked"`` where the cell path
    fails the exact check."""
    cells = face_path(cs, start, goal)
    if cells is None:
        return "none"
    return _poses_of_cells(cs, start, goal, settings, cells)


def _poses_of_cells(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, settings: NavSettings,
                    cells: list[Pose2D]) -> _CellPoses:
    """The waypoints through ``cells`` shortened by exact motion checks (see :func:`_cell_poses`)."""
    motion = ExactMotion(cs)
    poses: list[Pose2D] = [(start[0], start[1], wrap(start[2])), *cells, (goal[0], goal[1], wrap(goal[2]))]
    if not motion.path_free(poses):
        return "blocked"
    poses = shortcut(motion, poses, cs.grid.resolution * 5)
    mixed: int | None = None
    if settings.base_motion == "turn_drive_turn":
        poses, mixed = skid_steer(cs, poses, allow_reverse=settings.allow_reverse,
                                  limits=settings.base_limits, reverse_s_per_m=settings.reverse_s_per_m)
    return tuple(poses), mixed
