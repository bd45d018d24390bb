"""Navigation (B5, skills NV-1 and NV-2): SE(2) path planning with OMPL on an occupancy grid.

Takes an :class:`~kbplanner.world.occupancy.OccupancyGrid`, a start and goal pose (x, y, yaw; site frame,
metres, radians) and a :class:`~kbplanner.world.footprint.Footprint` (the base, plus the carried object in
its carry pose); returns a :class:`NavPath` with a status and a reason (never an exception for an
unreachable goal). Validity checks are array look-ups in a precomputed
:class:`~kbplanner.world.footprint.ConfigurationSpace` (one map per yaw bin). The planner (RRTConnect by
default, or BIT*/InformedRRT* with a time budget) is seeded through ``ou.RNG.setSeed``, so the same
seed gives the same path; the solution is shortcut-simplified and re-checked densely.

:func:`plan_with_carry_modes` is the doorway behaviour of the paper (Figure 14): plan with the
normal (wide) carry footprint; where that fails, plan with the narrow one and mark the stretches of
the path where the wide load does not fit, with "rotate to narrow" before and "rotate back" after
each (extended by a margin). :func:`time_parameterize` turns a path into timed samples
(trapezoidal velocity profiles under speed and yaw-rate limits); :func:`grid_shortest_path_length`
is the yardstick for path quality (8-connected Dijkstra on the configuration space, then
line-of-sight shortcutting).

Example:
    >>> import numpy as np
    >>> from kbplanner.world.footprint import Footprint, Rect
    >>> occ = np.zeros((60, 100), dtype=bool); occ[[0, -1], :] = True; occ[:, [0, -1]] = True
    >>> grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
    >>> path = plan_path(grid, (1.0, 1.5, 0.0), (4.0, 1.5, 0.0), Footprint((Rect(0, 0, 0.99, 0.67),)))
    >>> path.ok, round(path.length_m, 2)
    (True, 3.0)
"""

from __future__ import annotations

import heapq
import itertools
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from kbplanner.core.errors import KbplannerError
from kbplanner.world.footprint import ConfigurationSpace, Footprint
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

Pose2D = tuple[float, float, float]

PLANNERS: dict[str, Callable[[ob.SpaceInformation], ob.Planner]] = {
    "RRTConnect": og.RRTConnect,
    "BITstar": og.BITstar,
    "InformedRRTstar": og.InformedRRTstar,
    "RRTstar": og.RRTstar,
    "PRM": og.PRM,
}
# Planners that stop at the first solution: deterministic for a seed. The others use their
# whole time budget, so their result depends on machine speed.
DETERMINISTIC_PLANNERS = frozenset({"RRTConnect"})

OK = "ok"
FAILED = "failed"


CERTAIN_PASSAGE_CHECKS = 100_000  # OMPL's budget where free cells certainly join start and goal


@dataclass(frozen=True)
class NavSettings:
    """How to plan: planner name, time budget, yaw bins, seed and checking resolutions."""

    planner: str = "RRTConnect"
    time_limit_s: float = 10.0
    # Deterministic work budget: planning stops after this many motion checks, whatever the machine's
    # speed, so the same seed gives the same answer on a busy or a fast machine. ``time_limit_s`` stays
    # as a safety cap only (a run that hits it says so in its reason).
    max_motion_checks: int = 400_000
    n_yaw_bins: int = 72
    seed: int = 1
    simplify: bool = True
    margin_m: float = 0.0
    check_step_m: float | None = None  # motion check step; default: a quarter of a grid cell
    base_motion: str = "turn_drive_turn"  # or "holonomic": keep OMPL's SE(2) segments as they are
    allow_reverse: bool = True  # turn_drive_turn may drive backwards when that turns less
    # where free cells certainly join start and goal and OMPL finds no path within its (then smaller)
    # budget, take the cell path (breadth-first over face-adjacent free cells, shortened)
    cell_fallback: bool = True

    def __post_init__(self) -> None:
        if self.planner not in PLANNERS:
            raise KbplannerError(f"unknown planner '{self.planner}'", element="NavSettings.planner",
                                 fix=f"use one of {sorted(PLANNERS)}")
        if self.base_motion not in ("turn_drive_turn", "holonomic"):
            raise KbplannerError(f"unknown base motion '{self.base_motion}'",
                                 element="NavSettings.base_motion",
                                 fix="use 'turn_drive_turn' (skid-steer) or 'holonomic'")
        if not self.time_limit_s > 0:
            raise KbplannerError("time_limit_s must be positive", element="NavSettings.time_limit_s",
                                 fix="give the planning budget in seconds, e.g. 10")


