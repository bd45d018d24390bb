"""Moving workers (B5): deterministic walking routes of the people on site, from the site layout graph.

Each ``kbp:Worker`` walks to its ``kbp:routeStop`` locations in order, waits ``kbp:dwellTime`` at each,
and repeats. Legs between stops follow the shortest free path on the ground occupancy grid (8-connected
Dijkstra over cells with at least ``clearance_m`` to obstacles), so people walk around buildings and
fences rather than through them. A seed varies dwell times (x0.8-1.2), walking speed (x0.9-1.1) and
where on its route each worker starts; the same seed gives the same motion. Takes the model graph and
an occupancy grid; gives :class:`WorkerMotion` objects with ``position(t)``.
"""

from __future__ import annotations

import logging
import math
import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from rdflib import Graph

from kbplanner.core.errors import KbplannerError
from kbplanner.core.named_queries import run_named
from kbplanner.simulation.social_force import SocialForceParams
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

DEFAULT_SPEED_MPS = 1.2
DEFAULT_DWELL_S = 30.0
WORKER_RADIUS_M = 0.25


@dataclass(frozen=True)
class RouteStop:
    """A place a worker walks to: the site object, its position (m) and the dwell time (s)."""

    location: str
    label: str
    x: float
    y: float
    dwell_s: float


@dataclass(frozen=True)
class WorkerSpec:
    """A worker of the site layout."""

    iri: str
    label: str
    role: str
    speed_mps: float
    stops: tuple[RouteStop, ...]
    social: SocialForceParams | None = None  # reactive workers' parameters (None: the defaults)


def load_workers(graph: Graph) -> list[WorkerSpec]:
    """Every worker of the model with its ordered route (named query ``workers``)."""
    rows = run_named(graph, "workers").as_dicts()
    by_worker: dict[str, dict[str, Any]] = {}
    for r in rows:
        w = by_worker.setdefault(r["worker"], {"row": r, "stops": []})
        w["stops"].append(RouteStop(
            location=r["location"], label=str(r["locationLabel"] or r["location"]),
            x=float(r["x"]), y=float(r["y"]),
            dwell_s=float(r["dwell"]) if r["dwell"] is not None else DEFAULT_DWELL_S,
        ))
    out = []
    for iri in sorted(by_worker):
        r = by_worker[iri]["row"]
        speed = float(r["speed"]) if r["speed"] is not None else DEFAULT_SPEED_MPS
        if speed <= 0:
            raise KbplannerError(f"walking speed {speed} m/s is not positive", element=iri,
                                 fix="give kbp:walkingSpeed in m/s, e.g. 1.2")
        out.append(WorkerSpec(iri=iri, label=str(r["label"] or iri.rsplit("/", 1)[-1]),
                              role=str(r["role"] or "worker"), speed_mps=speed,
                              stops=tuple(by_worker[iri]["stops"]), social=_social(iri, r)))
    return out


_SOCIAL = (("comfort", "comfort_distance_m", "kbp:comfortDistance", 0.0, 5.0),
           ("personal", "personal_distance_m", "kbp:personalDistance", 0.0, 3.0),
           ("relaxation", "relaxation_time_s", "kbp:relaxationTime", 0.05, 5.0),
           ("reaction", "reaction_time_s", "kbp:reactionTime", 0.0, 3.0))


def _social(iri: str, row: dict[str, Any]) -> SocialForceParams:
    """The worker's social-force parameters from the site Turtle (defaults where not given), checked."""
    values: dict[str, float] = {}
    for col, field_name, prop, lo, hi in _SOCIAL:
        if row.get(col) is None:
            continue
        v = float(row[col])
        if not (math.isfinite(v) and lo <= v <= hi):
            raise KbplannerError(f"{prop} {v} is out of range [{lo}, {hi}]", element=iri,
                                 fix=f"give {prop} within [{lo}, {hi}] (see docs/safety.md for defaults)")
        values[field_name] = v
    return SocialForceParams(**values)


