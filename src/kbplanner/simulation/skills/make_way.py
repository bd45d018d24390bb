"""B5, navigation among reactive workers: the robot that has waited for a worker asks them to make way.

When the speed and separation monitoring has stopped the robot for a worker for ``replan_after_s``
(:mod:`kbplanner.simulation.skills.navigation`), a reactive worker who waits at a stop on its way walks
to a spot clear of the rest of the robot's path (:meth:`kbplanner.simulation.crowd.Crowd.make_way`):
without it, a worker working in a corridor and a robot that keeps the protective separation distance
from a standing person wait for each other until the step gives up. Scripted workers do not react.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from kbplanner.simulation.workers import WORKER_RADIUS_M

if TYPE_CHECKING:
    from kbplanner.simulation.sim_env import SimEnv


def ask_way(env: SimEnv, who: str, path: Sequence[tuple[float, float]], clear_m: float,
            emit: Callable[..., Any]) -> tuple[float, float] | None:
    """Ask worker ``who`` (a slug) to stand at least ``clear_m`` + the worker's radius from every point
    of ``path`` (the robot's remaining drive); emits ``make_way`` with the spot when they move."""
    crowd = env.crowd
    if crowd is None or not path:
        return None
    k = next((i for i, w in enumerate(env.workers) if w.slug == who), None)
    if k is None or k >= len(crowd):
        return None  # a scripted worker (crowd workers come first)
    spot = crowd.make_way(k, np.array(path, dtype=np.float64), clear_m + WORKER_RADIUS_M)
    if spot is not None:
        emit("make_way", worker=who, x=round(spot[0], 3), y=round(spot[1], 3))
    return spot