@dataclass(frozen=True)
class NavPath:
    """A planned base path: waypoints (x, y, yaw), straight-line/shortest-yaw between them.

    ``status`` is ``"ok"`` or ``"failed"``; ``reason`` says why it failed (or how it was found).
    """

    poses: tuple[Pose2D, ...]
    length_m: float
    planning_time_s: float
    planner: str
    status: str
    reason: str
    footprint: str = ""

    @property
    def ok(self) -> bool:
        """Whether a path was found."""
        return self.status == OK

    def interpolated(self, step_m: float, yaw_step_rad: float = math.radians(2.0)) -> list[Pose2D]:
        """Dense poses along the path, at most ``step_m`` / ``yaw_step_rad`` apart."""
        return _densify(self.poses, step_m, yaw_step_rad)


def _failed(reason: str, planner: str, footprint: str, t: float = 0.0) -> NavPath:
    return NavPath(poses=(), length_m=0.0, planning_time_s=t, planner=planner, status=FAILED,
                   reason=reason, footprint=footprint)


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _densify(poses: Sequence[Pose2D], step_m: float, yaw_step_rad: float) -> list[Pose2D]:
    if not poses:
        return []
    out: list[Pose2D] = [poses[0]]
    for (x0, y0, t0), (x1, y1, t1) in itertools.pairwise(poses):
        dyaw = _wrap(t1 - t0)
        n = max(1, math.ceil(max(math.hypot(x1 - x0, y1 - y0) / step_m, abs(dyaw) / yaw_step_rad)))
        for i in range(1, n + 1):
            u = i / n
            out.append((x0 + u * (x1 - x0), y0 + u * (y1 - y0), _wrap(t0 + u * dyaw)))
    return out


def _path_length(poses: Sequence[Pose2D]) -> float:
    return float(sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in itertools.pairwise(poses)))


def _connected(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> bool:
    """Whether start and goal share a component of the discretised free space (x, y, yaw bin).

    26-connectivity with the yaw axis closed into a ring over-connects, so "not connected" is
    certain: no continuous path exists in the (conservative) configuration space.
    """
    labels = cs.components(diagonal=True)
    return cs.component_of(labels, *start) == cs.component_of(labels, *goal)


def _validity_checker(cs: ConfigurationSpace) -> Callable[[ob.State], bool]:
    """A fast Python validity checker: one bytes look-up per state."""
    free = cs.free.tobytes()
    ox, oy = cs.grid.origin
    inv_res = 1.0 / cs.grid.resolution
    ny, nx = cs.grid.shape
    n_bins = cs.n_bins
    inv_w = n_bins / (2 * math.pi)
    plane = ny * nx
    floor = math.floor

    def valid(state: ob.State) -> bool:
        ix = floor((state.getX() - ox) * inv_res)
        iy = floor((state.getY() - oy) * inv_res)
        if ix < 0 or iy < 0 or ix >= nx or iy >= ny:
            return False
        k = floor(state.getYaw() * inv_w + 0.5) % n_bins
        return free[k * plane + iy * nx + ix] == 1

    return valid


def _set_seed(seed: int) -> None:
    # OMPL logs an error when the seed is set after sampling started; reseeding the seed generator is
    # still what makes later planners deterministic, so silence that message.
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    ou.RNG.setSeed(max(1, int(seed)))
    ou.setLogLevel(level)


class _ExactMotion:
    """Exact motion checks in a configuration space for SE(2) straight-line motions.

    A motion (x, y, yaw linear, yaw the short way round) is cut where the yaw crosses a bin border;
    within each piece the bin is fixed and the centre moves along a straight segment, so the piece
    is free exactly when every cell that segment touches (its supercover) is free in that bin.
    Sampled checks can miss a cell that a segment only clips at a corner; this cannot.
    """

    def __init__(self, cs: ConfigurationSpace) -> None:
        self.free = cs.free.tobytes()
        self.ny, self.nx = cs.grid.shape
        self.ox, self.oy = cs.grid.origin
        self.inv_res = 1.0 / cs.grid.resolution
        self.n_bins = cs.n_bins
        self.w = cs.bin_width
        self.plane = self.ny * self.nx

    def pose_free(self, x: float, y: float, yaw: float) -> bool:
        ix = math.floor((x - self.ox) * self.inv_res)
        iy = math.floor((y - self.oy) * self.inv_res)
        if not (0 <= ix < self.nx and 0 <= iy < self.ny):
            return False
        k = math.floor(yaw / self.w + 0.5) % self.n_bins
        return self.free[k * self.plane + iy * self.nx + ix] == 1

    def _segment_free(self, k: int, x0: float, y0: float, x1: float, y1: float) -> bool:
        """Every cell the segment touches is free in bin ``k`` (cell units)."""
        if x0 > x1:
            x0, y0, x1, y1 = x1, y1, x0, y0
        nx, ny = self.nx, self.ny
        base = k * self.plane
        ixa, ixb = math.floor(x0), math.floor(x1)
        if ixa < 0 or ixb >= nx:
            return False
        slope = (y1 - y0) / (x1 - x0) if x1 > x0 else 0.0
        for ix in range(ixa, ixb + 1):
            if x1 > x0:
                ya = y0 + (max(x0, ix) - x0) * slope
                yb = y0 + (min(x1, ix + 1) - x0) * slope
            else:
                ya, yb = y0, y1
            lo, hi = math.floor(min(ya, yb)), math.floor(max(ya, yb))
            if lo < 0 or hi >= ny:
                return False
            if 0 in self.free[base + lo * nx + ix : base + hi * nx + ix + 1 : nx]:
                return False
        return True

    def motion_free(self, a: Sequence[float], b: Sequence[float]) -> bool:
        """Whether the straight SE(2) motion from ``a`` to ``b`` is free (both ends included)."""
        t0 = float(a[2])
        d = _wrap(float(b[2]) - t0)
        # Cheap rejection first: most motions a planner tries run into a wall somewhere.
        n = max(2, math.ceil(max(abs(b[0] - a[0]), abs(b[1] - a[1])) * self.inv_res / 2))
        for i in (n // 2, n, *range(1, n)):
            u = i / n
            if not self.pose_free(a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]), t0 + u * d):
                return False
        cuts = [0.0]
        if d != 0.0:
            k0 = math.floor(t0 / self.w + 0.5)
            k1 = math.floor((t0 + d) / self.w + 0.5)
            borders = range(k0, k1) if d > 0 else range(k0 - 1, k1 - 1, -1)
            cuts += [((k + 0.5) * self.w - t0) / d for k in borders]
        cuts.append(1.0)
        ax, ay = (a[0] - self.ox) * self.inv_res, (a[1] - self.oy) * self.inv_res
        dx, dy = (b[0] - self.ox) * self.inv_res - ax, (b[1] - self.oy) * self.inv_res - ay
        for ua, ub in itertools.pairwise(cuts):
            k = math.floor((t0 + 0.5 * (ua + ub) * d) / self.w + 0.5) % self.n_bins
            if not self._segment_free(k, ax + ua * dx, ay + ua * dy, ax + ub * dx, ay + ub * dy):
                return False
        return True

    def path_free(self, poses: Sequence[Sequence[float]]) -> bool:
        """Whether every motion between consecutive poses is free."""
        if len(poses) == 1:
            return self.pose_free(*poses[0][:3])
        return all(self.motion_free(p, q) for p, q in itertools.pairwise(poses))


