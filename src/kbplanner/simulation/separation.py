"""B5 safety geometry: the robot's hazard footprint, distances to people, ISO/TS 15066 S_p.

One definition of "separation" for the whole pipeline (the executor's contact check and safety
metrics, the reactive workers' repulsion, the analysis and ``benchmarks/safety_check.py``):

- the robot's **hazard footprint** is the base rectangle plus, while it holds an element, the
  element's rectangle of its carry mode (``normal``/``narrow``; while it is ``lifted`` or being
  ``placed`` the normal carry rectangle stands for it), all in the robot frame (``footprints.json``);
- a worker is a disc of radius ``WORKER_RADIUS_M`` around their recorded position;
- **separation** = distance from the footprint to the disc (0 when they overlap), plus the storeys
  between the robot's floor and the ground the workers walk on;
- **contact** = the disc overlaps the footprint (separation 0 and penetration > 0).

ISO/TS 15066 (clause 5.5.4) protective separation distance for a robot moving at ``v``::

    S_p(v) = v_h (T_r + T_s(v)) + v T_r + v^2 / (2 a_s) + C + Z,   T_s(v) = v / a_s

with ``v_h`` the human approach speed, ``T_r`` the robot's reaction time (sensor latency and control),
``a_s`` its braking deceleration, ``C`` the ISO 13855 intrusion distance of the sensor and ``Z`` the
position uncertainties of sensor and robot. :meth:`SsmParameters.allowed_speed` inverts it: the
largest speed whose S_p fits a measured separation.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kbplanner.world.footprint import Rect

FloatArray = npt.NDArray[np.float64]

WORKER_RADIUS_M = 0.25
SCALAR_POINTS = 8  # up to this many points, rects_distance works on plain floats (same results)
_hypot = np.hypot
MODE_RECT = {"normal": "normal", "narrow": "narrow", "lifted": "normal", "placing": "normal"}


@dataclass(frozen=True)
class SsmParameters:
    """Constants of the ISO/TS 15066 protective separation distance (SI units).

    Defaults are the knowledge base's NV-1/NV-2 skill defaults (``ontology/kb/skills.ttl``):
    v_h 1.6 m/s (ISO 13855), T_r 0.14 s (one 25 Hz scan + one 10 Hz control period), a_s 1.0 m/s^2,
    C 1.08 m (ISO 13855 for a scanner plane at 0.3 m), Z 0.1 m.
    """

    human_speed_mps: float = 1.6
    reaction_time_s: float = 0.14
    deceleration_mps2: float = 1.0
    intrusion_m: float = 1.08
    uncertainty_m: float = 0.1

    @classmethod
    def from_parameters(cls, params: Mapping[str, object]) -> SsmParameters:
        """From a skill call's effective parameters (kind local names), defaults where absent."""
        d = cls()

        def num(key: str, default: float) -> float:
            v = params.get(key)
            return float(v) if isinstance(v, (int, float)) and math.isfinite(float(v)) else default

        out = cls(
            num("humanApproachSpeed", d.human_speed_mps),
            num("reactionTime", d.reaction_time_s),
            num("brakingDeceleration", d.deceleration_mps2),
            num("intrusionDistance", d.intrusion_m),
            num("positionUncertainty", d.uncertainty_m),
        )
        if (
            out.deceleration_mps2 <= 0
            or min(out.human_speed_mps, out.reaction_time_s, out.intrusion_m, out.uncertainty_m) < 0
        ):
            from kbplanner.core.errors import KbplannerError

            raise KbplannerError(
                f"speed and separation monitoring parameters out of range: {out}",
                element="NV-1/NV-2 skill parameters",
                fix="give a positive kbp:brakingDeceleration and non-negative "
                "kbp:humanApproachSpeed, kbp:reactionTime, kbp:intrusionDistance, "
                "kbp:positionUncertainty",
            )
        return out

    def separation_m(self, v: FloatArray | float) -> FloatArray:
        """S_p for robot speed(s) ``v`` (m/s).

        Example:
            >>> round(float(SsmParameters().separation_m(0.0)), 3)
            1.404
        """
        v = np.abs(np.asarray(v, dtype=np.float64))
        a = self.deceleration_mps2
        s_h = self.human_speed_mps * (self.reaction_time_s + v / a)
        return np.asarray(
            s_h + v * self.reaction_time_s + v * v / (2 * a) + self.intrusion_m + self.uncertainty_m,
            dtype=np.float64,
        )

    def separation_at(self, v: float) -> float:
        """:meth:`separation_m` of one speed in plain floats: the same operations in the same order
        (numpy's float64 arithmetic is IEEE's, as Python's), the same number without the fixed cost of
        numpy calls on a scalar (the monitor asks every control period)."""
        v = abs(float(v))
        a = self.deceleration_mps2
        s_h = self.human_speed_mps * (self.reaction_time_s + v / a)
        return float(s_h + v * self.reaction_time_s + v * v / (2 * a) + self.intrusion_m + self.uncertainty_m)

    def allowed_speed(self, separation_m: float) -> float:
        """The largest speed v >= 0 with S_p(v) <= ``separation_m`` (0 when even S_p(0) is larger).

        Example:
            >>> p = SsmParameters()
            >>> v = p.allowed_speed(2.0); round(float(p.separation_m(v)), 6)
            2.0
        """
        a = self.deceleration_mps2
        c0 = (
            self.human_speed_mps * self.reaction_time_s + self.intrusion_m + self.uncertainty_m - separation_m
        )
        if c0 >= 0:
            return 0.0
        qa, qb = 1.0 / (2 * a), self.human_speed_mps / a + self.reaction_time_s
        return float((-qb + math.sqrt(qb * qb - 4 * qa * c0)) / (2 * qa))

    @classmethod
    def from_dict(cls, d: Mapping[str, object] | None) -> SsmParameters:
        """From ``metrics.json``'s ``safety.ssm`` (:meth:`as_dict`); defaults for what is absent."""
        base = cls()
        if not d:
            return base

        def num(key: str, default: float) -> float:
            v = d.get(key)
            return float(v) if isinstance(v, (int, float)) and math.isfinite(float(v)) else default

        return cls(
            num("human_speed_mps", base.human_speed_mps),
            num("reaction_time_s", base.reaction_time_s),
            num("deceleration_mps2", base.deceleration_mps2),
            num("intrusion_m", base.intrusion_m),
            num("uncertainty_m", base.uncertainty_m),
        )

    def as_dict(self) -> dict[str, float]:
        """The constants, for metrics.json."""
        return {
            "human_speed_mps": self.human_speed_mps,
            "reaction_time_s": self.reaction_time_s,
            "deceleration_mps2": self.deceleration_mps2,
            "intrusion_m": self.intrusion_m,
            "uncertainty_m": self.uncertainty_m,
        }