@dataclass
class WorkerMotion:
    """A worker's motion over time: alternating walks (polylines) and waits, repeated as needed.

    ``segments`` holds (t_start, t_end, points, cumulative lengths); a wait has one point.
    """

    spec: WorkerSpec
    segments: list[tuple[float, float, np.ndarray, np.ndarray]] = field(default_factory=list)

    @property
    def horizon_s(self) -> float:
        """The time up to which the motion is defined."""
        return self.segments[-1][1] if self.segments else 0.0

    def position(self, t: float) -> tuple[float, float, float]:
        """(x, y, heading rad) at time ``t`` seconds; holds the last pose past the horizon."""
        if not self.segments:
            s = self.spec.stops[0]
            return (s.x, s.y, 0.0)
        lo, hi = 0, len(self.segments) - 1
        while lo < hi:  # binary search: the segment containing t
            mid = (lo + hi) // 2
            if self.segments[mid][1] < t:
                lo = mid + 1
            else:
                hi = mid
        t0, t1, pts, cum = self.segments[lo]
        if len(pts) == 1 or t1 <= t0:
            heading = self._heading_before(lo)
            return (float(pts[0, 0]), float(pts[0, 1]), heading)
        d = (min(max(t, t0), t1) - t0) / (t1 - t0) * cum[-1]
        i = int(np.searchsorted(cum, d, side="right") - 1)
        i = min(max(i, 0), len(pts) - 2)
        seg = cum[i + 1] - cum[i]
        f = 0.0 if seg <= 0 else (d - cum[i]) / seg
        p = pts[i] + f * (pts[i + 1] - pts[i])
        v = pts[i + 1] - pts[i]
        return (float(p[0]), float(p[1]), math.atan2(float(v[1]), float(v[0])))

    def _heading_before(self, k: int) -> float:
        for j in range(k - 1, -1, -1):
            pts = self.segments[j][2]
            if len(pts) > 1:
                v = pts[-1] - pts[-2]
                return math.atan2(float(v[1]), float(v[0]))
        return 0.0


MAX_ROUTING_CELLS = 400_000  # worker routes on a coarser grid beyond this (a whole building's site)


