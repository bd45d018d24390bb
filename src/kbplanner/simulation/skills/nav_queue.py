"""B5 skills NV-1 and NV-2, what the navigation skill plans and executes: a :class:`Route` (pieces of path,
each with its carry mode and the configuration space it was planned in) and the queue items it is turned
into, :class:`Drive` (timed base poses at the control rate) and :class:`Turn` (an arm motion, the base
standing still: the carried element's carry pose or its turn to narrow and back).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from kbplanner.simulation.carry_paths import CarryPlan
from kbplanner.simulation.skills.base import JointPath
from kbplanner.world.footprint import ConfigurationSpace

Pose2D = tuple[float, float, float]


@dataclass
class Route:
    """A planned route: pieces of path, each with the carry mode to drive it in ("" without a load) and
    the configuration space it was planned in (its corners are rounded where they fit there; None: kept)."""

    pieces: list[tuple[list[Pose2D], str, ConfigurationSpace | None]]
    length_m: float
    narrow_length_m: float


def route_of(cp: CarryPlan) -> Route:
    """The route of a carry-mode plan: its pieces between the load's turns."""
    return Route(cp.pieces(), cp.path.length_m, float(cp.extra.get("narrow_length_m", 0.0)))


@dataclass
class Drive:
    """Timed base poses to drive; monitoring sets how far along them the robot gets per period."""

    t: list[Pose2D]  # timed poses at the control rate, the first one where the drive starts
    mode: str
    s: float = 0.0  # progress in samples (1 per control period at full speed)

    def at(self, s: float) -> Pose2D:
        i = min(int(s), len(self.t) - 2)
        u = s - i
        a, b = self.t[i], self.t[i + 1]
        dyaw = math.atan2(math.sin(b[2] - a[2]), math.cos(b[2] - a[2]))
        return (a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]), a[2] + u * dyaw)


@dataclass
class Turn:
    """An arm motion with the base standing still, with the event to record when it starts."""

    path: JointPath
    event: str | None
    mode: str
    announced: bool = False  # its event is recorded
    share: float = 0.0  # of the next arm sample made (monitoring slows or holds the turn)

    def joint_rate(self, q: Sequence[float], hz: float) -> float:
        """The fastest joint's rate (rad/s) from ``q`` to the next sample (not done)."""
        return max(abs(b - a) for a, b in zip(q, self.path.samples[self.path._i][0], strict=True)) * hz