def _shortcut(motion: _ExactMotion, poses: Sequence[Pose2D], step_m: float) -> list[Pose2D]:
    """Greedy string pulling: from each kept pose, jump to the farthest free pose of the densified path."""
    dense = _densify(poses, step_m, math.pi)
    out = [dense[0]]
    i, n = 0, len(dense)
    while i < n - 1:
        j = n - 1
        while j > i + 1 and not motion.motion_free(dense[i], dense[j]):
            j -= 1
        out.append(dense[j])
        i = j
    return out if _path_length(out) <= _path_length(poses) else list(poses)


def path_is_free(cs: ConfigurationSpace, poses: Sequence[Sequence[float]]) -> bool:
    """Exact check of a path (straight SE(2) motions between waypoints) in a configuration space."""
    return _ExactMotion(cs).path_free(poses)


class _OmplMotionValidator(ob.MotionValidator):
    def __init__(self, si: ob.SpaceInformation, exact: _ExactMotion) -> None:
        super().__init__(si)
        self.exact = exact

    calls = 0

    def checkMotion(self, s1: ob.State, s2: ob.State) -> bool:  # OMPL's method name
        self.calls += 1
        a = (s1.getX(), s1.getY(), s1.getYaw())
        return self.exact.motion_free(a, (s2.getX(), s2.getY(), s2.getYaw()))