class _Router:
    """Shortest walking paths on a grid, with a clearance for a person; memoised per (start, goal) cell."""

    def __init__(self, grid: OccupancyGrid | None, clearance_m: float,
                 cells: tuple[np.ndarray, int] | None = None) -> None:
        """``cells``: :func:`walk_cells` of ``grid`` and ``clearance_m`` when known (kept by an earlier run,
        :func:`kbplanner.simulation.walk_store.walk_cells_kept`), else made here."""
        self.grid = grid
        self.free: np.ndarray | None = None
        if grid is not None:
            free, k = cells if cells is not None else walk_cells(grid, clearance_m)
            if k > 1:
                self.grid = OccupancyGrid(~free, origin=grid.origin, resolution=grid.resolution * k)
            self.free = free
        self._memo: dict[tuple[tuple[int, int], tuple[int, int]], np.ndarray] = {}
        self.kept_legs: frozenset[tuple[tuple[int, int], tuple[int, int]]] = frozenset()  # read or kept
        self._csgraph: tuple[Any, np.ndarray] | None = None
        self._pred: dict[int, np.ndarray] = {}
        self._nearest: np.ndarray | None = None
        self._cells = np.zeros(0, dtype=np.int64)  # the free cells' flat numbers (by _graph)

    def _nearest_free(self, ix: int, iy: int) -> tuple[int, int]:
        assert self.free is not None
        ny, nx = self.free.shape
        ix, iy = min(max(ix, 0), nx - 1), min(max(iy, 0), ny - 1)
        if self.free[iy, ix]:
            return ix, iy
        if self._nearest is None:
            if not self.free.any():
                raise KbplannerError("the ground map has no free cell for workers to walk on",
                                     element="workers", fix="check the site extent and the obstacles")
            from scipy import ndimage

            _, self._nearest = ndimage.distance_transform_edt(~self.free, return_indices=True)
        assert self._nearest is not None
        return int(self._nearest[1][iy, ix]), int(self._nearest[0][iy, ix])

    def path(self, a: tuple[float, float], b: tuple[float, float]) -> np.ndarray:
        """Polyline (n x 2, metres) from a to b around obstacles; straight when there is no grid."""
        if self.grid is None or self.free is None:
            return np.array([a, b], dtype=float)
        g = self.grid
        s = self._nearest_free(*g.cell_of(*a))
        t = self._nearest_free(*g.cell_of(*b))
        key = (s, t)
        if key not in self._memo:
            cells = self._dijkstra(s, t)
            pts = np.array([g.center_of(ix, iy) for ix, iy in cells], dtype=float)
            self._memo[key] = _simplify(pts, self.free, g)
        core = self._memo[key]
        return np.vstack([np.array([a]), core, np.array([b])])

    def _graph(self) -> tuple[Any, np.ndarray]:
        """The 8-connected walking graph of the free cells (built once) and the cell -> node index map.

        (Each node's edges to its neighbours at (dx, dy) = (1, -1), (1, 0), (0, 1), (1, 1), in that order
        - ascending node numbers -, straight into the compressed rows: the very arrays the sparse
        matrix of the (row, column, weight) lists gives, sorted and summed, a quarter of its time.)"""
        if self._csgraph is None:
            from scipy import sparse

            assert self.free is not None
            free = self.free
            ny, nx = free.shape
            n = int(free.sum())
            index = np.full(free.shape, -1, dtype=np.int64)
            index[free] = np.arange(n)
            pad = np.full((ny + 2, nx + 2), -1, dtype=np.int64)
            pad[1:-1, 1:-1] = index
            steps = ((1, -1), (1, 0), (0, 1), (1, 1))
            cols = np.stack([pad[1 + dy:ny + 1 + dy, 1 + dx:nx + 1 + dx][free] for dx, dy in steps], axis=1)
            ok = cols >= 0
            weights = np.array([math.hypot(dx, dy) for dx, dy in steps])
            indptr = np.concatenate([[0], np.cumsum(ok.sum(axis=1))])
            data = np.broadcast_to(weights, cols.shape)[ok]
            graph = sparse.csr_matrix((data, cols[ok], indptr), shape=(n, n))
            self._csgraph = (graph, index)
            self._cells = np.flatnonzero(index.ravel() >= 0)
        return self._csgraph

    def _dijkstra(self, s: tuple[int, int], t: tuple[int, int]) -> list[tuple[int, int]]:
        """Shortest 8-connected cell path from s to t (scipy's Dijkstra from s, kept for later targets)."""
        from scipy.sparse import csgraph

        graph, index = self._graph()
        src, dst = int(index[s[1], s[0]]), int(index[t[1], t[0]])
        if src not in self._pred:
            _, pred = csgraph.dijkstra(graph, directed=False, indices=src, return_predecessors=True)
            self._pred[src] = pred
        pred = self._pred[src]
        if src != dst and pred[dst] < 0:
            log.warning("no walking path between cells %s and %s; the worker walks straight", s, t)
            return [s, t]
        nx = index.shape[1]
        nodes = [dst]
        while nodes[-1] != src:
            nodes.append(int(pred[nodes[-1]]))
        flat = self._cells[nodes[::-1]]
        return [(int(c % nx), int(c // nx)) for c in flat]


def walk_cells(grid: OccupancyGrid, clearance_m: float) -> tuple[np.ndarray, int]:
    """The cells a person walks on (``clearance_m`` or more from obstacles) and how many times coarser than
    ``grid``'s they are: on a big site (over :data:`MAX_ROUTING_CELLS`) routes are found on cells ``k`` times
    coarser, free where all their fine cells are."""
    free = grid.clearance_m() >= clearance_m
    k = max(1, math.ceil(math.sqrt(free.size / MAX_ROUTING_CELLS)))
    if k > 1:
        ny, nx = free.shape[0] // k * k, free.shape[1] // k * k
        free = np.asarray(free[:ny, :nx].reshape(ny // k, k, nx // k, k).all(axis=(1, 3)), dtype=bool)
    return free, k


def _line_free(p: np.ndarray, q: np.ndarray, free: np.ndarray, g: OccupancyGrid) -> bool:
    n = max(2, int(np.linalg.norm(q - p) / (g.resolution * 0.5)) + 1)
    f = np.linspace(0.0, 1.0, n)[:, None]
    pts = p[None, :] + f * (q - p)[None, :]
    ix = np.floor((pts[:, 0] - g.origin[0]) / g.resolution).astype(np.int64)
    iy = np.floor((pts[:, 1] - g.origin[1]) / g.resolution).astype(np.int64)
    inside = (iy >= 0) & (iy < free.shape[0]) & (ix >= 0) & (ix < free.shape[1])
    return bool(inside.all() and free[iy, ix].all())


def _simplify(pts: np.ndarray, free: np.ndarray, g: OccupancyGrid) -> np.ndarray:
    """Greedy shortcutting: keep a point only when the straight line past it would hit an obstacle."""
    if len(pts) <= 2:
        return pts
    out = [pts[0]]
    i = 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1 and not _line_free(pts[i], pts[j], free, g):
            j -= 1
        out.append(pts[j])
        i = j
    return np.array(out)


def _rng_for(spec: WorkerSpec, seed: int) -> np.random.Generator:
    return np.random.default_rng([seed, zlib.crc32(spec.iri.encode("utf-8"))])


def plan_worker_motion(spec: WorkerSpec, grid: OccupancyGrid | None, *, seed: int, horizon_s: float,
                       clearance_m: float = WORKER_RADIUS_M, router: Any = None) -> WorkerMotion:
    """The worker's motion from t = 0 to at least ``horizon_s`` seconds, deterministic in ``seed``.

    Example:
        >>> s = WorkerSpec("urn:w", "W", "carpenter", 1.0,
        ...                (RouteStop("a", "A", 0.0, 0.0, 10.0), RouteStop("b", "B", 10.0, 0.0, 10.0)))
        >>> m = plan_worker_motion(s, None, seed=1, horizon_s=100.0)
        >>> m.horizon_s >= 100.0
        True
    """
    rng = _rng_for(spec, seed)
    r = router if router is not None else _Router(grid, clearance_m)
    speed = spec.speed_mps * float(rng.uniform(0.9, 1.1))
    stops = spec.stops
    motion = WorkerMotion(spec=spec)
    if len(stops) == 1:
        p = np.array([[stops[0].x, stops[0].y]])
        motion.segments.append((0.0, max(horizon_s, 1.0), p, np.zeros(1)))
        return motion
    k = int(rng.integers(len(stops)))  # where on the route the worker is at t = 0
    t = -float(rng.uniform(0.0, stops[k].dwell_s))  # part of the first wait already done
    while t < horizon_s:
        here, there = stops[k], stops[(k + 1) % len(stops)]
        dwell = here.dwell_s * float(rng.uniform(0.8, 1.2))
        motion.segments.append((max(t, 0.0), max(t + dwell, 0.0), np.array([[here.x, here.y]]), np.zeros(1)))
        t += dwell
        pts = r.path((here.x, here.y), (there.x, there.y))
        cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        dur = float(cum[-1]) / speed
        motion.segments.append((max(t, 0.0), t + dur, pts, cum))
        t += dur
        k = (k + 1) % len(stops)
    motion.segments = [s for s in motion.segments if s[1] > s[0] or s[0] > 0.0]
    return motion


def plan_workers(graph: Graph, grid: OccupancyGrid | None, *, seed: int, horizon_s: float,
                 clearance_m: float = WORKER_RADIUS_M) -> list[WorkerMotion]:
    """Motions of every worker of the model (one shared router so paths are computed once)."""
    router = _Router(grid, clearance_m)
    return [plan_worker_motion(s, grid, seed=seed, horizon_s=horizon_s, clearance_m=clearance_m,
                               router=router) for s in load_workers(graph)]