def rects_distance(
    px: FloatArray, py: FloatArray, pose: tuple[float, float, float], rects: Sequence[Rect]
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Distance from points to the union of robot-frame rectangles at one robot pose, and the unit
    direction (site frame) from the nearest footprint point to each point (zero inside).

    Example:
        >>> d, ux, uy = rects_distance(np.array([2.0]), np.array([0.0]), (0.0, 0.0, 0.0),
        ...                            [Rect(0.0, 0.0, 1.0, 0.6)])
        >>> float(d[0]), float(ux[0]), float(uy[0])
        (1.5, 1.0, 0.0)
    """
    px, py = np.asarray(px, dtype=np.float64), np.asarray(py, dtype=np.float64)
    if px.size <= SCALAR_POINTS and px.ndim == 1:
        rows = points_rects_distance(px.tolist(), py.tolist(), pose, rects)
        out = np.array(rows, dtype=np.float64).reshape(-1, 3)
        return out[:, 0], out[:, 1], out[:, 2]
    c, s = math.cos(pose[2]), math.sin(pose[2])
    dx, dy = px - pose[0], py - pose[1]
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    best = np.full(px.shape, np.inf)
    bx, by = np.zeros(px.shape), np.zeros(px.shape)
    for r in rects:
        cr, sr = math.cos(r.yaw), math.sin(r.yaw)
        qx, qy = lx - r.cx, ly - r.cy
        ux, uy = cr * qx + sr * qy, -sr * qx + cr * qy
        ex = np.sign(ux) * np.maximum(np.abs(ux) - r.length / 2, 0.0)
        ey = np.sign(uy) * np.maximum(np.abs(uy) - r.width / 2, 0.0)
        d = np.hypot(ex, ey)
        better = d < best
        best = np.where(better, d, best)
        # back to the robot frame, then to the site frame
        vx, vy = cr * ex - sr * ey, sr * ex + cr * ey
        bx = np.where(better, vx, bx)
        by = np.where(better, vy, by)
    n = np.where(best > 0, best, 1.0)
    gx, gy = (c * bx - s * by) / n, (s * bx + c * by) / n
    return best, np.where(best > 0, gx, 0.0), np.where(best > 0, gy, 0.0)


def _point_rects_distance(
    x: float, y: float, pose: tuple[float, float, float], rects: Sequence[Rect]
) -> tuple[float, float, float]:
    """:func:`rects_distance` of one point in plain floats: the same operations in the same order
    (``np.hypot`` for the norm), so the results are bit-identical; a few microseconds instead of the
    fixed cost of some thirty numpy calls on one-element arrays (the reactive workers call it per
    worker and step)."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    dx, dy = x - pose[0], y - pose[1]
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    best, bx, by = math.inf, 0.0, 0.0
    for r in rects:
        cr, sr = math.cos(r.yaw), math.sin(r.yaw)
        qx, qy = lx - r.cx, ly - r.cy
        ux, uy = cr * qx + sr * qy, -sr * qx + cr * qy
        ex = ((ux > 0) - (ux < 0)) * max(abs(ux) - r.length / 2, 0.0)
        ey = ((uy > 0) - (uy < 0)) * max(abs(uy) - r.width / 2, 0.0)
        d = float(_hypot(ex, ey))
        if d < best:
            best = d
            bx, by = cr * ex - sr * ey, sr * ex + cr * ey
    if not best > 0:
        return best, 0.0, 0.0
    return best, (c * bx - s * by) / best, (s * bx + c * by) / best


_RectConstants = list[tuple[float, float, float, float, float, float]]
_RECT_CONSTANTS: dict[int, tuple[tuple[Rect, ...], _RectConstants]] = {}


def _rect_constants(rects: Sequence[Rect]) -> _RectConstants:
    """Per rectangle: centre x, y, cos and sin of its yaw, half length, half width (the same numbers
    as computed from it each time), kept per footprint list while it holds the same rectangles."""
    key = tuple(rects)
    hit = _RECT_CONSTANTS.get(id(rects))
    if hit is not None and hit[0] == key:
        return hit[1]
    if len(_RECT_CONSTANTS) >= 256:
        _RECT_CONSTANTS.clear()
    out = [(r.cx, r.cy, math.cos(r.yaw), math.sin(r.yaw), r.length / 2, r.width / 2) for r in rects]
    _RECT_CONSTANTS[id(rects)] = (key, out)
    return out


def points_rects_offsets(
    xs: Sequence[float], ys: Sequence[float], pose: tuple[float, float, float], rects: Sequence[Rect]
) -> tuple[list[float], list[float]]:
    """The first half of :func:`points_rects_distance`: per point and rectangle (point-major), the
    offset (x, y, rectangle frame) of the point from the rectangle, whose norms the caller takes with
    ``np.hypot`` and hands to :func:`points_rects_nearest`."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    x0, y0 = pose[0], pose[1]
    consts = _rect_constants(rects)
    exs: list[float] = []
    eys: list[float] = []
    for x, y in zip(xs, ys, strict=True):
        dx, dy = x - x0, y - y0
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        for rcx, rcy, cr, sr, hl, hw in consts:
            qx, qy = lx - rcx, ly - rcy
            ux, uy = cr * qx + sr * qy, -sr * qx + cr * qy
            exs.append(((ux > 0) - (ux < 0)) * max(abs(ux) - hl, 0.0))
            eys.append(((uy > 0) - (uy < 0)) * max(abs(uy) - hw, 0.0))
    return exs, eys


def points_rects_nearest(
    norms: Sequence[float], exs: Sequence[float], eys: Sequence[float], n: int,
    pose: tuple[float, float, float], rects: Sequence[Rect]
) -> list[tuple[float, float, float]]:
    """The second half of :func:`points_rects_distance`: per point of ``n``, the distance to the nearest
    rectangle and the unit direction (site frame) away from it, from :func:`points_rects_offsets`'
    offsets and their norms."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    trig = [(k[2], k[3]) for k in _rect_constants(rects)]
    out = []
    k = 0
    for _ in range(n):
        best, bx, by = math.inf, 0.0, 0.0
        for cr, sr in trig:
            d = norms[k]
            if d < best:
                ex, ey = exs[k], eys[k]
                best = d
                bx, by = cr * ex - sr * ey, sr * ex + cr * ey
            k += 1
        if not best > 0:
            out.append((best, 0.0, 0.0))
        else:
            out.append((best, (c * bx - s * by) / best, (s * bx + c * by) / best))
    return out


def points_rects_distance(
    xs: Sequence[float], ys: Sequence[float], pose: tuple[float, float, float], rects: Sequence[Rect]
) -> list[tuple[float, float, float]]:
    """:func:`_point_rects_distance` of a few points at once: the same operations per point and
    rectangle, with one ``np.hypot`` call for all norms (numpy's hypot gives the same number for an
    element of an array as for two floats), so the results are bit-identical."""
    exs, eys = points_rects_offsets(xs, ys, pose, rects)
    norms = _hypot(np.array(exs, dtype=np.float64), np.array(eys, dtype=np.float64)).tolist()
    return points_rects_nearest(norms, exs, eys, len(xs), pose, rects)


def distance_at_poses(
    px: FloatArray, py: FloatArray, rx: FloatArray, ry: FloatArray, ryaw: FloatArray, rects: Sequence[Rect]
) -> FloatArray:
    """Distance from points to the footprint at one robot pose per point (vectorised over samples)."""
    c, s = np.cos(ryaw), np.sin(ryaw)
    dx, dy = np.asarray(px) - rx, np.asarray(py) - ry
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    best = np.full(np.shape(lx), np.inf)
    for r in rects:
        cr, sr = math.cos(r.yaw), math.sin(r.yaw)
        qx, qy = lx - r.cx, ly - r.cy
        ux, uy = cr * qx + sr * qy, -sr * qx + cr * qy
        best = np.minimum(
            best,
            np.hypot(np.maximum(np.abs(ux) - r.length / 2, 0.0), np.maximum(np.abs(uy) - r.width / 2, 0.0)),
        )
    return np.asarray(best, dtype=np.float64)


def robot_speed(t: FloatArray, x: FloatArray, y: FloatArray) -> FloatArray:
    """Translational speed (m/s) of the robot base from its sampled positions (backward differences,
    0 at the first sample): the speed S_p is evaluated at in the safety figures.

    Example:
        >>> robot_speed(np.array([0.0, 1.0, 2.0]), np.array([0.0, 0.3, 0.3]), np.zeros(3)).tolist()
        [0.0, 0.3, 0.0]
    """
    t, x, y = (np.asarray(a, dtype=np.float64) for a in (t, x, y))
    v = np.zeros_like(t)
    if len(t) > 1:
        dt = np.diff(t)
        dt[dt <= 0] = np.inf
        v[1:] = np.hypot(np.diff(x), np.diff(y)) / dt
    return v


def sample_period_s(t: FloatArray) -> float:
    """The recording period: the median step between samples (0 for fewer than two samples)."""
    return float(np.median(np.diff(t))) if len(t) > 1 else 0.0


def time_below_s(t: FloatArray, separations: Sequence[FloatArray], limit: FloatArray | float) -> float:
    """**The** time below a limit: samples at which *any* worker's separation is below ``limit`` (a
    number, or one per sample such as S_p at the robot's speed), times the recording period.

    One worker or several at once count the same: it is time of the run, not worker-seconds.

    Example:
        >>> t = np.arange(5.0)
        >>> time_below_s(t, [np.array([2.0, 0.5, 0.5, 2, 2]), np.array([2, 2, 0.5, 0.5, 2.0])], 1.0)
        3.0
    """
    t = np.asarray(t, dtype=np.float64)
    lim = np.broadcast_to(np.asarray(limit, dtype=np.float64), t.shape)
    below = np.zeros(t.shape, dtype=bool)
    for s in separations:
        below |= np.asarray(s, dtype=np.float64) < lim
    return float(np.count_nonzero(below)) * sample_period_s(t)


def hazard_rects(robot: Sequence[Rect], element_rects: Mapping[str, Rect] | None, mode: str) -> list[Rect]:
    """The hazard footprint: the base plus the held element's rectangle for ``mode`` (see module doc)."""
    key = MODE_RECT.get(mode)
    if element_rects is None or key is None or key not in element_rects:
        return list(robot)
    return [*robot, element_rects[key]]


def separation(
    px: FloatArray,
    py: FloatArray,
    pose: tuple[float, float, float],
    rects: Sequence[Rect],
    *,
    dz_m: float = 0.0,
    radius_m: float = WORKER_RADIUS_M,
) -> FloatArray:
    """Separation (m) of worker discs at (px, py) from the hazard footprint (0 on contact)."""
    d, _, _ = rects_distance(px, py, pose, rects)
    return np.asarray(np.maximum(np.hypot(d, dz_m) - radius_m, 0.0), dtype=np.float64)


_REACH_SEEN: dict[int, tuple[tuple[Rect, ...], float]] = {}  # id of a rects sequence: its rects, reach


def reach_m(rects: Sequence[Rect]) -> float:
    """The farthest footprint corner from the base centre (m).

    (Asked several times per control period of the same footprint list: kept per list object and
    given again while the list holds the same rectangles - a tuple comparison that finds the same
    objects without hashing them - else computed, or read from the cache of the rectangles.)"""
    key = tuple(rects)
    hit = _REACH_SEEN.get(id(rects))
    if hit is not None and hit[0] == key:
        return hit[1]
    if len(_REACH_SEEN) >= 256:
        _REACH_SEEN.clear()
    reach = _reach(key)
    _REACH_SEEN[id(rects)] = (key, reach)
    return reach


@functools.lru_cache(maxsize=256)
def _reach(rects: tuple[Rect, ...]) -> float:
    return max(float(np.max(np.hypot(*r.corners().T))) for r in rects)
