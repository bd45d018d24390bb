"""B4, the carry leg: can the robot holding an element drive from its pick base pose to an install base pose?

The navigation with object (B5 NV-2, :func:`kbplanner.simulation.carry_paths.plan_with_carry_modes` and
the load turned at a standstill, :mod:`kbplanner.simulation.skills.navigation`) plans in the
configuration spaces (:class:`~kbplanner.world.footprint.ConfigurationSpace`, 72 yaw bins, the
conservative cell test) of two footprints: the robot with the element carried *normal* and carried
*narrow* (:class:`~kbplanner.planning.carry.CarryGeometry`). Before any search it gives up when start
and goal lie in different components of free (x, y, yaw bin) cells, 26-connected with the yaw axis
closed into a ring ("the goal is walled off from the start for this footprint"): that labelling
over-connects, so different components are certainly apart.

:class:`CarryReach` labels the same cells once per grid, carry geometry and pick base pose, and joins
the two modes where a cell is free for both (where the load can be turned in place), so that each
install base pose candidate is one array look-up: it is reachable only when it lies in the start's
joint component. Like the navigation, the labels are built on windows of the grid around the pick
base pose and the installed pose (growing margins, then the whole map; a window's cells off the grid
count as occupied, so what is connected in a window is connected on the map): a candidate joined in a
window is reachable, one that is not is judged on a larger window, and is unreachable only on the
whole map, unless the start's or the goal's component stays clear of the window's edges (then it
is the same on the map, and final). Where the robot starts in cells its configuration space calls
blocked, it starts from the nearest free pose, as the navigation does
(:func:`~kbplanner.planning.base_poses.nearest_free_pose`). Each question is first asked of a part of
the window around the poses (:class:`~kbplanner.world.cspace_join.PartJoin`, its own labels; joined
there is joined on the window), so that most are answered without building and labelling the whole
window: the same answers, cheaper.

:func:`carry_leg_reason` says why no candidate was reachable, with figures: how wide the robot is with
the element carried each way, whether the robot alone gets there (then the load, not the walls, is
the problem), and which element installed before closes the way (the first whose footprint, added
to the map in install order, separates the pick base pose from the install base poses).

Example:
    >>> import numpy as np
    >>> from kbplanner.planning.carry import CarryMode
    >>> from kbplanner.world.footprint import Footprint, Rect
    >>> occ = np.zeros((80, 120), dtype=bool); occ[:, 60] = True; occ[35:45, 60] = False  # 0.5 m door
    >>> grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
    >>> base = Footprint((Rect(0, 0, 0.4, 0.3),), "base")
    >>> eye = np.eye(4)
    >>> geo = CarryGeometry(base, CarryMode("normal", (0.0,), eye, Rect(0, 0, 0.2, 1.6), 0.1),
    ...                     CarryMode("narrow", (0.0,), eye, Rect(0, 0, 1.6, 0.1), 0.1))
    >>> reach = CarryReach(grid, carry_footprints(geo), Pose2(1.5, 2.0, 0.0), (4.5, 2.0))
    >>> reach.reaches(Pose2(4.5, 2.0, 0.0))       # narrow, along the heading, through the door
    True
    >>> wide = CarryGeometry(base, geo.normal, CarryMode("narrow", (0.0,), eye, Rect(0, 0, 0.2, 1.6), 0.1))
    >>> CarryReach(grid, carry_footprints(wide), Pose2(1.5, 2.0, 0.0), (4.5, 2.0)).reaches(
    ...     Pose2(4.5, 2.0, 0.0))
    False
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import shapely

from kbplanner.planning.base_poses import N_YAW_BINS, PoseChecker, mark_polygon, nearest_free_pose, window
from kbplanner.planning.carry import NARROW, NORMAL, CarryGeometry
from kbplanner.planning.carry_parts import WindowParts, joint_components
from kbplanner.planning.plan_model import Pose2
from kbplanner.world.cspace_cache import configuration_space
from kbplanner.world.footprint import ConfigurationSpace, Footprint
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

#: Window margins (m) around the pick base pose and the installed pose: the navigation's (4 m, 10 m,
#: the whole map), grown by the arm's reach (install base poses lie up to that far from the target).
WINDOW_MARGINS_M: tuple[float | None, ...] = (6.0, 12.0, None)
#: Maps of more cells (x, y) are not labelled whole (72 yaw bins, two footprints: seconds per element):
#: there the largest window decides (a way that leaves it is not counted, and the reason says so).
WHOLE_MAP_MAX_CELLS = 250_000
#: The window that names what closes a way (:func:`first_blocker`, :func:`reaches_alone`): the first only,
#: as the bisection builds it several times (a hint for the reason and the install order, which B4
#: checks again; the verdict is :class:`CarryReach`'s).
BLOCKER_MARGINS_M: tuple[float | None, ...] = WINDOW_MARGINS_M[:1]


@dataclass
class _Level:
    """The joint components on one window: per mode its configuration space and labels."""

    grid: OccupancyGrid
    spaces: tuple[ConfigurationSpace, ...]
    labels: tuple[npt.NDArray[np.int32], ...]
    offsets: tuple[int, ...]  # node offset of each mode in ``joint``
    roots: tuple[npt.NDArray[np.int64], ...]
    joint: npt.NDArray[np.int64]  # node -> joint component
    open: frozenset[int]  # joint components (+1) with a cell near a window edge that is not the map's
    start: int  # the start's joint component, 0 when the start is blocked in every mode

    def component(self, pose: Pose2) -> int:
        """The joint component of a pose (0: blocked in every mode or off the window)."""
        g = self.grid
        ix, iy = g.cell_of(pose.x, pose.y)
        ny, nx = g.shape
        if not (0 <= ix < nx and 0 <= iy < ny):
            return 0
        for cs, lab, off, roots in zip(self.spaces, self.labels, self.offsets, self.roots, strict=True):
            label = int(lab[cs.yaw_bin(pose.yaw), iy, ix])
            if label:
                return int(self.joint[off + int(roots[label])]) + 1
        return 0


def carry_footprints(geo: CarryGeometry) -> tuple[Footprint, ...]:
    """The footprints the navigation with object plans with: the robot + element carried normal, narrow."""
    return (geo.footprint(NORMAL), geo.footprint(NARROW))


class CarryReach:
    """Which base poses the robot holding an element reaches from ``start`` on ``grid`` (module docstring).

    ``footprints``: the robot's footprints the navigation may switch between standing still (the carry
    modes, :func:`carry_footprints`; the base alone for a robot without a load). ``around`` is the
    (x, y) the goals lie near (the installed pose); windows are cut around it and the start.
    Levels are built lazily, each once.
    """

    def __init__(self, grid: OccupancyGrid, footprints: Sequence[Footprint], start: Pose2,
                 around: tuple[float, float], *, margins: Sequence[float | None] = WINDOW_MARGINS_M,
                 n_bins: int = N_YAW_BINS) -> None:
        self.grid = grid
        self.footprints = tuple(footprints)
        self.n_bins = n_bins
        self.margins = tuple(margins)
        self.around = around
        checker = PoseChecker(grid, n_bins)
        s = (start.x, start.y, start.yaw)
        if not any(checker.free(f, *s) for f in self.footprints):
            moved = nearest_free_pose(checker, s, list(self.footprints))
            s = moved if moved is not None else s
        self.start = Pose2(*s)
        self._levels: dict[int, _Level] = {}
        self.reason: str | None = None  # the caller's reason once no goal was reachable (kept with it)
        self._spaces: dict[tuple[int, int], ConfigurationSpace] = {}
        self._windows: dict[int, tuple[OccupancyGrid, PoseChecker]] = {}
        self._parts = WindowParts(self._window, self.footprints, around, n_bins)
        n_cells = grid.shape[0] * grid.shape[1]
        # the whole map only where it is small enough to label quickly; else the largest window is final
        self.capped = self.margins[-1] is None and n_cells > WHOLE_MAP_MAX_CELLS and len(self.margins) > 1
        if self.capped:
            self.margins = self.margins[:-1]

    def _window(self, i: int) -> OccupancyGrid:
        return self._window_checker(i)[0]

    def _window_checker(self, i: int) -> tuple[OccupancyGrid, PoseChecker]:
        """Window ``i`` and a pose checker on it (each made once)."""
        got = self._windows.get(i)
        if got is None:
            win = window(self.grid, [(self.start.x, self.start.y), self.around], self.margins[i])
            got = (win, PoseChecker(win, self.n_bins))
            self._windows[i] = got
        return got

    def _space(self, i: int, k: int) -> ConfigurationSpace:
        """Footprint ``k``'s configuration space on window ``i`` (built once; its labels, 26-connected,
        when first asked for, :meth:`~kbplanner.world.footprint.ConfigurationSpace.labels_and_roots`)."""
        cs = self._spaces.get((i, k))
        if cs is None:
            t0 = time.perf_counter()
            cs = configuration_space(self._window(i), self.footprints[k], self.n_bins)
            self._spaces[(i, k)] = cs
            log.debug("carry reach: footprint %d on window %d (%s cells): %.2f s", k, i, cs.grid.shape,
                      time.perf_counter() - t0)
        return cs

    def _joins(self, i: int, k: int, a: Pose2, b: Pose2) -> bool:
        """Whether footprint ``k`` joins ``a`` and ``b`` on window ``i`` (26-connected, the yaw ring).

        The same answer as the window's configuration space gives
        (:meth:`~kbplanner.world.footprint.ConfigurationSpace.joined`), without building it where a
        pose is blocked for the footprint (the kernel test on the window's cells) or a part of the
        window around the poses decides (:class:`~kbplanner.world.cspace_join.PartJoin`).
        """
        pa, pb = (a.x, a.y, a.yaw), (b.x, b.y, b.yaw)
        cs = self._spaces.get((i, k))
        if cs is None or True not in cs.memo:
            _win, checker = self._window_checker(i)
            fp = self.footprints[k]
            if not (checker.free(fp, *pa) and checker.free(fp, *pb)):
                return False
            got = self._parts.joins(i, k, a, b)
            if got is not None:
                return got
        return self._space(i, k).joined(pa, pb, diagonal=True)

    def _first_joins(self, goal: Pose2) -> bool:
        """Whether the first footprint alone (the normal carry: the navigation's first try) joins the
        start and ``goal`` on the smallest window."""
        return self._joins(0, 0, self.start, goal)

    def _level(self, i: int) -> _Level:
        level = self._levels.get(i)
        if level is None:
            parts = [(cs, *cs.labels_and_roots(True))
                     for cs in (self._space(i, k) for k in range(len(self.footprints)))]
            sub = parts[0][0].grid
            offsets, joint = joint_components([(lab, root) for _cs, lab, root in parts])
            band = self._band(sub)
            touching: set[int] = set()
            for (_cs, lab, root), off in zip(parts, offsets, strict=True):
                hit = np.unique(lab[:, band])
                hit = hit[hit > 0]
                touching.update(int(j) + 1 for j in joint[off + root[hit]])
            level = _Level(sub, tuple(p[0] for p in parts), tuple(p[1] for p in parts), offsets,
                           tuple(p[2] for p in parts), joint, frozenset(touching), 0)
            level.start = level.component(self.start)
            self._levels[i] = level
            log.debug("carry reach: level %d, %s cells, start component %d", i, sub.shape, level.start)
        return level

    def _band(self, sub: OccupancyGrid) -> npt.NDArray[np.bool_]:
        """Cells of window ``sub`` whose free/blocked state may differ on the whole map: within the
        largest footprint's radius (plus two cells) of a window edge that is not an edge of the map."""
        res = self.grid.resolution
        k = math.ceil((max(f.radius_m for f in self.footprints) + 2 * res) / res)
        band = np.zeros(sub.shape, dtype=bool)
        ix0 = round((sub.origin[0] - self.grid.origin[0]) / res)
        iy0 = round((sub.origin[1] - self.grid.origin[1]) / res)
        ny, nx = self.grid.shape
        sy, sx = sub.shape
        if ix0 > 0:
            band[:, :k] = True
        if ix0 + sx < nx:
            band[:, -k:] = True
        if iy0 > 0:
            band[:k, :] = True
        if iy0 + sy < ny:
            band[-k:, :] = True
        return band

    def start_blocked(self) -> bool:
        """Whether the robot holding the element fits neither way at (or near) the start."""
        return self._level(0).start == 0

    def direct(self, goal: Pose2) -> bool:
        """Whether one footprint alone joins the start and ``goal`` on the first two windows: the
        navigation's first plan (normal carry, else narrow all the way) gets there without turning the
        load at a standstill."""
        for i in range(min(2, len(self.margins))):
            for k in range(len(self.footprints)):
                if self._joins(i, k, self.start, goal):
                    return True
        return False

    def way(self, goal: Pose2) -> int:
        """2: :meth:`direct`; 1: reachable only by changing footprint on the way (:meth:`reaches`); 0: not."""
        if self._first_joins(goal):
            return 2
        if not self.reaches(goal):
            return 0
        return 2 if self.direct(goal) else 1

    def joins(self, k: int, a: Pose2, b: Pose2) -> bool:
        """Whether footprint ``k`` alone joins ``a`` and ``b`` on one of the first two windows."""
        return any(self._joins(i, k, a, b) for i in range(min(2, len(self.margins))))

    def turn_route(self, goal: Pose2) -> str | None:
        """None when the navigation's way of turning the load on the way gets to ``goal``, else why not.

        As the navigation with object does when no carry mode drives from start to goal: where only one
        carry footprint fits at the start (or the goal), the load is turned at the nearest pose where both
        fit (:func:`turn_pose`: rings of 0.25 m around it); the robot drives start -> that pose in the
        footprint that fits at the start, then to the turning pose near the goal in either carry mode,
        then to the goal in the footprint that fits there. Each leg must be joined in its footprint.
        """
        checker = PoseChecker(self.grid, self.n_bins)
        fps = self.footprints
        fits_s = [k for k, f in enumerate(fps) if checker.free(f, self.start.x, self.start.y, self.start.yaw)]
        fits_g = [k for k, f in enumerate(fps) if checker.free(f, goal.x, goal.y, goal.yaw)]
        if not fits_s or not fits_g:
            return "the held element fits neither way at the " + ("pick" if not fits_s else "install") + \
                " base pose"
        v1 = self.start if len(fits_s) == len(fps) else turn_pose(checker, fps, self.start)
        v2 = goal if len(fits_g) == len(fps) else turn_pose(checker, fps, goal)
        if v1 is None or v2 is None:
            where = self.start if v1 is None else goal
            return (f"no pose within {TURN_RINGS * TURN_RING_M:g} m of ({where.x:.2f}, {where.y:.2f}) where "
                    "the held element fits both ways, to turn it")
        if not self.joins(fits_s[0], self.start, v1):
            return (f"the place to turn the load nearest the pick base pose, ({v1.x:.2f}, {v1.y:.2f}), is "
                    "not reachable from it")
        if not any(self.joins(k, v1, v2) for k in range(len(fps))):
            return (f"no carry mode drives from the turning place ({v1.x:.2f}, {v1.y:.2f}) to the one near "
                    f"the install base pose ({v2.x:.2f}, {v2.y:.2f})")
        if not self.joins(fits_g[0], v2, goal):
            return (f"the install base pose is not reachable from the place to turn the load nearest it "
                    f"({v2.x:.2f}, {v2.y:.2f})")
        return None

    def reaches(self, goal: Pose2) -> bool:
        """Whether ``goal`` lies in the start's joint component (on the smallest window that joins them)."""
        if self._first_joins(goal):
            return True
        if 0 not in self._levels and self._parts.reaches(self.start, goal):
            return True
        for i in range(len(self.margins)):
            level = self._level(i)
            if not level.start:
                return False
            there = level.component(goal)
            if there == level.start:
                return True
            if level.start not in level.open or (there and there not in level.open):
                return False  # one of the two components is closed within the window: as on the map
        return False


TURN_RING_M = 0.25
TURN_RINGS = 12


def turn_pose(checker: PoseChecker, footprints: Sequence[Footprint], near: Pose2) -> Pose2 | None:
    """The nearest pose to ``near`` where every footprint fits: rings of :data:`TURN_RING_M` (at most
    :data:`TURN_RINGS`), 16 bearings from behind the robot, yaws: the robot's, turned by +-90 degrees,
    reversed; where the navigation with object (B5) turns the held element."""
    for k in range(1, TURN_RINGS + 1):
        r = TURN_RING_M * k
        for j in range(16):
            bearing = near.yaw + math.pi + j * math.pi / 8  # behind the robot first
            x, y = near.x + r * math.cos(bearing), near.y + r * math.sin(bearing)
            for yaw in (near.yaw, near.yaw + math.pi / 2, near.yaw - math.pi / 2, near.yaw + math.pi):
                if all(checker.free(f, x, y, yaw) for f in footprints):
                    return Pose2(x, y, math.atan2(math.sin(yaw), math.cos(yaw)))
    return None


def _size(fp: Footprint) -> tuple[float, float]:
    """(length along the heading, width across it) of a footprint's bounding box, m."""
    x0, y0, x1, y1 = fp.bounds_m()
    return x1 - x0, y1 - y0


@dataclass(frozen=True)
class Blocker:
    """The element installed before that closes the carry way (the first in install order)."""

    iri: str
    label: str


def first_blocker(base_grid: OccupancyGrid, installed: Sequence[tuple[str, str, shapely.Geometry]],
                  geo: CarryGeometry, start: Pose2, goals: Sequence[Pose2],
                  around: tuple[float, float], *, known_closed: bool = False) -> Blocker | None:
    """The first element of ``installed`` (iri, label, floor polygon; in install order) whose footprint,
    added to ``base_grid`` with those before it, leaves no goal reachable from ``start``; None when the
    way is closed even with none of them (the walls, the storage or the site close it).

    Bisection over the number of elements installed (reachability only shrinks as elements are added);
    ``known_closed``: the caller saw no goal reachable with all of them (not checked again).
    """
    def reachable(k: int) -> bool:
        g = base_grid
        for _iri, _label, poly in installed[:k]:
            g = mark_polygon(g, poly)
        reach = CarryReach(g, carry_footprints(geo), start, around, margins=BLOCKER_MARGINS_M)
        return any(reach.reaches(b) for b in goals)

    if not installed or not reachable(0) or (not known_closed and reachable(len(installed))):
        return None
    lo, hi = 0, len(installed)  # reachable with lo installed; not with hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if reachable(mid):
            lo = mid
        else:
            hi = mid
    iri, label, _ = installed[hi - 1]
    return Blocker(iri, label)


def carry_leg_reason(geo: CarryGeometry, start: Pose2, n_goals: int, base_reaches: bool,
                     blocker: Blocker | None, within_m: float | None = None) -> str:
    """The infeasibility reason of a carry leg: sizes, whether the robot alone gets there, what closes it.

    Starts with ``"carry way walled off"`` (the install-order feedback and the fixes key on it).
    """
    ln, wn = _size(geo.footprint(NORMAL))
    lw, ww = _size(geo.footprint(NARROW))
    text = (f"carry way walled off: the robot holding the element (carried normal {ln:.2f} m long x "
            f"{wn:.2f} m wide, narrow {lw:.2f} x {ww:.2f} m) cannot drive from the pick base pose "
            f"({start.x:.2f}, {start.y:.2f}) to any of {n_goals} free install base pose(s): no opening on "
            "the way lets either carry footprint through, nor is there room to turn the load"
            + (f" (ways within {within_m:g} m of the pick base pose and the installed pose: the map is too "
               "large to search whole)" if within_m is not None else ""))
    if blocker is not None:
        text += (f"; the way is open until {blocker.label} is installed (carry way closed by {blocker.iri}): "
                 f"install this element before {blocker.label}")
    elif base_reaches:
        text += ("; the robot alone gets there, so the held element does not pass: the pickup location or "
                 "the storage is too far from a way wide enough, or the element too large")
    else:
        text += (f"; even the robot alone does not get there within {BLOCKER_MARGINS_M[-1]:g} m of the pick "
                 "base pose and the installed pose")
    return text


BLOCKER_MARK = "carry way closed by "


def blocker_in(reason: str) -> str | None:
    """The IRI of the element named as closing the carry way in a reason of :func:`carry_leg_reason`."""
    i = reason.find(BLOCKER_MARK)
    if i < 0:
        return None
    rest = reason[i + len(BLOCKER_MARK):]
    return rest.split(")", 1)[0].strip() or None


def reaches_alone(grid: OccupancyGrid, base: Footprint, start: Pose2, goals: Sequence[Pose2],
                  around: tuple[float, float]) -> bool:
    """Whether the robot without a load reaches any of ``goals`` from ``start`` (same test, one footprint)."""
    reach = CarryReach(grid, (base,), start, around, margins=BLOCKER_MARGINS_M)
    return any(reach.reaches(g) for g in goals)