def plan_path(
    space: OccupancyGrid | ConfigurationSpace,
    start: Pose2D,
    goal: Pose2D,
    footprint: Footprint | None = None,
    settings: NavSettings | None = None,
) -> NavPath:
    """Plan a collision-free SE(2) path for ``footprint`` from ``start`` to ``goal``.

    Args:
        space: an occupancy grid (the configuration space is built for ``footprint``) or a prebuilt
            :class:`ConfigurationSpace` (reuse it for many queries with one footprint).
        start, goal: (x, y, yaw) in the site frame, metres and radians.
        footprint: required with a grid; ignored with a configuration space.
        settings: planner, time budget, seed, ...

    Returns:
        A :class:`NavPath`; when no path is found its status is ``"failed"`` and ``reason`` says why
        (start or goal in collision or off the map, goal walled off, no path within the budget).
    """
    settings = settings or NavSettings()
    if isinstance(space, ConfigurationSpace):
        cs = space
    else:
        if footprint is None:
            raise KbplannerError("plan_path on a grid needs a footprint", element="plan_path",
                                 fix="pass footprint=robot_spec.footprint() (plus the load)")
        cs = ConfigurationSpace.build(space, footprint, settings.n_yaw_bins, settings.margin_m)
    name = settings.planner
    fp = cs.footprint.name
    grid = cs.grid
    for label, pose in (("start", start), ("goal", goal)):
        if not grid.contains(pose[0], pose[1]):
            return _failed(f"no path: {label} ({pose[0]:.2f}, {pose[1]:.2f}) is off the map", name, fp)
        if not cs.is_free(*pose):
            return _failed(f"no path: {label} in collision", name, fp)
    if not _connected(cs, start, goal):
        return _failed("no path: the goal is walled off from the start for this footprint", name, fp)

    t0 = time.perf_counter()
    certain: list[bool] = []

    def cells_certain() -> bool:
        """Asked once, when RRTConnect has used CERTAIN_PASSAGE_CHECKS without a path."""
        certain.append(_face_connected(cs, start, goal))
        return certain[-1]

    level = ou.getLogLevel()
    ou.setLogLevel(ou.LogLevel.LOG_INFO if log.isEnabledFor(logging.DEBUG) else ou.LogLevel.LOG_WARN)
    try:
        result = _solve(cs, start, goal, settings, t0, cells_certain if settings.cell_fallback else None)
    finally:
        ou.setLogLevel(level)
    if result.ok or not (certain and certain[-1]):
        return result
    cells = _face_path(cs, start, goal)
    if cells is None:
        return result
    return _cell_route(cs, start, goal, cells, settings, t0, result.reason)


