"""Human-robot proximity (analysis): the intervals where workers come too close to the robot.

The distances and the ISO/TS 15066 protective separation distance S_p are **the simulation's**
(:mod:`kbplanner.simulation.separation`, :func:`kbplanner.simulation.safety.separation_samples`): the
footprint of the robot including the element it carries in its current carry mode, to the worker's
disc of ``WORKER_RADIUS_M``; S_p with the run's own constants (``metrics.json``, ``safety.ssm``: the
navigation skill's effective parameters) at the robot's translational speed from consecutive samples.
This module only cuts the per-sample separations into intervals below a threshold, for the report's
interval table; the *time below* a threshold is :func:`kbplanner.simulation.separation.time_below_s`
(samples at which any worker is below, times the recording period), the same figure as ``metrics.json``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.safety import FIXED_THRESHOLD_M
from kbplanner.simulation.separation import (
    WORKER_RADIUS_M,
    SsmParameters,
    distance_at_poses,
    robot_speed,
    sample_period_s,
    time_below_s,
)

FloatArray = npt.NDArray[np.float64]

DEFAULT_THRESHOLD_M = FIXED_THRESHOLD_M
point_to_rects_distance = distance_at_poses  # the footprint distance, one robot pose per sample

__all__ = ["DEFAULT_THRESHOLD_M", "WORKER_RADIUS_M", "ProximityInterval", "SsmParameters", "intervals_below",
           "point_to_rects_distance", "robot_speed", "sample_period_s", "time_below_s"]


@dataclass(frozen=True)
class ProximityInterval:
    """A stretch of time a worker spent closer to the robot than a threshold."""

    worker: str
    threshold: str
    start_s: float
    end_s: float
    min_distance_m: float
    t_min_s: float
    x_m: float
    y_m: float

    @property
    def duration_s(self) -> float:
        """Length of the interval in seconds."""
        return self.end_s - self.start_s


def intervals_below(t: FloatArray, distance: FloatArray, limit: FloatArray | float, *, worker: str,
                    threshold: str, wx: FloatArray, wy: FloatArray) -> list[ProximityInterval]:
    """Maximal runs of samples with ``distance < limit``; each interval spans its samples' time steps.

    A run of samples i..j covers [t_i, t_{j+1}) (the last sample holds until the next); the position is
    the worker's where the distance was smallest.
    """
    t = np.asarray(t, float)
    below = np.asarray(distance, float) < np.broadcast_to(np.asarray(limit, float), t.shape)
    out: list[ProximityInterval] = []
    if not below.any():
        return out
    edges = np.diff(np.concatenate([[0], below.astype(np.int8), [0]]))
    starts, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    dt = sample_period_s(t)
    for i, j in zip(starts, ends, strict=True):
        seg = distance[i:j]
        k = i + int(np.argmin(seg))
        end_t = float(t[j]) if j < len(t) else float(t[-1]) + dt
        out.append(ProximityInterval(worker=worker, threshold=threshold, start_s=float(t[i]), end_s=end_t,
                                     min_distance_m=float(distance[k]), t_min_s=float(t[k]),
                                     x_m=float(wx[k]), y_m=float(wy[k])))
    return out
