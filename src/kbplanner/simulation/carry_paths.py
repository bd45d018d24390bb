"""Navigation (B5, NV-2), carry modes: the doorway behaviour of the paper (Figure 14).

Takes an occupancy grid, start and goal poses and two footprints (the base with the load carried normal,
wide, and narrow, on its side); :func:`plan_with_carry_modes` plans with the normal footprint (OMPL,
:func:`kbplanner.simulation.navigation.plan_path`); where that fails, it plans with the narrow one and
marks the stretches of the path where the wide load does not fit, with "rotate to narrow" before and
"rotate back" after each (extended by a margin). Returns a :class:`CarryPlan`.

With ``NavSettings.carry_cells_first``, a leg whose normal carry must pass a narrow passage
(:func:`kbplanner.simulation.narrow_passage.narrow_passage`: on every way the load fits at fewer than
``narrow_passage_deg`` of headings somewhere) takes the cell route over free configuration cells
(:mod:`kbplanner.simulation.cell_path`; the cells searched in a corridor round the grid's shortest
path first, :mod:`kbplanner.simulation.corridor_cells`) without RRTConnect's try, which there often
used its whole normal-carry budget before the cell route was taken (docs/scale.md "Session 9:
carryroute").
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.cell_path import cell_route, face_path
from kbplanner.simulation.corridor_cells import corridor_cells
from kbplanner.simulation.narrow_passage import narrow_passage
from kbplanner.simulation.nav_path import (
    OK,
    NavPath,
    NavSettings,
    Pose2D,
    densify,
    failed_path,
    path_length,
    wrap,
)
from kbplanner.simulation.navigation import plan_path
from kbplanner.world.cspace_cache import configuration_space
from kbplanner.world.footprint import ConfigurationSpace, Footprint
from kbplanner.world.occupancy import OccupancyGrid


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
    space: ConfigurationSpace | None = None  # the configuration space of the path's footprint
    normal_space: ConfigurationSpace | None = None  # that of the normal carry (same grid)

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

    def pieces(self) -> list[tuple[list[Pose2D], str, ConfigurationSpace | None]]:
        """The path cut where the load turns: each stretch with its carry mode (``"normal"`` or
        ``"narrow"``) and the configuration space of that mode's footprint."""
        poses = list(self.path.poses)
        spans = [(seg.start_index, seg.end_index) for seg in self.segments]
        cuts = sorted({0, len(poses) - 1, *(i for span in spans for i in span)})
        out: list[tuple[list[Pose2D], str, ConfigurationSpace | None]] = []
        for a, b in itertools.pairwise(cuts):
            inside = any(lo <= a and b <= hi for lo, hi in spans)
            out.append((poses[a:b + 1], "narrow" if inside else "normal",
                        self.space if inside or self.mode == "normal" else self.normal_space))
        return out or [(poses, "normal", self.space)]


def _arc_lengths(poses: Sequence[Pose2D]) -> npt.NDArray[np.float64]:
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    seg = np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1]))
    return np.concatenate([[0.0], np.cumsum(seg)])


def narrow_intervals(
    poses: Sequence[Pose2D], normal: ConfigurationSpace, margin_m: float, step_m: float
) -> list[tuple[float, float]]:
    """Arc-length intervals of a path where the normal footprint is blocked, grown by ``margin_m``.

    The path is sampled every ``step_m`` (its turns on the spot every quarter yaw bin); grown intervals
    less than ``margin_m`` apart are merged: the load is not turned back for a normal stretch shorter
    than the margin kept round a narrow one and turned on its side again at once (a turn on the spot
    that only the narrow load can make, next to a narrow passage, would otherwise be a narrow stretch
    of its own, a few decimetres before the passage's).
    """
    dense = densify(poses, step_m, normal.bin_width / 4)
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
        if intervals and lo < intervals[-1][1] + margin_m:
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
    poses.insert(i, (x0 + u * (x1 - x0), y0 + u * (y1 - y0), wrap(t0 + u * wrap(t1 - t0))))
    return i


def cells_first(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, settings: NavSettings) -> NavPath | None:
    """The cell route for a leg through a narrow passage (``settings.carry_cells_first``), RRTConnect not
    tried; None where the setting is off, the passage is not narrow, an end is blocked or free cells do
    not join start and goal (then the planner is tried as before)."""
    if not settings.carry_cells_first:
        return None
    if not (cs.is_free(*start) and cs.is_free(*goal)):
        return None
    t0 = time.perf_counter()
    if not narrow_passage(cs, start, goal, settings.narrow_passage_deg):
        return None
    cells = corridor_cells(cs, start, goal)  # near the grid's shortest path first, else the whole window
    if cells is None:
        cells = face_path(cs, start, goal)
    if cells is None:
        return None
    why = (f"not tried: a narrow passage, the load fits at under {settings.narrow_passage_deg:g} deg of "
           "headings on every way")
    path = cell_route(cs, start, goal, settings, t0, why, cells)
    return path if path is not None and path.ok else None


