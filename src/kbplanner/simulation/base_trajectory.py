"""Navigation (B5), time parameterisation: a planned base path as timed samples at a fixed rate.

Takes a :class:`~kbplanner.simulation.nav_path.NavPath` (or its poses) and the base's limits (speed,
yaw rate, accelerations); :func:`time_parameterize` gives a :class:`Trajectory` with rest-to-rest
trapezoidal velocity profiles per segment, translation and rotation progressing together so that
neither limit is exceeded. The executor moves the base kinematically along these samples.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from kbplanner.core.errors import KbplannerError
from kbplanner.simulation.nav_path import NavPath, Pose2D, wrap


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
        dyaw = abs(wrap(b[2] - a[2]))
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
        dyaw = wrap(b[2] - a[2])
        ts = t - float(starts[i])
        if d >= abs(dyaw) * max_speed_mps / max_yaw_rate_rps:
            u = _trapezoid_progress(ts, seg_t[i], d, max_speed_mps, max_accel_mps2)
        else:
            u = _trapezoid_progress(ts, seg_t[i], abs(dyaw), max_yaw_rate_rps, max_yaw_accel_rps2)
        out.append((a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]), wrap(a[2] + u * dyaw)))
    return Trajectory(tuple(round(t, 9) for t in times), tuple(out))
