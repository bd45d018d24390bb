"""Human-robot proximity (analysis): distances from the robot's footprint to each worker, and the
intervals where they come too close.

Distances are measured from the *footprint* of the robot, including the element it carries in its
current carry mode (a union of oriented rectangles in the robot frame, see ``footprint.Rect``), to the
worker's body, a circle of ``worker_radius_m`` around the worker's recorded position. A worker inside
the footprint has distance 0. Two thresholds are applied: a fixed one (1 m by default, the paper's) and
the protective separation distance of ISO/TS 15066 speed and separation monitoring
(:class:`SsmParameters`), which grows with the robot's speed.

ISO/TS 15066 (clause 5.5.4), for a human approaching at ``v_h`` and a robot moving at ``v_r(t)``:

    S_p(t) = S_h + S_r + S_s + C + Z_d + Z_r
    S_h = v_h * (T_r + T_s)        human motion while the robot reacts and stops
    S_r = v_r(t) * T_r             robot motion during its reaction time
    S_s = v_r(t)**2 / (2 * a_s)    robot stopping distance at deceleration a_s
    C   = 1.2 - 0.4 * H  (m)       intrusion distance of ISO 13855 for a horizontal scanner at height H,
                                   at least 0.85 m
    Z_d, Z_r                       position uncertainty of the sensor and of the robot

Constants (defaults of :class:`SsmParameters`): v_h = 1.6 m/s (ISO 13855 walking speed), T_r = 0.1 s,
T_s = 0.5 s, a_s = 1.0 m/s^2, H = 0.3 m (the lidar height of a Husky-class base), Z_d = 0.05 m,
Z_r = 0.05 m. With the robot standing still S_p = 0.96 + 1.08 + 0.10 = 2.14 m.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kbplanner.world.footprint import Rect

FloatArray = npt.NDArray[np.float64]

DEFAULT_THRESHOLD_M = 1.0
WORKER_RADIUS_M = 0.25


@dataclass(frozen=True)
class SsmParameters:
    """Constants of the ISO/TS 15066 protective separation distance (SI units)."""

    human_speed_mps: float = 1.6
    reaction_time_s: float = 0.1
    stopping_time_s: float = 0.5
    deceleration_mps2: float = 1.0
    sensor_height_m: float = 0.3
    sensor_uncertainty_m: float = 0.05
    robot_uncertainty_m: float = 0.05

    @property
    def intrusion_m(self) -> float:
        """C of ISO 13855 for a horizontal detection plane at ``sensor_height_m``."""
        return max(0.85, 1.2 - 0.4 * self.sensor_height_m)

    def separation_m(self, robot_speed_mps: FloatArray | float) -> FloatArray:
        """The protective separation distance S_p for the given robot speed(s).

        Example:
            >>> round(float(SsmParameters().separation_m(0.0)), 3)
            2.14
        """
        v = np.asarray(robot_speed_mps, dtype=np.float64)
        s_h = self.human_speed_mps * (self.reaction_time_s + self.stopping_time_s)
        s_r = v * self.reaction_time_s
        s_s = v * v / (2.0 * self.deceleration_mps2)
        return np.asarray(s_h + s_r + s_s + self.intrusion_m + self.sensor_uncertainty_m
                          + self.robot_uncertainty_m, dtype=np.float64)


def point_to_rects_distance(px: FloatArray, py: FloatArray, rx: FloatArray, ry: FloatArray,
                            ryaw: FloatArray, rects: Sequence[Rect]) -> FloatArray:
    """Distance (m) from points to the union of robot-frame rectangles placed at robot poses (vectorised).

    All arrays have one entry per sample; a point inside a rectangle has distance 0.

    Example:
        >>> import numpy as np
        >>> d = point_to_rects_distance(np.array([2.0]), np.array([0.0]), np.zeros(1), np.zeros(1),
        ...                             np.zeros(1), [Rect(0.0, 0.0, 1.0, 0.6)])
        >>> float(d[0])
        1.5
    """
    px, py = np.asarray(px, float), np.asarray(py, float)
    dx, dy = px - np.asarray(rx, float), py - np.asarray(ry, float)
    c, s = np.cos(ryaw), np.sin(ryaw)
    lx, ly = c * dx + s * dy, -s * dx + c * dy  # the point in the robot frame
    best = np.full(px.shape, np.inf)
    for r in rects:
        cr, sr = math.cos(r.yaw), math.sin(r.yaw)
        qx, qy = lx - r.cx, ly - r.cy
        ux, uy = cr * qx + sr * qy, -sr * qx + cr * qy  # in the rectangle's frame
        ex = np.maximum(np.abs(ux) - r.length / 2.0, 0.0)
        ey = np.maximum(np.abs(uy) - r.width / 2.0, 0.0)
        best = np.minimum(best, np.hypot(ex, ey))
    return best


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
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    for i, j in zip(starts, ends, strict=True):
        seg = distance[i:j]
        k = i + int(np.argmin(seg))
        end_t = float(t[j]) if j < len(t) else float(t[-1]) + dt
        out.append(ProximityInterval(worker=worker, threshold=threshold, start_s=float(t[i]), end_s=end_t,
                                     min_distance_m=float(distance[k]), t_min_s=float(t[k]),
                                     x_m=float(wx[k]), y_m=float(wy[k])))
    return out


def robot_speed(t: FloatArray, x: FloatArray, y: FloatArray) -> FloatArray:
    """Translational speed (m/s) of the robot base from its sampled positions (backward differences)."""
    t, x, y = (np.asarray(a, float) for a in (t, x, y))
    v = np.zeros_like(t)
    if len(t) > 1:
        dt = np.diff(t)
        dt[dt <= 0] = np.inf
        v[1:] = np.hypot(np.diff(x), np.diff(y)) / dt
    return v
