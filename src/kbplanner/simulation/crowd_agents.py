"""B5 reactive workers, a worker's state in the crowd (:mod:`kbplanner.simulation.crowd`): where they
are on their route, whether they walk, wait or make way for the robot, and the constants of those rules.

Takes a worker's :class:`~kbplanner.simulation.workers.WorkerSpec` and their social-force parameters;
holds what the crowd's step (:mod:`~kbplanner.simulation.crowd`), route following
(:mod:`~kbplanner.simulation.crowd_routes`), look for a way round the robot
(:mod:`~kbplanner.simulation.crowd_detours`) and making way (:mod:`~kbplanner.simulation.crowd_make_way`)
read and change.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.separation import WORKER_RADIUS_M
from kbplanner.simulation.social_force import Obstacle, SocialForceParams
from kbplanner.simulation.workers import WorkerSpec, _Router

FloatArray = npt.NDArray[np.float64]

STUCK_SPEED_MPS = 0.2  # a walking worker slower than this for STUCK_S looks for a way round the robot
STUCK_S = 2.0
HEADWAY_M = STUCK_SPEED_MPS * STUCK_S  # a worker walking to their anchor who has not come this much
# nearer (along their way) for STUCK_S has made little headway (pushed to and fro by the robot)
WAYPOINT_REACHED_M = 0.35
ARRIVED_M = 0.2
LEG_CLEAR_M = WORKER_RADIUS_M + 0.3  # the walk to a make-way spot keeps this clear of the robot's footprint
HOME_STRETCH_M = 10.0  # how much of a walking worker's route the robot must have passed before they walk on
WAY_ROUTED_M = 1.0  # a waiting worker farther than this from their anchor walks there along the router's path
CONTACT_MARGIN_M = 0.01  # a worker's own step keeps at least this much clear of the robot
MAKE_WAY_MAX_HOLD_S = 300.0  # a worker who made way goes back after this even if the robot has not passed
OFF_PATH_M = 1.0  # a robot this far from the path it asked for has left it (replanned, gave up)
MAKE_WAY_RINGS_M = tuple(0.5 * k for k in range(1, 13))  # where a worker looks for a spot to make way


@dataclass
class Yield:
    """A worker who made way: the robot's path they wait for, how far it passes, where they go back to."""

    path: FloatArray  # the robot's remaining path (base centre, n x 2) when it asked
    clear_m: float  # from the base centre: footprint reach + S_p + the worker's radius
    home: FloatArray  # (n, 2): their stop, or the next HOME_STRETCH_M of a walking worker's route
    walking: bool  # walk on to the next stop when released (else: back to the stop)
    deadline: float  # released at this time at the latest
    progress: int = 0  # index of the path point the robot has reached


@dataclass
class Agent:
    """One worker of the crowd: their spec, walking speed, random draws, and where they are on their route."""

    spec: WorkerSpec
    params: SocialForceParams
    rng: np.random.Generator
    v0: float
    k: int  # the stop the worker is at or walked from
    walking: bool = False
    until: float = 0.0  # end of the current wait
    path: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    wp: int = 0
    anchor: tuple[float, float] = (0.0, 0.0)
    slow_s: float = 0.0  # how long the worker has made little headway on their walk
    making_way: bool = False  # on the way to (or at) a spot where the worker lets the robot pass
    yielding: Yield | None = None  # made way: waits there until the robot has passed
    way: FloatArray | None = None  # a waiting worker's walking path to their anchor (far from it)
    way_i: int = 0
    way_to: tuple[float, float] = (math.nan, math.nan)  # the anchor ``way`` leads to
    way_slow_s: float = 0.0  # how long they have made little headway on it
    way_best_m: float = math.inf  # the shortest walk left along ``way`` so far
    _points: tuple[FloatArray, list[list[float]]] | None = None  # ``path`` as floats, and of which array

    def points(self) -> list[list[float]]:
        """``path`` as lists of floats (the same numbers; converted once per path)."""
        if self._points is None or self._points[0] is not self.path:
            self._points = (self.path, self.path.tolist())
        return self._points[1]


class CrowdState(Protocol):
    """What the crowd's parts read and change of the crowd (:class:`kbplanner.simulation.crowd.Crowd`)."""

    agents: list[Agent]
    router: _Router
    dt: float
    t: float
    _xs: list[float]
    _ys: list[float]
    _history: deque[Obstacle | None]
    _no_detour: dict[int, tuple[bytes, tuple[object, ...]]]

    @property
    def pos(self) -> FloatArray:
        """(n, 2) positions."""
        ...

    def speed_list(self) -> list[float]:
        """The walking speed of every worker."""
        ...

    def _way_target(self, a: Agent, p: FloatArray) -> FloatArray: ...

    def _walkable_along(self, pts: FloatArray) -> bool: ...

    def _free_at(self, q: FloatArray) -> bool: ...

    def _clear_many(self, legs: Sequence[tuple[FloatArray, FloatArray]], robot: Obstacle) -> list[bool]: ...
