"""Navigation (B5, skills NV-1 and NV-2): SE(2) path planning with OMPL on an occupancy grid.

Takes an :class:`~kbplanner.world.occupancy.OccupancyGrid`, a start and goal pose (x, y, yaw; site frame,
metres, radians) and a :class:`~kbplanner.world.footprint.Footprint` (the base, plus the carried object in
its carry pose); returns a :class:`~kbplanner.simulation.nav_path.NavPath` with a status and a reason
(never an exception for an unreachable goal). Validity checks are array look-ups in a precomputed
:class:`~kbplanner.world.footprint.ConfigurationSpace` (one map per yaw bin), motions are checked exactly
(:mod:`kbplanner.simulation.motion_check`). The planner (RRTConnect by default, or BIT*/InformedRRT* with
a time budget) is seeded through ``ou.RNG.setSeed``, so the same seed gives the same path; the solution
is shortcut-simplified and re-checked densely. Where free cells certainly join start and goal but
RRTConnect finds nothing within its first budget, the cell path is taken
(:mod:`kbplanner.simulation.cell_path`). Whether the goal is walled off is asked only of a search that
has made :data:`PLANE_AFTER_CHECKS` motion checks without a path (of the plane: cells free in some yaw
bin, :func:`apart_in_plane`), :data:`WALLED_OFF_AFTER_CHECKS` (of the labelled space), or has failed (a
path found proves it is not): the answer is that of asking before planning, mostly without labelling
the space. A goal walled off on the whole map is so in its windows (``known_walled_off``).

The rest of navigation: settings and path types (:mod:`kbplanner.simulation.nav_path`), the doorway
behaviour of the paper (:mod:`kbplanner.simulation.carry_paths`), timed samples
(:mod:`kbplanner.simulation.base_trajectory`) and the yardstick for path quality
(:mod:`kbplanner.simulation.grid_yardstick`).

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

import logging
import math
import time
from collections.abc import Callable

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from kbplanner.core.errors import KbplannerError
from kbplanner.simulation.cell_path import cell_route, face_connected
from kbplanner.simulation.motion_check import ExactMotion, free_bytes, shortcut
from kbplanner.simulation.nav_path import (
    OK,
    PLANNERS,
    NavPath,
    NavSettings,
    Pose2D,
    failed_path,
    path_length,
    wrap,
)
from kbplanner.simulation.turn_around import skid_steer
from kbplanner.world.footprint import ConfigurationSpace, Footprint
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

CERTAIN_PASSAGE_CHECKS = 100_000  # OMPL's budget where free cells certainly join start and goal
# Whether start and goal are walled off from each other is asked only once the planner has used this many
# motion checks without a path (all but the hardest queries end sooner; labelling a space to answer it costs
# about as much as 10,000-20,000 checks): a path found proves them joined.
WALLED_OFF_AFTER_CHECKS = 50_000
# Whether the plane (cells free in some yaw bin, labelled in 2D: a few milliseconds) walls them off is asked
# sooner, once the planner has used this many checks without a path (:func:`apart_in_plane`).
PLANE_AFTER_CHECKS = 2_000
WALLED_OFF = "no path: the goal is walled off from the start for this footprint"


def _connected(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> bool:
    """Whether start and goal share a component of the discretised free space (x, y, yaw bin).

    26-connectivity with the yaw axis closed into a ring over-connects, so "not connected" is
    certain: no continuous path exists in the (conservative) configuration space.
    """
    return cs.joined(start, goal, diagonal=True)  # labels the whole space only where boxes do not decide


class _WalledOff:
    """Whether start and goal are walled off (not :func:`_connected`), asked at most once, lazily.

    The planner is not told beforehand: every motion of its path passed the exact motion check, which
    checks a face-connected chain of free cells, so a path found proves start and goal joined and the
    answer would have been "no". It is asked from the planner's termination condition once the planner has
    used :data:`WALLED_OFF_AFTER_CHECKS` motion checks (a read-only question: the search goes on exactly as
    it would have), and after a failed search; "yes" stops the search with the result a check before
    planning gives. Face-adjacent free cells that join them (:func:`face_connected`, asked first and kept
    for the cell path) answer "no" as well: they are 26-connected too.
    """

    def __init__(self, cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> None:
        self.cs, self.start, self.goal = cs, start, goal
        self.answer: bool | None = None
        self.face: bool | None = None
        self.plane: bool | None = None

    def face_joined(self) -> bool:
        """:func:`face_connected` of start and goal, computed once (False at once where they are
        :func:`apart_in_plane`)."""
        if self.face is None:
            self.face = not self.apart() and face_connected(self.cs, self.start, self.goal)
        return self.face

    def apart(self) -> bool:
        """:func:`apart_in_plane` of start and goal, computed once."""
        if self.plane is None:
            self.plane = apart_in_plane(self.cs, self.start, self.goal)
        return self.plane

    def __call__(self) -> bool:
        if self.answer is None:
            self.answer = self.apart() or not (self.face_joined()
                                               or _connected(self.cs, self.start, self.goal))
        return self.answer


def apart_in_plane(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> bool:
    """Whether start and goal are certainly walled off, told from the plane: the cells free in some yaw
    bin, 8-connected (labelled once per space), do not join their cells. A chain of free (x, y, yaw bin)
    cells, 26-connected, lies on such cells, each next to the one before (or the same): where the plane
    does not join them, neither do :func:`_connected` nor :func:`face_connected` - the same answer as
    labelling the space, at a small part of its cost (a worker standing in a passage walls it off for
    every heading)."""
    ends = [cs._cell(*start), cs._cell(*goal)]
    if ends[0] is None or ends[1] is None:
        return True
    key = ("any yaw", True)
    plane = cs.open_memo.get(key)
    if plane is None:
        from scipy import ndimage  # imported here: the module is imported by commands that never plan

        ring = np.ones((3, 3), dtype=bool)
        plane = ndimage.label(cs.free.any(axis=0), structure=ring)[0].astype(np.int32)
        cs.open_memo[key] = plane
    a, b = plane[ends[0][1:]], plane[ends[1][1:]]
    return bool(a == 0 or a != b)


def is_walled_off(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> bool:
    """Whether start and goal (both free) are walled off from each other in ``cs`` (what a failed
    :func:`plan_path` asks, :class:`_WalledOff`). Where it holds in a space, it holds in every space of the
    same footprint whose free cells are among these - a window of its map (cells off a window count as
    occupied) - and :func:`plan_path` there, told so, fails at once with the reason planning gives."""
    return _WalledOff(cs, start, goal)()


def _validity_checker(cs: ConfigurationSpace) -> Callable[[ob.State], bool]:
    """A fast Python validity checker: one bytes look-up per state."""
    free = free_bytes(cs)
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


class _OmplMotionValidator(ob.MotionValidator):
    def __init__(self, si: ob.SpaceInformation, exact: ExactMotion) -> None:
        super().__init__(si)
        self.exact = exact
        self.free6 = exact.free6

        self.calls = 0
        self.alarm: float = math.inf  # when calls reaches it, ring() is called
        self.ring: Callable[[], None] = _nothing

    def checkMotion(self, s1: ob.State, s2: ob.State) -> bool:  # OMPL's method name
        self.calls += 1
        if self.calls >= self.alarm:
            self.ring()
        return self.free6(s1.getX(), s1.getY(), s1.getYaw(), s2.getX(), s2.getY(), s2.getYaw())


def _nothing() -> None:
    return None


def _asked_walled_off(walled_off: _WalledOff | None, calls: int) -> bool:
    """Whether a search without a path that has made ``calls`` motion checks stops as walled off: from
    PLANE_AFTER_CHECKS checks on where the plane says so, from WALLED_OFF_AFTER_CHECKS on where the
    labels do (the same answer: :func:`apart_in_plane` is certain)."""
    if walled_off is None:
        return False
    if calls >= PLANE_AFTER_CHECKS and walled_off.apart():
        return True
    return calls >= WALLED_OFF_AFTER_CHECKS and walled_off()


def _run(ss: og.SimpleSetup, validator: _OmplMotionValidator, limit: int, deadline: float,
         walled_off: _WalledOff | None) -> ob.PlannerStatus:
    """``ss.solve`` until the validator has made ``limit`` motion checks, the clock passes ``deadline`` or
    ``walled_off`` says so (:func:`_asked_walled_off`).

    The planner asks its termination condition at every iteration; rather than a Python condition asked
    each time, the clock is OMPL's own condition and the work budget is an alarm of the validator that
    ends the condition (``terminate``) at the very check after which the counted condition first holds:
    the planner stops at the same point either way, for the checks only grow.
    """
    ptc = ob.timedPlannerTerminationCondition(max(0.0, deadline - time.perf_counter()))

    def holds() -> bool:
        calls = validator.calls
        if calls >= limit:
            return True
        return _asked_walled_off(walled_off, calls)

    def ring() -> None:
        if holds():
            ptc.terminate()
            validator.alarm = math.inf
        else:  # the next count at which holds() may change
            calls = validator.calls
            steps = [PLANE_AFTER_CHECKS, WALLED_OFF_AFTER_CHECKS] if walled_off is not None else []
            validator.alarm = min([limit, *(c for c in steps if c > calls)])

    validator.ring = ring
    ring()
    try:
        return ss.solve(ptc)
    finally:
        validator.alarm = math.inf  # simplifying the path checks motions too


def plan_path(
    space: OccupancyGrid | ConfigurationSpace,
    start: Pose2D,
    goal: Pose2D,
    footprint: Footprint | None = None,
    settings: NavSettings | None = None,
    *,
    known_walled_off: bool = False,
) -> NavPath:
    """Plan a collision-free SE(2) path for ``footprint`` from ``start`` to ``goal``.

    Args:
        space: an occupancy grid (the configuration space is built for ``footprint``) or a prebuilt
            :class:`ConfigurationSpace` (reuse it for many queries with one footprint).
        start, goal: (x, y, yaw) in the site frame, metres and radians.
        footprint: required with a grid; ignored with a configuration space.
        settings: planner, time budget, seed, ...
        known_walled_off: start and goal are known to be walled off from each other (:func:`is_walled_off`
            of a space whose free cells include these, e.g. the whole map's where this is a window): once
            start and goal are found free, the plan fails at once with the reason planning gives (no path
            can be found, and a failed search asks that question: the same result, without planning).

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
            return failed_path(f"no path: {label} ({pose[0]:.2f}, {pose[1]:.2f}) is off the map", name, fp)
        if not cs.is_free(*pose):
            return failed_path(f"no path: {label} in collision", name, fp)
    if known_walled_off:
        return failed_path(WALLED_OFF, name, fp)
    walled_off = _WalledOff(cs, start, goal)
    t0 = time.perf_counter()
    certain: list[bool] = []

    def cells_certain() -> bool:
        """Asked once, when RRTConnect has used CERTAIN_PASSAGE_CHECKS without a path."""
        certain.append(walled_off.face_joined())
        return certain[-1]

    level = ou.getLogLevel()
    ou.setLogLevel(ou.LogLevel.LOG_INFO if log.isEnabledFor(logging.DEBUG) else ou.LogLevel.LOG_WARN)
    try:
        result = _solve(cs, start, goal, settings, t0, cells_certain if settings.cell_fallback else None,
                        walled_off)
    finally:
        ou.setLogLevel(level)
    if not result.ok and walled_off():
        return failed_path(WALLED_OFF, name, fp)
    if result.ok or not (certain and certain[-1]):
        return result
    cells = cell_route(cs, start, goal, settings, t0, result.reason)
    return result if cells is None else cells


def _solve(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, settings: NavSettings, t0: float,
           cells_certain: Callable[[], bool] | None = None,
           walled_off: _WalledOff | None = None) -> NavPath:
    """RRTConnect within the work budget. With ``cells_certain``: after CERTAIN_PASSAGE_CHECKS motion
    checks without a path it is asked whether free cells certainly join start and goal; if so, planning
    stops there (the caller takes the cell path), else the same tree grows on to the full budget. With
    ``walled_off``: after PLANE_AFTER_CHECKS motion checks without a path the plane, after
    WALLED_OFF_AFTER_CHECKS the labels are asked (once each) whether start and goal are walled off; if so,
    planning stops (the caller reports it)."""
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
    motion = ExactMotion(cs)
    validator = _OmplMotionValidator(si, motion)  # kept referenced until planning ends
    si.setMotionValidator(validator)
    planner = PLANNERS[name](si)
    ss.setPlanner(planner)
    s, g = space_se2.allocState(), space_se2.allocState()
    s.setXY(start[0], start[1])
    s.setYaw(wrap(start[2]))
    g.setXY(goal[0], goal[1])
    g.setYaw(wrap(goal[2]))
    ss.setStartAndGoalStates(s, g)
    deadline = time.perf_counter() + settings.time_limit_s
    budget = settings.max_motion_checks
    first = min(budget, CERTAIN_PASSAGE_CHECKS) if cells_certain is not None else budget
    status = _run(ss, validator, first, deadline, walled_off)
    if not ss.haveExactSolutionPath() and _asked_walled_off(walled_off, validator.calls):
        del ss, planner
        return failed_path(WALLED_OFF, name, fp)
    if cells_certain is not None and not ss.haveExactSolutionPath() and time.perf_counter() <= deadline:
        if cells_certain():
            budget = first  # the caller takes the cell path
        elif first < budget:
            # The planner keeps its trees: this continues the same search.
            status = _run(ss, validator, budget, deadline, None)
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
        return failed_path(reason, name, fp, elapsed)
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
        return failed_path("no path: the planner's path failed the dense re-check", name, fp, elapsed)
    poses[0] = (start[0], start[1], wrap(start[2]))
    if settings.simplify:
        poses = shortcut(motion, poses, grid.resolution * 5)
    elapsed = time.perf_counter() - t0
    if settings.base_motion == "turn_drive_turn":
        poses, kept = skid_steer(cs, poses, allow_reverse=settings.allow_reverse,
                                 limits=settings.base_limits, reverse_s_per_m=settings.reverse_s_per_m)
        how += "; turn-drive-turn" + (f" ({kept} segment(s) partly turning while driving)" if kept else "")
        elapsed = time.perf_counter() - t0
    return NavPath(poses=tuple(poses), length_m=path_length(poses), planning_time_s=elapsed,
                   planner=name, status=OK, reason=how, footprint=fp)


def _states(path: og.PathGeometric) -> list[Pose2D]:
    out = []
    for i in range(path.getStateCount()):
        st = path.getState(i)
        out.append((float(st.getX()), float(st.getY()), float(st.getYaw())))
    return out