DETOUR_CORRIDORS_M = (0.5, 1.0)  # corridor radii of the cell routes tried for a leg gone round the long way


def cell_alternatives(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, settings: NavSettings
                      ) -> list[NavPath]:
    """Cell routes from start to goal on ``cs`` for a leg the planner drove round the long way (the caller
    times them against its path): through free cells within each of ``DETOUR_CORRIDORS_M`` of the grid's
    shortest path (:func:`~kbplanner.simulation.corridor_cells.corridor_cells`) and through the whole
    window's (:func:`~kbplanner.simulation.cell_path.face_path`), each shortened by exact motion checks in
    the same space, distinct paths only; no random numbers (the same routes for every seed)."""
    if not (cs.is_free(*start) and cs.is_free(*goal)):
        return []
    out: list[NavPath] = []
    seen: set[tuple[Pose2D, ...]] = set()
    why = "round the long way: a cell route tried"
    for radius in (*DETOUR_CORRIDORS_M, None):
        t0 = time.perf_counter()
        cells = face_path(cs, start, goal) if radius is None else corridor_cells(cs, start, goal, radius)
        if cells is None:
            continue
        path = cell_route(cs, start, goal, settings, t0, why, cells)
        if path is not None and path.ok and path.poses not in seen:
            seen.add(path.poses)
            out.append(path)
    return out


def plan_with_carry_modes(
    grid: OccupancyGrid,
    start: Pose2D,
    goal: Pose2D,
    normal: Footprint,
    narrow: Footprint,
    settings: NavSettings | None = None,
    margin_m: float = 0.5,
    walled_off: frozenset[Footprint] = frozenset(),
) -> CarryPlan:
    """Plan with the normal carry footprint; where it cannot pass, carry the load narrow.

    If the normal footprint finds a path (within ``settings.normal_carry_checks`` motion checks, or by
    the cell path where free cells certainly join start and goal), that is the plan (mode
    ``"normal"``; with ``settings.carry_cells_first`` a leg through a narrow passage takes the cell path
    without trying RRTConnect, :func:`cells_first`). Otherwise the path is
    planned with the narrow footprint, and each stretch where the normal footprint is blocked,
    grown by ``margin_m`` on both sides, becomes a :class:`CarrySegment` with a
    ``rotate_to_narrow`` event at its start and a ``rotate_back`` event at its end (new waypoints
    are inserted there). If even the narrow footprint fails, the plan fails with both reasons.
    A footprint in ``walled_off`` is known to be walled off from the goal (on a map this grid is a
    window of, :func:`~kbplanner.simulation.navigation.is_walled_off`): it is not planned, and fails with
    the reason planning gives (``known_walled_off`` of :func:`plan_path`; no cell route joins them either).
    """
    settings = settings or NavSettings()
    cs_normal = configuration_space(grid, normal, settings.n_yaw_bins, settings.margin_m)  # kept per process
    routed = None if normal in walled_off else cells_first(cs_normal, start, goal, settings)
    if routed is not None:
        return CarryPlan(path=routed, mode="normal", normal_attempt=routed, space=cs_normal,
                         normal_space=cs_normal)
    checks = min(settings.max_motion_checks, settings.normal_carry_checks)
    first = plan_path(cs_normal, start, goal, settings=replace(settings, max_motion_checks=checks),
                      known_walled_off=normal in walled_off)
    if first.ok:
        return CarryPlan(path=first, mode="normal", normal_attempt=first, space=cs_normal,
                         normal_space=cs_normal)
    cs_narrow = configuration_space(grid, narrow, settings.n_yaw_bins, settings.margin_m)
    second = plan_path(cs_narrow, start, goal, settings=settings, known_walled_off=narrow in walled_off)
    if not second.ok:
        failed = failed_path(f"{second.reason} even with the narrow carry mode ({narrow.name}); "
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
    path = NavPath(poses=tuple(_floats3(q) for q in poses), length_m=path_length(poses),
                   planning_time_s=first.planning_time_s + second.planning_time_s,
                   planner=second.planner, status=OK,
                   reason=f"{second.reason} with the narrow carry mode; normal mode: {first.reason}",
                   footprint=narrow.name)
    narrow_len = sum(seg.end_s_m - seg.start_s_m for seg in segments)
    return CarryPlan(path=path, mode="narrow", segments=tuple(segments), events=tuple(events),
                     normal_attempt=first, extra={"narrow_length_m": narrow_len}, space=cs_narrow,
                     normal_space=cs_normal)
