"""B5 path quality: how far a run's motions are from a kinematic lower bound (run metrics).

Per navigation step the executor records the **shortest collision-free path** from where the robot
stood to its goal (the grid yardstick of :mod:`kbplanner.simulation.grid_yardstick` - 8-connected
shortest path over the cells where the footprint fits at some yaw, then line-of-sight shortcuts - on
the map as it was at the step's start): on the configuration space the step planned its path in (the
planner's window; the base for NV-1, for NV-2 the normal carry, or the narrow one where the normal
one could not pass), else (several legs, a start off the free cells) by :func:`shortest_path_m` for
the step's most permissive footprint (the narrow carry for NV-2); and the step's top speed. Per step
it records the **arm's minimum time**: for every control period the largest joint move over that
joint's speed limit (the executed joint path - carry-mode turns included - at the joint speed, each
joint moving at its own limit; :class:`ArmClock`).

:func:`path_quality` turns them into the figures of ``metrics.json`` ``"path_quality"``: per
installed element (frame) ``time_over_lower_bound`` = frame time / (sum of shortest paths / top
speed + sum of arm minimum times), per navigation ``driven_over_shortest`` = driven length /
shortest path, each with median and max over the run. Turning on the spot, acceleration and speed
and separation monitoring are what the lower bound leaves out.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping, Sequence
from typing import Any

from kbplanner.simulation.grid_yardstick import grid_shortest_path_length
from kbplanner.simulation.nav_path import Pose2D
from kbplanner.world.footprint import Footprint
from kbplanner.world.occupancy import OccupancyGrid

YARDSTICK_MARGIN_M = 5.0  # the shortest path is searched around start and goal first, then on the map


def shortest_path_m(
    near: OccupancyGrid, whole: OccupancyGrid, start: Pose2D, goal: Pose2D, footprint: Footprint
) -> float:
    """Shortest collision-free path length (m) for ``footprint`` on ``near`` (a window of ``whole``
    around start and goal, ``YARDSTICK_MARGIN_M``), else on ``whole``; ``inf`` when there is none."""
    length = grid_shortest_path_length(near, start, goal, footprint)
    if not math.isfinite(length) and near is not whole:
        length = grid_shortest_path_length(whole, start, goal, footprint)
    return length


class ArmClock:
    """Sums, over control periods, max_j |dq_j| / v_j of the arm's executed motion."""

    def __init__(self, start: Sequence[float], speeds: Sequence[float]) -> None:
        self.q = [float(v) for v in start]
        self.speeds = [float(v) for v in speeds]
        self.total_s = 0.0

    def update(self, q: Sequence[float]) -> None:
        """The arm is now at ``q``."""
        step = 0.0
        for a, b, v in zip(self.q, q, self.speeds, strict=True):
            step = max(step, abs(float(b) - a) / v)
        self.total_s += step
        self.q = [float(v) for v in q]


def _spread(values: Sequence[float]) -> dict[str, float | int | None]:
    return {"median": round(statistics.median(values), 3) if values else None,
            "max": round(max(values), 3) if values else None, "count": len(values)}


def path_quality(per_element: Sequence[Mapping[str, Any]], navigation: Sequence[Mapping[str, Any]]
                 ) -> dict[str, Any]:
    """Run figures from ``metrics.json``'s ``per_element`` and ``navigation`` entries (see module doc).

    Example:
        >>> nav = {"step": 1, "outcome": "succeeded", "driven_m": 5.5, "shortest_m": 5.0}
        >>> el = {"outcome": "installed", "duration_s": 30.0, "steps": [
        ...     {"step": 1, "details": {"shortest_m": 5.0, "max_speed_mps": 0.5, "arm_min_s": 2.0}},
        ...     {"step": 2, "details": {"arm_min_s": 8.0}}]}
        >>> q = path_quality([el], [nav])
        >>> q["per_element"][0]["lower_bound_s"], q["time_over_lower_bound"]["median"]
        (20.0, 1.5)
        >>> q["driven_over_shortest"]["max"]
        1.1
    """
    frames = []
    for e in per_element:
        if e.get("outcome") != "installed":
            continue
        bound = 0.0
        for s in e.get("steps", []):
            d = s.get("details", {})
            bound += float(d.get("arm_min_s", 0.0))
            if "shortest_m" in d and d.get("max_speed_mps"):
                bound += float(d["shortest_m"]) / float(d["max_speed_mps"])
        if bound > 0 and math.isfinite(bound):
            frames.append({"global_id": e.get("global_id"), "duration_s": e["duration_s"],
                           "lower_bound_s": round(bound, 3),
                           "time_over_lower_bound": round(float(e["duration_s"]) / bound, 3)})
    paths = [float(n["driven_m"]) / float(n["shortest_m"]) for n in navigation
             if n.get("outcome") == "succeeded" and n.get("shortest_m") and math.isfinite(n["shortest_m"])
             and float(n["shortest_m"]) > 0.05]
    return {
        "definition": "frame time / (shortest collision-free paths / top speed + arm joint path at the "
                      "joint speed limits); driven / shortest collision-free path per navigation",
        "time_over_lower_bound": _spread([f["time_over_lower_bound"] for f in frames]),
        "driven_over_shortest": _spread(paths),
        "per_element": frames,
    }