def _face_connected(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> bool:
    """Whether face-adjacent free cells of (x, y, yaw bin) join start and goal (see :func:`_face_path`)."""
    labels = cs.components(diagonal=False)
    a = cs.component_of(labels, *start)
    return a > 0 and a == cs.component_of(labels, *goal)


def _face_path(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> list[Pose2D] | None:
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
    return [(ox + (float(x) + 0.5) * res, oy + (float(y) + 0.5) * res, _wrap(float(b) * w))
            for b, y, x in cell.tolist()]


def _cell_route(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, cells: list[Pose2D],
                settings: NavSettings, t0: float, ompl_reason: str) -> NavPath:
    """The path of :func:`_face_path`, shortened by exact motion checks (OMPL found none in its budget)."""
    motion = _ExactMotion(cs)
    poses: list[Pose2D] = [(start[0], start[1], _wrap(start[2])), *cells, (goal[0], goal[1], _wrap(goal[2]))]
    if not motion.path_free(poses):
        return _failed(f"{ompl_reason}; the cell path failed the exact check", settings.planner,
                       cs.footprint.name, time.perf_counter() - t0)
    poses = _shortcut(motion, poses, cs.grid.resolution * 5)
    how = f"cell search over free configuration cells (RRTConnect: {ompl_reason})"
    if settings.base_motion == "turn_drive_turn":
        poses, kept = turn_drive_turn(cs, poses, allow_reverse=settings.allow_reverse)
        how += "; turn-drive-turn" + (f" ({kept} segment(s) partly turning while driving)" if kept else "")
    return NavPath(poses=tuple(poses), length_m=_path_length(poses), planning_time_s=time.perf_counter() - t0,
                   planner=f"{settings.planner}+cells", status=OK, reason=how, footprint=cs.footprint.name)


def _solve(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, settings: NavSettings, t0: float,
           cells_certain: Callable[[], bool] | None = None) -> NavPath:
    """RRTConnect within the work budget. With ``cells_certain``: after CERTAIN_PASSAGE_CHECKS motion
    checks without a path it is asked whether free cells certainly join start and goal; if so, planning
    stops there (the caller takes the cell path), else the same tree grows on to the full budget."""
    name = settings.planner
    fp = cs.footprint.name
    grid = cs.grid
    _set_seed(settings.seed)
    space_se2 = ob.SE2StateSpace()
    bounds = ob.RealVectorBounds(2)
    ext = grid.extent
    bounds.setLow(0, ext.xmin)
    bounds.setLow(1, ext.ymin)
    bounds.setHigh(0, ext.xmax)
    bounds.setHigh(1, ext.ymax)
    space_se2.setBounds(bounds)
    ss = og.SimpleSetup(space_se2)
    ss.setStateValidityChecker(_validity_checker(cs))
    si = ss.getSpaceInformation()
    step = settings.check_step_m or grid.resolution / 4
    si.setStateValidityCheckingResolution(min(0.5, step / space_se2.getMaximumExtent()))
    motion = _ExactMotion(cs)
    validator = _OmplMotionValidator(si, motion)  # kept referenced until planning ends
    si.setMotionValidator(validator)
    planner = PLANNERS[name](si)
    ss.setPlanner(planner)
    s, g = space_se2.allocState(), space_se2.allocState()
    s.setXY(start[0], start[1])
    s.setYaw(_wrap(start[2]))
    g.setXY(goal[0], goal[1])
    g.setYaw(_wrap(goal[2]))
    ss.setStartAndGoalStates(s, g)
    deadline = time.perf_counter() + settings.time_limit_s
    budget = settings.max_motion_checks
    first = min(budget, CERTAIN_PASSAGE_CHECKS) if cells_certain is not None else budget
    ptc = ob.PlannerTerminationCondition(
        lambda: validator.calls >= first or time.perf_counter() > deadline)
    status = ss.solve(ptc)
    if cells_certain is not None and not ss.haveExactSolutionPath() and time.perf_counter() <= deadline:
        if cells_certain():
            budget = first  # the caller takes the cell path
        elif first < budget:
            ptc = ob.PlannerTerminationCondition(
                lambda: validator.calls >= budget or time.perf_counter() > deadline)
            status = ss.solve(ptc)  # the planner keeps its trees: this continues the same search
    elif first < budget and not ss.haveExactSolutionPath():
        budget = first
    if validator.calls < budget and time.perf_counter() > deadline:
        log.warning("planning hit the %.0f s safety cap before its work budget: the result may depend on "
                    "machine speed", settings.time_limit_s)
    exact = ss.haveExactSolutionPath()
    if not exact:
        elapsed = time.perf_counter() - t0
        reason = (f"no path within {budget} motion checks or {settings.time_limit_s:g} s "
                  f"({status.asString()})")
        del ss, planner
        return _failed(reason, name, fp, elapsed)
    raw = _states(ss.getSolutionPath())
    poses = raw
    how = "found"
    if settings.simplify:
        ss.simplifySolution()
        simplified = _states(ss.getSolutionPath())
        if motion.path_free(simplified):
            poses = simplified
            how = "found and simplified"
        else:
            log.info("simplified path failed the dense re-check; keeping the unsimplified path")
    del ss, planner
    if not motion.path_free(poses):
        elapsed = time.perf_counter() - t0
        return _failed("no path: the planner's path failed the dense re-check", name, fp, elapsed)
    poses[0] = (start[0], start[1], _wrap(start[2]))
    if settings.simplify:
        poses = _shortcut(motion, poses, grid.resolution * 5)
    elapsed = time.perf_counter() - t0
    if settings.base_motion == "turn_drive_turn":
        poses, kept = turn_drive_turn(cs, poses, allow_reverse=settings.allow_reverse)
        how += "; turn-drive-turn" + (f" ({kept} segment(s) partly turning while driving)" if kept else "")
        elapsed = time.perf_counter() - t0
    return NavPath(poses=tuple(poses), length_m=_path_length(poses), planning_time_s=elapsed,
                   planner=name, status=OK, reason=how, footprint=fp)


def turn_drive_turn(
    cs: ConfigurationSpace,
    poses: Sequence[Pose2D],
    *,
    allow_reverse: bool = True,
) -> tuple[list[Pose2D], int]:
    """Rewrite an SE(2) path for a skid-steer base: turn in place, drive straight, turn at the goal.

    Each segment becomes a rotation on the spot to face along it (or away from it, driving backwards,
    when that turns less and ``allow_reverse``) and a straight drive; the goal yaw is reached by a
    final turn. Where such a turn is blocked (next to a door jamb, say), the shortest leading part of
    the segment (1/8, 1/4, ... of it) is driven as in SE(2), turning while moving, and the rest turn-
    drive-turn. Every motion is checked densely. Returns the waypoints and how many segments needed
    such an SE(2) part; if one cannot be rejoined at all, the SE(2) path itself is returned.
    """
    if len(poses) < 2:
        return list(poses), 0
    exact = _ExactMotion(cs)

    def free(seq: Sequence[Pose2D]) -> bool:
        return exact.path_free(seq)

    def tdt(frm: Pose2D, b: Pose2D, last: bool) -> list[Pose2D]:
        x, y, cur = frm
        moves: list[Pose2D] = []
        if math.hypot(b[0] - x, b[1] - y) > 1e-9:
            heading = math.atan2(b[1] - y, b[0] - x)
            back = _wrap(heading + math.pi)
            if allow_reverse and abs(_wrap(back - cur)) < abs(_wrap(heading - cur)):
                heading = back
            moves = [(x, y, heading), (b[0], b[1], heading)]
        if last:
            moves.append(b)
        return [m for i, m in enumerate(moves) if m != ([frm, *moves][i])]

    out: list[Pose2D] = [poses[0]]
    mixed = 0
    n = len(poses) - 1
    for i, (a, b) in enumerate(itertools.pairwise(poses)):
        last = i == n - 1
        moves = tdt(out[-1], b, last)
        if free([out[-1], *moves]):
            out.extend(moves)
            continue
        for u in (0.125, 0.25, 0.5, 0.75, 1.0):
            m = (a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]), _wrap(a[2] + u * _wrap(b[2] - a[2])))
            rest = tdt(m, b, last) if u < 1.0 else []
            if free([out[-1], m]) and free([m, *rest]):
                out.append(m)
                out.extend(rest)
                mixed += 1
                break
        else:
            if not (free([out[-1], a]) and free([a, b])):
                return list(poses), n
            out.extend(p for p in (a, b) if p != out[-1])
            mixed += 1
    return out, mixed


