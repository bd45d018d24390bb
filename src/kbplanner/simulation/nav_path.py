"""Navigation (B5, NV-1 and NV-2), the path types: planner settings, a planned base path, and the
helpers every planning step shares (angle wrapping, densifying, length).

:class:`NavSettings` says how to plan (planner, work budget, yaw bins, seed, checking resolutions, base
motion); :class:`NavPath` is what every planning step returns: waypoints (x, y, yaw; site frame,
metres, radians) with a status and a reason, never an exception for an unreachable goal. Used by the
OMPL query (:mod:`kbplanner.simulation.navigation`), the cell path
(:mod:`kbplanner.simulation.cell_path`), carry modes (:mod:`kbplanner.simulation.carry_paths`) and
time parameterisation (:mod:`kbplanner.simulation.base_trajectory`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ompl import base as ob
from ompl import geometric as og

from kbplanner.core.errors import KbplannerError

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


@dataclass(frozen=True)
class NavSettings:
    """How to plan: planner name, time budget, yaw bins, seed and checking resolutions."""

    planner: str = "RRTConnect"
    time_limit_s: float = 10.0
    # Deterministic work budget: planning stops after this many motion checks, whatever the machine's
    # speed, so the same seed gives the same answer on a busy or a fast machine. ``time_limit_s`` stays
    # as a safety cap only (a run that hits it says so in its reason).
    max_motion_checks: int = 400_000
    # NV-2 plans with the load carried normal first: that try stops after this many motion checks
    # (where free cells do not certainly join start and goal) and the narrow carry is planned, instead
    # of spending the whole budget on a passage the wide load rarely gets through.
    normal_carry_checks: int = 100_000
    # NV-2: where the normal carry must pass a narrow passage (fits at fewer than ``narrow_passage_deg`` of
    # headings on every way between start and goal; :mod:`kbplanner.simulation.narrow_passage`), take the
    # cell route over free configuration cells straight away instead of trying RRTConnect first
    carry_cells_first: bool = False
    narrow_passage_deg: float = 45.0
    n_yaw_bins: int = 72
    seed: int = 1
    simplify: bool = True
    margin_m: float = 0.0
    check_step_m: float | None = None  # motion check step; default: a quarter of a grid cell
    base_motion: str = "turn_drive_turn"  # or "holonomic": keep OMPL's SE(2) segments as they are
    allow_reverse: bool = True  # turn_drive_turn may drive backwards when that turns less
    # the base's top speed, yaw rate, acceleration and yaw acceleration, by which rewrites of a path that
    # drives backwards are timed (without ``allow_reverse``, :func:`~.turn_around.skid_steer`)
    base_limits: tuple[float, float, float, float] = (0.5, 2.0, 1.0, 2.0)
    # ... and how many seconds of drive time a metre less driven backwards is worth there (0: the start
    # backed out and the end backed in straight, :mod:`kbplanner.simulation.back_out`, are not tried; 0, 4
    # and 8 measured in docs/scale.md "Session 14: heading-aware carry legs"). The navigation skill sets it
    # from its parameter ``kbp:reversingCost`` (ontology/kb/skills.ttl: 0)
    reverse_s_per_m: float = 0.0
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
        return densify(self.poses, step_m, yaw_step_rad)


def failed_path(reason: str, planner: str, footprint: str, t: float = 0.0) -> NavPath:
    return NavPath(poses=(), length_m=0.0, planning_time_s=t, planner=planner, status=FAILED,
                   reason=reason, footprint=footprint)


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def densify(poses: Sequence[Pose2D], step_m: float, yaw_step_rad: float) -> list[Pose2D]:
    if not poses:
        return []
    out: list[Pose2D] = [poses[0]]
    for (x0, y0, t0), (x1, y1, t1) in itertools.pairwise(poses):
        dyaw = wrap(t1 - t0)
        n = max(1, math.ceil(max(math.hypot(x1 - x0, y1 - y0) / step_m, abs(dyaw) / yaw_step_rad)))
        for i in range(1, n + 1):
            u = i / n
            out.append((x0 + u * (x1 - x0), y0 + u * (y1 - y0), wrap(t0 + u * dyaw)))
    return out


def path_length(poses: Sequence[Pose2D]) -> float:
    return float(sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in itertools.pairwise(poses)))
