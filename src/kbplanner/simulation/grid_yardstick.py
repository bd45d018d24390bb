"""Navigation (B5), the yardstick for path quality: the grid shortest path length for a footprint.

Takes an occupancy grid (or a configuration space), start and goal; :func:`grid_shortest_path_length`
is 8-connected Dijkstra over the cells where the footprint fits at some yaw, then line-of-sight
shortcutting: a slightly optimistic length to compare planned paths with (benchmarks and tests).
"""

from __future__ import annotations

import functools
import math
import weakref
from typing import Any

import numpy as np
import numpy.typing as npt

from kbplanner.core.errors import KbplannerError
from kbplanner.simulation import cell_store
from kbplanner.simulation.nav_path import Pose2D
from kbplanner.world.cspace_cache import configuration_space
from kbplanner.world.footprint import ConfigurationSpace, Footprint
from kbplanner.world.occupancy import OccupancyGrid


def _dijkstra_cells(
    free: npt.NDArray[np.bool_], s: tuple[int, int], t: tuple[int, int],
    graph_of: tuple[npt.NDArray[np.int32], Any] | None = None,
) -> list[tuple[int, int]] | None:
    """Cells (iy, ix) of a shortest 8-connected path over ``free`` from ``s`` to ``t`` (scipy's
    Dijkstra; steps cost 1 or sqrt 2 cells), or None. ``graph_of``: :func:`_graph` of ``free``, when
    known."""
    from scipy.sparse import csgraph

    index, graph = graph_of if graph_of is not None else _graph(free)
    src, dst = int(index[s]), int(index[t])
    # directed over both directions' edges: the search of the undirected one (see _graph)
    dist, pred = csgraph.dijkstra(graph, directed=True, indices=src, return_predecessors=True)
    if not math.isfinite(float(dist[dst])):
        return None
    out = [dst]
    while out[-1] != src:
        out.append(int(pred[out[-1]]))
    out.reverse()
    flat = np.flatnonzero(free)
    nx = free.shape[1]
    return [(int(flat[k]) // nx, int(flat[k]) % nx) for k in out]


# the steps of a cell's row: to E, SW, S, SE (the half graph's edges, to higher nodes), then NW, N, NE, W
_STEPS = ((0, 1), (1, -1), (1, 0), (1, 1), (-1, -1), (-1, 0), (-1, 1), (0, -1))
_STEP_COSTS = np.array([math.hypot(dy, dx) for dy, dx in _STEPS])


def _graph(free: npt.NDArray[np.bool_]) -> tuple[npt.NDArray[np.int32], Any]:
    """The node of each cell (-1 blocked; free cells numbered in row-major order) and the graph for a
    directed Dijkstra that searches as scipy's undirected one does on the half graph: each free cell's
    row its edges to its free neighbours (y, x+1), (y+1, x-1), (y+1, x), (y+1, x+1) - the half graph's
    row, costs 1 or sqrt 2 - then (y-1, x-1), (y-1, x), (y-1, x+1), (y, x-1) - the row of the half
    graph's transpose, in increasing order as ``graph.T.tocsr()`` has it.

    scipy's undirected Dijkstra scans, for each node it takes from its heap, the node's row of the graph
    and then its row of the transpose (which it builds on every call); on this graph the directed one
    scans the same edges in the same order, so the same distances and predecessors (tested against the
    former half graph's undirected search); the transpose is not built per search, indices are int32 as
    the search wants them (not converted per search)."""
    from scipy import sparse

    ny, nx = free.shape
    w = nx + 2  # a blocked border round the grid: no step leaves it
    at = np.zeros((ny + 2, w), dtype=bool)
    at[1:-1, 1:-1] = free
    at = np.flatnonzero(at)  # the free cells in the bordered grid, in row-major order
    n = len(at)
    pad = np.full((ny + 2, w), -1, dtype=np.int32)
    pad.ravel()[at] = np.arange(n, dtype=np.int32)
    index = pad[1:-1, 1:-1]
    nb = pad.ravel()[at[:, None] + np.array([dy * w + dx for dy, dx in _STEPS])]
    mask = nb >= 0
    indptr = np.zeros(n + 1, dtype=np.int32)
    np.cumsum(mask.sum(axis=1), out=indptr[1:])
    costs = np.broadcast_to(_STEP_COSTS, nb.shape)[mask]
    return index, sparse.csr_matrix((costs, nb[mask], indptr), shape=(n, n))


def grid_shortest_path_length(
    grid: OccupancyGrid | ConfigurationSpace,
    start: Pose2D | tuple[float, float],
    goal: Pose2D | tuple[float, float],
    footprint: Footprint | None = None,
    n_yaw_bins: int = 72,
) -> float:
    """Length (m) of the shortest path for a footprint on the grid; ``inf`` when there is none.

    Dijkstra, 8-connected, over the cells where the footprint fits at some yaw (a relaxation: it
    may turn anywhere), then greedy line-of-sight shortcutting through those cells, which removes
    most of the 8-connected metric's excess (up to 8 %) over straight lines. On a configuration space
    the length is kept with it: asked again for the same start and goal, it is not searched again.
    """
    if isinstance(grid, ConfigurationSpace):
        known = _LENGTHS.setdefault(grid, {})
        key = (tuple(start), tuple(goal))
        if key not in known:
            known[key] = _shortest_length(grid, start, goal)
        return known[key]
    if footprint is None:
        raise KbplannerError("grid_shortest_path_length on a grid needs a footprint",
                             element="grid_shortest_path_length", fix="pass footprint=...")
    # the same free maps as ConfigurationSpace.build(grid, footprint, n_yaw_bins), kept (in the process
    # and, where a folder is given, on disk): the yardstick's windows come back on every run
    return _shortest_length(configuration_space(grid, footprint, n_yaw_bins), start, goal)


def shortest_cells(cs: ConfigurationSpace, start: Pose2D | tuple[float, float],
                   goal: Pose2D | tuple[float, float]) -> list[tuple[int, int]] | None:
    """Cells (iy, ix) of the 8-connected shortest path over the cells where the footprint fits at some
    yaw, from start's cell to goal's (the search :func:`grid_shortest_path_length` shortens), or None."""
    free = _free_any(cs)
    g = cs.grid
    ny, nx = g.shape
    (sx, sy), (gx, gy) = g.cell_of(start[0], start[1]), g.cell_of(goal[0], goal[1])
    if not (0 <= sx < nx and 0 <= sy < ny and 0 <= gx < nx and 0 <= gy < ny):
        return None
    if not (free[sy, sx] and free[gy, gx]):
        return None
    return _cells(cs, (sy, sx), (gy, gx))


def _free_any(cs: ConfigurationSpace) -> npt.NDArray[np.bool_]:
    """``cs.free_any_yaw()``, kept on the space (``path_memo``, shared by the spaces of one free map)."""
    got = cs.path_memo.get("any")
    if got is None:
        got = cs.free_any_yaw()
        got.setflags(write=False)
        cs.path_memo["any"] = got
        cs.path_memo["bytes"] = cs.path_memo.get("bytes", 0) + int(got.nbytes)
    return np.asarray(got)


def _cells(cs: ConfigurationSpace, s: tuple[int, int], t: tuple[int, int]) -> list[tuple[int, int]] | None:
    """:func:`_dijkstra_cells` over :func:`_free_any` of ``cs``, the graph and each (s, t)'s path kept on
    the space: the leg's planner (the carry cell route, :mod:`kbplanner.simulation.corridor_cells`) and
    its yardstick search the same cells; and on disk, where a folder is given
    (:mod:`kbplanner.simulation.cell_store`: a path an earlier run searched over the same map is read)."""
    memo = cs.path_memo
    key = ("cells", s, t)
    if key in memo:
        got: list[tuple[int, int]] | None = memo[key]
        return None if got is None else list(got)
    free = _free_any(cs)
    store_key = _store_key(cs, free)
    if store_key is not None:  # a path an earlier run searched over the same map
        kept, cells = cell_store.lookup(free, s, t, store_key)
        if kept:
            memo[key] = cells
            return None if cells is None else list(cells)
    graph_of = memo.get("graph")
    if graph_of is None:
        graph_of = _graph(free)
        index, graph = graph_of
        memo["graph"] = graph_of
        memo["bytes"] = memo.get("bytes", 0) + int(index.nbytes + graph.data.nbytes + graph.indices.nbytes
                                                   + graph.indptr.nbytes)
    got = _dijkstra_cells(_free_any(cs), s, t, graph_of)
    memo[key] = None if got is None else tuple(got)
    if store_key is not None:
        cell_store.keep(free, s, t, memo[key], store_key)
    return None if got is None else list(got)


def _store_key(cs: ConfigurationSpace, free: npt.NDArray[np.bool_]) -> str | None:
    """:func:`kbplanner.simulation.cell_store.key` of the space's ``free`` (kept on it), None when no
    folder is given."""
    if not cell_store.active():
        return None
    got: str | None = cs.path_memo.get("store_key")
    if got is None:
        got = cs.path_memo["store_key"] = cell_store.key(free)
    return got


# the lengths found in a configuration space (the skills ask again for the leg they planned)
_Ends = tuple[tuple[float, ...], tuple[float, ...]]
_LENGTHS: weakref.WeakKeyDictionary[ConfigurationSpace, dict[_Ends, float]] = weakref.WeakKeyDictionary()


def _shortest_length(cs: ConfigurationSpace, start: Pose2D | tuple[float, float],
                     goal: Pose2D | tuple[float, float]) -> float:
    free = _free_any(cs)
    g = cs.grid
    ny, nx = g.shape
    (sx, sy), (gx, gy) = g.cell_of(start[0], start[1]), g.cell_of(goal[0], goal[1])
    if not (0 <= sx < nx and 0 <= sy < ny and 0 <= gx < nx and 0 <= gy < ny):
        return math.inf
    if not (free[sy, sx] and free[gy, gx]):
        return math.inf
    store_key = _store_key(cs, free)
    ends = (float(start[0]), float(start[1]), float(goal[0]), float(goal[1]), float(g.origin[0]),
            float(g.origin[1]), float(g.resolution))
    if store_key is not None:  # the length an earlier run found (the same map, ends and grid)
        kept = cell_store.lookup_length(free, store_key, ends)
        if kept is not None:
            return kept
    length = _line_of_sight_length(cs, free, (sy, sx), (gy, gx), start, goal)
    if store_key is not None:
        cell_store.keep_length(free, store_key, ends, length)
    return length


def _line_of_sight_length(cs: ConfigurationSpace, free: npt.NDArray[np.bool_], s: tuple[int, int],
                          t: tuple[int, int], start: Pose2D | tuple[float, float],
                          goal: Pose2D | tuple[float, float]) -> float:
    """The grid shortest path from cell ``s`` to ``t`` shortened by line of sight (inf: none)."""
    g = cs.grid
    cells = _cells(cs, s, t)
    if cells is None:
        return math.inf
    pts = [(float(start[0]), float(start[1]))]
    pts += [g.center_of(x, y) for y, x in cells[1:-1]]
    pts.append((float(goal[0]), float(goal[1])))

    length = 0.0
    i = 0
    while i < len(pts) - 1:
        j = _farthest_visible(pts, i, free, g)
        length += math.hypot(pts[j][0] - pts[i][0], pts[j][1] - pts[i][1])
        i = j
    return length


_BATCH = 32  # line-of-sight candidates checked per numpy query
_COARSE = 8  # every this many samples of a line first: a blocked one rules the candidate out


@functools.lru_cache(maxsize=1024)
def _unit_steps(n: int) -> npt.NDArray[np.float64]:
    """``np.linspace(0, 1, n)`` (read only, the same array for the same ``n``)."""
    out = np.linspace(0.0, 1.0, n)
    out.flags.writeable = False
    return out


def _farthest_visible(pts: list[tuple[float, float]], i: int, free: npt.NDArray[np.bool_],
                      g: OccupancyGrid) -> int:
    """The farthest ``j > i`` whose straight line from ``pts[i]`` stays in free cells (sampled every half
    cell), else ``i + 1``: candidates from the last point back, ``_BATCH`` per numpy query.

    Each query first looks at every :data:`_COARSE`-th sample of the candidates' lines (the very same
    sample points): a candidate with one of them blocked is not visible; only the others' lines are
    then sampled in full, and the first of them whose samples are all free is the answer - the same
    answer as sampling every line in full (tests/test_grid_route_searches.py)."""
    ax, ay = pts[i]
    half = g.resolution / 2
    j = len(pts) - 1
    while j > i + 1:
        cands = range(j, max(i + 1, j - _BATCH), -1)
        units, dxs, dys = [], [], []
        for k in cands:
            bx, by = pts[k]
            dx, dy = bx - ax, by - ay
            units.append(_unit_steps(max(1, math.ceil(math.hypot(dx, dy) / half)) + 1))
            dxs.append(dx)
            dys.append(dy)
        coarse = [u[::_COARSE] for u in units]
        alive = np.flatnonzero(_all_free(coarse, dxs, dys, ax, ay, free, g))
        if alive.size:
            keep = alive.tolist()
            hit = np.flatnonzero(_all_free([units[c] for c in keep], [dxs[c] for c in keep],
                                           [dys[c] for c in keep], ax, ay, free, g))
            if hit.size:
                return cands[keep[int(hit[0])]]
        j = cands[-1] - 1
    return i + 1


def _all_free(units: list[npt.NDArray[np.float64]], dxs: list[float], dys: list[float], ax: float, ay: float,
              free: npt.NDArray[np.bool_], g: OccupancyGrid) -> npt.NDArray[np.bool_]:
    """Per line from (ax, ay) by (dx, dy): whether its points at the fractions ``units`` lie in free cells
    of the grid (``a + u * d``, the cell by floor: the points of :func:`_farthest_visible`)."""
    ny, nx = free.shape
    counts = np.fromiter((len(u) for u in units), dtype=np.int64, count=len(units))
    u = np.concatenate(units)
    x = ax + u * np.repeat(np.asarray(dxs, dtype=np.float64), counts)
    y = ay + u * np.repeat(np.asarray(dys, dtype=np.float64), counts)
    ix = np.floor((x - g.origin[0]) / g.resolution).astype(np.int64)
    iy = np.floor((y - g.origin[1]) / g.resolution).astype(np.int64)
    ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    ok[ok] = free[iy[ok], ix[ok]]
    starts = np.zeros(len(counts), dtype=np.int64)
    np.cumsum(counts[:-1], out=starts[1:])
    return np.logical_and.reduceat(ok, starts)