def _states(path: og.PathGeometric) -> list[Pose2D]:
    out = []
    for i in range(path.getStateCount()):
        st = path.getState(i)
        out.append((float(st.getX()), float(st.getY()), float(st.getYaw())))
    return out


# --------------------------------------------------------------------------------------------
# Carry modes (paper, Figure 14)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CarrySegment:
    """A stretch of the path to be driven with the load in the narrow carry mode."""

    start_index: int  # waypoint where the load is turned to narrow
    end_index: int  # waypoint where it is turned back
    start_s_m: float  # arc length along the path
    end_s_m: float


@dataclass(frozen=True)
class CarryEvent:
    """A load rotation to record: ``kind`` is ``"rotate_to_narrow"`` or ``"rotate_back"``."""

    kind: str
    index: int
    s_m: float
    pose: Pose2D


@dataclass(frozen=True)
class CarryPlan:
    """A path for a robot carrying a load, with where to carry it narrow."""

    path: NavPath
    mode: str  # "normal" (never narrow), "narrow" (narrow somewhere) or "" when failed
    segments: tuple[CarrySegment, ...] = ()
    events: tuple[CarryEvent, ...] = ()
    normal_attempt: NavPath | None = None
    extra: dict[str, float] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """Whether a path was found."""
        return self.path.ok

    @property
    def status(self) -> str:
        """``"ok"`` or ``"failed"``."""
        return self.path.status

    @property
    def reason(self) -> str:
        """Why it failed, or how it was found."""
        return self.path.reason


def _arc_lengths(poses: Sequence[Pose2D]) -> npt.NDArray[np.float64]:
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    seg = np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1]))
    return np.concatenate([[0.0], np.cumsum(seg)])


def narrow_intervals(
    poses: Sequence[Pose2D], normal: ConfigurationSpace, margin_m: float, step_m: float
) -> list[tuple[float, float]]:
    """Arc-length intervals of a path where the normal footprint is blocked, grown by ``margin_m``.

    The path is sampled every ``step_m``; overlapping grown intervals are merged.
    """
    dense = _densify(poses, step_m, normal.bin_width / 4)
    s = _arc_lengths(dense)
    ok = normal.is_free_many(dense)
    total = float(s[-1]) if len(s) else 0.0
    intervals: list[tuple[float, float]] = []
    i = 0
    while i < len(ok):
        if ok[i]:
            i += 1
            continue
        j = i
        while j + 1 < len(ok) and not ok[j + 1]:
            j += 1
        lo, hi = max(0.0, float(s[i]) - margin_m), min(total, float(s[j]) + margin_m)
        if intervals and lo <= intervals[-1][1]:
            intervals[-1] = (intervals[-1][0], max(hi, intervals[-1][1]))
        else:
            intervals.append((lo, hi))
        i = j + 1
    return intervals


def _floats3(p: Sequence[float]) -> Pose2D:
    return (float(p[0]), float(p[1]), float(p[2]))


def _insert_at(poses: list[Pose2D], s_target: float) -> int:
    """Insert a waypoint at arc length ``s_target`` (or reuse one within 1 mm); return its index."""
    s = _arc_lengths(poses)
    for i, si in enumerate(s):
        if abs(si - s_target) < 1e-3:
            return i
    i = int(np.searchsorted(s, s_target))  # s[i-1] < s_target < s[i]
    (x0, y0, t0), (x1, y1, t1) = poses[i - 1], poses[i]
    u = float((s_target - s[i - 1]) / (s[i] - s[i - 1]))
    poses.insert(i, (x0 + u * (x1 - x0), y0 + u * (y1 - y0), _wrap(t0 + u * _wrap(t1 - t0))))
    return i


def plan_with_carry_modes(
    grid: OccupancyGrid,
    start: Pose2D,
    goal: Pose2D,
    normal: Footprint,
    narrow: Footprint,
    settings: NavSettings | None = None,
    margin_m: float = 0.5,
) -> CarryPlan:
    """Plan with the normal carry footprint; where it cannot pass, carry the load narrow.

    If the normal footprint finds a path, that is the plan (mode ``"normal"``). Otherwise the path is
    planned with the narrow footprint, and each stretch where the normal footprint is blocked,
    grown by ``margin_m`` on both sides, becomes a :class:`CarrySegment` with a
    ``rotate_to_narrow`` event at its start and a ``rotate_back`` event at its end (new waypoints
    are inserted there). If even the narrow footprint fails, the plan fails with both reasons.
    """
    settings = settings or NavSettings()
    cs_normal = ConfigurationSpace.build(grid, normal, settings.n_yaw_bins, settings.margin_m)
    first = plan_path(cs_normal, start, goal, settings=settings)
    if first.ok:
        return CarryPlan(path=first, mode="normal", normal_attempt=first)
    cs_narrow = ConfigurationSpace.build(grid, narrow, settings.n_yaw_bins, settings.margin_m)
    second = plan_path(cs_narrow, start, goal, settings=settings)
    if not second.ok:
        failed = _failed(f"{second.reason} even with the narrow carry mode ({narrow.name}); "
                         f"normal mode ({normal.name}): {first.reason}",
                         settings.planner, narrow.name,
                         first.planning_time_s + second.planning_time_s)
        return CarryPlan(path=failed, mode="", normal_attempt=first)
    step = settings.check_step_m or grid.resolution / 4
    intervals = narrow_intervals(second.poses, cs_normal, margin_m, step)
    poses = list(second.poses)
    bounds = []
    for lo, hi in intervals:
        bounds.append((_insert_at(poses, lo), _insert_at(poses, hi)))
    # Inserting shifts later indices; recompute them from the final list.
    s_all = _arc_lengths(poses)
    segments, events = [], []
    for lo, hi in intervals:
        i0 = int(np.argmin(np.abs(s_all - lo)))
        i1 = int(np.argmin(np.abs(s_all - hi)))
        segments.append(CarrySegment(i0, i1, float(s_all[i0]), float(s_all[i1])))
        events.append(CarryEvent("rotate_to_narrow", i0, float(s_all[i0]), _floats3(poses[i0])))
        events.append(CarryEvent("rotate_back", i1, float(s_all[i1]), _floats3(poses[i1])))
    del bounds
    path = NavPath(poses=tuple(_floats3(q) for q in poses), length_m=_path_length(poses),
                   planning_time_s=first.planning_time_s + second.planning_time_s,
                   planner=second.planner, status=OK,
                   reason=f"{second.reason} with the narrow carry mode; normal mode: {first.reason}",
                   footprint=narrow.name)
    narrow_len = sum(seg.end_s_m - seg.start_s_m for seg in segments)
    return CarryPlan(path=path, mode="narrow", segments=tuple(segments), events=tuple(events),
                     normal_attempt=first, extra={"narrow_length_m": narrow_len})


# --------------------------------------------------------------------------------------------
# Time parameterisation
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Trajectory:
    """Timed base poses sampled at a fixed rate: ``t_s[i]`` -> ``poses[i]``."""

    t_s: tuple[float, ...]
    poses: tuple[Pose2D, ...]

    @property
    def duration_s(self) -> float:
        """Time from the first to the last sample."""
        return self.t_s[-1] if self.t_s else 0.0


def _trapezoid_time(dist: float, vmax: float, amax: float) -> float:
    if dist <= 0:
        return 0.0
    d_acc = vmax * vmax / amax
    if dist >= d_acc:
        return dist / vmax + vmax / amax
    return 2.0 * math.sqrt(dist / amax)


def _trapezoid_progress(t: float, total_t: float, dist: float, vmax: float, amax: float) -> float:
    """Fraction of ``dist`` covered at time ``t`` of a rest-to-rest trapezoidal profile."""
    if dist <= 0 or total_t <= 0:
        return 1.0
    t = min(max(t, 0.0), total_t)
    # Scale the profile so it takes exactly total_t (when another quantity dominates).
    v_peak_full = min(vmax, math.sqrt(dist * amax))
    t_acc = v_peak_full / amax
    if 2 * t_acc >= total_t:  # triangular, stretched
        t_acc = total_t / 2
    v = dist / (total_t - t_acc)
    a = v / t_acc if t_acc > 0 else float("inf")
    if t < t_acc:
        d = 0.5 * a * t * t
    elif t <= total_t - t_acc:
        d = 0.5 * v * t_acc + v * (t - t_acc)
    else:
        tr = total_t - t
        d = dist - 0.5 * a * tr * tr
    return min(1.0, max(0.0, d / dist))


def time_parameterize(
    path: NavPath | Sequence[Pose2D],
    max_speed_mps: float,
    max_yaw_rate_rps: float,
    max_accel_mps2: float = 1.0,
    max_yaw_accel_rps2: float = 2.0,
    rate_hz: float = 10.0,
) -> Trajectory:
    """Timed samples along a path, stopping at each waypoint (rest-to-rest trapezoids per segment).

    Each segment takes the longer of its translation time (``max_speed_mps``, ``max_accel_mps2``)
    and its rotation time (``max_yaw_rate_rps``, ``max_yaw_accel_rps2``); translation and rotation
    progress together along that time, so neither limit is exceeded. Samples are ``1 / rate_hz``
    apart, plus the final pose.
    """
    poses = list(path.poses if isinstance(path, NavPath) else path)
    if min(max_speed_mps, max_yaw_rate_rps, max_accel_mps2, max_yaw_accel_rps2, rate_hz) <= 0:
        raise KbplannerError("speed, yaw rate, accelerations and rate must be positive",
                             element="time_parameterize", fix="give the robot's limits (> 0)")
    if not poses:
        return Trajectory((), ())
    seg_t: list[float] = []
    for a, b in itertools.pairwise(poses):
        d = math.hypot(b[0] - a[0], b[1] - a[1])
        dyaw = abs(_wrap(b[2] - a[2]))
        seg_t.append(max(_trapezoid_time(d, max_speed_mps, max_accel_mps2),
                         _trapezoid_time(dyaw, max_yaw_rate_rps, max_yaw_accel_rps2)))
    starts = np.concatenate([[0.0], np.cumsum(seg_t)])
    total = float(starts[-1])
    n = math.floor(total * rate_hz + 1e-9)
    times = [i / rate_hz for i in range(n + 1)]
    if total - times[-1] > 1e-9:
        times.append(total)
    out: list[Pose2D] = []
    for t in times:
        i = min(int(np.searchsorted(starts, t, side="right")) - 1, len(seg_t) - 1)
        if i < 0 or not seg_t:
            out.append(poses[0])
            continue
        a, b = poses[i], poses[i + 1]
        d = math.hypot(b[0] - a[0], b[1] - a[1])
        dyaw = _wrap(b[2] - a[2])
        ts = t - float(starts[i])
        if d >= abs(dyaw) * max_speed_mps / max_yaw_rate_rps:
            u = _trapezoid_progress(ts, seg_t[i], d, max_speed_mps, max_accel_mps2)
        else:
            u = _trapezoid_progress(ts, seg_t[i], abs(dyaw), max_yaw_rate_rps, max_yaw_accel_rps2)
        out.append((a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]), _wrap(a[2] + u * dyaw)))
    return Trajectory(tuple(round(t, 9) for t in times), tuple(out))


# --------------------------------------------------------------------------------------------
# Yardstick: grid shortest path
# --------------------------------------------------------------------------------------------


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
    most of the 8-connected metric's excess (up to 8 %) over straight lines.
    """
    if isinstance(grid, ConfigurationSpace):
        cs = grid
    else:
        if footprint is None:
            raise KbplannerError("grid_shortest_path_length on a grid needs a footprint",
                                 element="grid_shortest_path_length", fix="pass footprint=...")
        cs = ConfigurationSpace.build(grid, footprint, n_yaw_bins)
    free = cs.free_any_yaw()
    g = cs.grid
    ny, nx = g.shape
    (sx, sy), (gx, gy) = g.cell_of(start[0], start[1]), g.cell_of(goal[0], goal[1])
    if not (0 <= sx < nx and 0 <= sy < ny and 0 <= gx < nx and 0 <= gy < ny):
        return math.inf
    if not (free[sy, sx] and free[gy, gx]):
        return math.inf
    dist = np.full((ny, nx), np.inf)
    prev = np.full((ny, nx), -1, dtype=np.int64)
    dist[sy, sx] = 0.0
    heap: list[tuple[float, int, int]] = [(0.0, sy, sx)]
    moves = [(dy, dx, math.hypot(dy, dx)) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    free_l = free.tolist()
    dist_l = dist.tolist()
    while heap:
        d, y, x = heapq.heappop(heap)
        if d > dist_l[y][x]:
            continue
        if y == gy and x == gx:
            break
        for dy, dx, c in moves:
            yy, xx = y + dy, x + dx
            if 0 <= yy < ny and 0 <= xx < nx and free_l[yy][xx]:
                nd = d + c
                if nd < dist_l[yy][xx]:
                    dist_l[yy][xx] = nd
                    prev[yy, xx] = y * nx + x
                    heapq.heappush(heap, (nd, yy, xx))
    if not math.isfinite(dist_l[gy][gx]):
        return math.inf
    cells = [(gy, gx)]
    while cells[-1] != (sy, sx):
        p = int(prev[cells[-1]])
        cells.append((p // nx, p % nx))
    cells.reverse()
    pts = [(float(start[0]), float(start[1]))]
    pts += [g.center_of(x, y) for y, x in cells[1:-1]]
    pts.append((float(goal[0]), float(goal[1])))

    def visible(a: tuple[float, float], b: tuple[float, float]) -> bool:
        n = max(1, math.ceil(math.hypot(b[0] - a[0], b[1] - a[1]) / (g.resolution / 2)))
        u = np.linspace(0.0, 1.0, n + 1)
        xs, ys = a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])
        ix = np.floor((xs - g.origin[0]) / g.resolution).astype(np.int64)
        iy = np.floor((ys - g.origin[1]) / g.resolution).astype(np.int64)
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        return bool(inside.all() and free[iy, ix].all())

    length = 0.0
    i = 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1 and not visible(pts[i], pts[j]):
            j -= 1
        length += math.hypot(pts[j][0] - pts[i][0], pts[j][1] - pts[i][1])
        i = j
    return length
