"""Navigation (B5), a planned base path as pieces to time: turns on the spot and continuous drives, with
the corners of a skid-steer path rounded where the footprint fits.

Takes the waypoints of a planned path (x, y, yaw; turn-drive-turn as
:func:`kbplanner.simulation.motion_check.turn_drive_turn` writes them) and, for :func:`blend_corners`, the
configuration space the path was planned in and the base's limits. Returns :class:`Spin` pieces (turn on
the spot, rest to rest) and :class:`Run` pieces (a drive from rest to rest through dense poses whose
heading and yaw rate change continuously), which :mod:`kbplanner.simulation.base_trajectory` times.

:func:`split_pieces` keeps the path as it is (a stop at every corner). :func:`blend_corners` replaces
"drive, turn on the spot, drive" by a curve on which the heading follows a half cosine over its length
(curvature zero at both ends, so the yaw rate starts and ends at zero): the robot turns while driving.
Each curve is checked with the exact motion check of the configuration space the path was planned in
(:class:`~kbplanner.simulation.motion_check.ExactMotion`, the planner's own validator) on dense poses;
a corner keeps its turn on the spot where no curve fits or where the curve would not save time.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from kbplanner.simulation.motion_check import ExactMotion
from kbplanner.simulation.nav_path import Pose2D, wrap
from kbplanner.world.footprint import ConfigurationSpace

EPS_M = 1e-9
BLEND_SCALES = (1.0, 0.7, 0.5, 0.35, 0.25)  # fractions of the full-speed curve length tried per corner
MIN_BLEND_M = 0.1  # shorter curves are not tried
CURVE_STEP_M = 0.01  # spacing of a curve's poses
SE2_BLEND_M = (0.8, 0.4, 0.2, 0.1, 0.05)  # how far from a corner an SE(2) rounding may start, tried in order


@dataclass(frozen=True)
class Spin:
    """A turn on the spot at (x, y) from ``yaw0`` by ``dyaw`` (radians, signed), rest to rest."""

    x: float
    y: float
    yaw0: float
    dyaw: float


@dataclass(frozen=True)
class Run:
    """A drive from rest to rest through ``poses`` (straight motions between them, yaw the short way);
    within a run the direction of travel and the yaw rate per metre change without jumps."""

    poses: tuple[Pose2D, ...]


Piece = Spin | Run


@dataclass(frozen=True)
class _Drive:
    a: Pose2D
    b: Pose2D

    @property
    def length(self) -> float:
        return math.hypot(self.b[0] - self.a[0], self.b[1] - self.a[1])

    @property
    def direction(self) -> float:
        return math.atan2(self.b[1] - self.a[1], self.b[0] - self.a[0])

    @property
    def offset(self) -> float | None:
        """Heading minus direction of travel (0 forwards, pi backwards) for a drive at constant yaw,
        else None (a motion turning while it translates)."""
        if abs(wrap(self.b[2] - self.a[2])) > 1e-9:
            return None
        off = wrap(self.a[2] - self.direction)
        if abs(off) < 1e-6:
            return 0.0
        if abs(abs(off) - math.pi) < 1e-6:
            return math.pi
        return None


def _along(dr: _Drive, s: float) -> Pose2D:
    """The pose ``s`` metres along a drive (position and yaw linear)."""
    u = s / dr.length
    return (dr.a[0] + u * (dr.b[0] - dr.a[0]), dr.a[1] + u * (dr.b[1] - dr.a[1]),
            wrap(dr.a[2] + u * wrap(dr.b[2] - dr.a[2])))


def _se2_blend(p: _Drive, q: _Drive, d: float) -> list[Pose2D]:
    """Poses of a rounded corner between drives ``p`` and ``q`` (at least one turning while it drives):
    from ``d`` before the corner to ``d`` after it, the centre on a quadratic Bezier curve (the corner its
    control point), the yaw a cubic through the yaw and yaw per metre of both drives at its ends."""
    a, c = _along(p, p.length - d), _along(q, d)
    v = p.b
    ka, kb = wrap(p.b[2] - p.a[2]) / p.length, wrap(q.b[2] - q.a[2]) / q.length
    y0 = a[2]
    y1 = y0 + wrap(c[2] - y0)  # the short way from the yaw at the start to the yaw at the end
    m0, m1 = 2 * d * ka, 2 * d * kb  # yaw per unit of the curve parameter at its ends
    n = max(8, math.ceil(2 * d / CURVE_STEP_M))
    t = np.arange(n + 1) / n
    x = (1 - t) ** 2 * a[0] + 2 * t * (1 - t) * v[0] + t**2 * c[0]
    y = (1 - t) ** 2 * a[1] + 2 * t * (1 - t) * v[1] + t**2 * c[1]
    h00, h10, h01, h11 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t, -2 * t**3 + 3 * t**2, t**3 - t**2
    yaw = h00 * y0 + h10 * m0 + h01 * y1 + h11 * m1
    pts = [(float(px), float(py), wrap(float(pt))) for px, py, pt in zip(x, y, yaw, strict=True)]
    pts[0], pts[-1] = a, c
    return pts


def _parse(poses: Sequence[Pose2D]) -> tuple[list[Spin], list[_Drive], list[list[Spin]], list[Spin]]:
    """Leading spins, drives, the spins between drive k-1 and k (index k, 0 unused), trailing spins."""
    lead: list[Spin] = []
    drives: list[_Drive] = []
    between: list[list[Spin]] = [[]]
    pending: list[Spin] = []
    for a, b in itertools.pairwise(poses):
        d = math.hypot(b[0] - a[0], b[1] - a[1])
        if d <= EPS_M:
            dyaw = wrap(b[2] - a[2])
            if abs(dyaw) > 1e-12:
                pending.append(Spin(a[0], a[1], a[2], dyaw))
            continue
        if not drives:
            lead = pending
        else:
            between.append(pending)
        pending = []
        drives.append(_Drive(a, b))
    if not drives:
        return pending, [], [[]], []
    return lead, drives, between, pending


def _continues(prev: _Drive | None, dr: _Drive, spins: list[Spin]) -> bool:
    """Whether ``dr`` goes on from ``prev`` without a stop: no turn between, the same direction of travel
    and the same yaw rate per metre."""
    return (prev is not None and not spins and abs(wrap(dr.direction - prev.direction)) < 1e-9
            and abs(wrap(dr.b[2] - dr.a[2]) / dr.length - wrap(prev.b[2] - prev.a[2]) / prev.length) < 1e-9)


def split_pieces(poses: Sequence[Pose2D]) -> list[Piece]:
    """The path as it is: every turn on the spot a :class:`Spin`, every drive a :class:`Run`; drives
    that continue in the same direction at the same yaw rate per metre form one run."""
    lead, drives, between, trail = _parse(poses)
    out: list[Piece] = list(lead)
    run: list[Pose2D] = []
    for k, dr in enumerate(drives):
        if not _continues(drives[k - 1] if k else None, dr, between[k]):
            if run:
                out.append(Run(tuple(run)))
            out.extend(between[k])
            run = [dr.a]
        run.append(dr.b)
    if run:
        out.append(Run(tuple(run)))
    out.extend(trail)
    return out


def curve_length_for(theta: float, max_speed: float, max_yaw_rate: float, max_yaw_accel: float) -> float:
    """Length of the half-cosine curve that turns by ``theta`` at ``max_speed`` within the yaw rate and
    half the yaw acceleration (the other half is left for speeding up or slowing down on it)."""
    th = abs(theta)
    return max(max_speed * th * math.pi / (2 * max_yaw_rate),
               max_speed * math.pi * math.sqrt(th / max_yaw_accel))


def curve_speed(theta: float, length: float, max_speed: float, max_yaw_rate: float,
                max_yaw_accel: float) -> float:
    """Top speed on a half-cosine curve of ``length`` turning by ``theta`` (see :func:`curve_length_for`)."""
    th = abs(theta)
    if th < 1e-12:
        return max_speed
    return min(max_speed, 2 * length * max_yaw_rate / (th * math.pi),
               length / math.pi * math.sqrt(max_yaw_accel / th))


def _curve(corner: Pose2D, h1: float, theta: float, length: float, offset: float
           ) -> tuple[list[Pose2D], float]:
    """Poses of the curve around ``corner`` (the drive in at direction ``h1``, out at ``h1 + theta``) and
    how far from the corner it leaves and rejoins the two straight lines."""
    n = max(8, math.ceil(length / CURVE_STEP_M))
    u = (np.arange(n) + 0.5) / n  # midpoints: the heading profile is symmetric, so is the curve
    heading = h1 + theta * (1.0 - np.cos(np.pi * u)) / 2.0
    ds = length / n
    dx, dy = np.cos(heading) * ds, np.sin(heading) * ds
    hm = h1 + theta / 2.0
    along = float(np.sum(dx * math.cos(hm) + dy * math.sin(hm)))  # chord, along the bisector
    d = along / (2.0 * math.cos(theta / 2.0))
    x0, y0 = corner[0] - d * math.cos(h1), corner[1] - d * math.sin(h1)
    xs = x0 + np.concatenate([[0.0], np.cumsum(dx)])
    ys = y0 + np.concatenate([[0.0], np.cumsum(dy)])
    u_all = np.arange(n + 1) / n
    yaws = h1 + theta * (1.0 - np.cos(np.pi * u_all)) / 2.0 + offset
    pts = [(float(x), float(y), wrap(float(t))) for x, y, t in zip(xs, ys, yaws, strict=True)]
    h2 = h1 + theta
    pts[-1] = (corner[0] + d * math.cos(h2), corner[1] + d * math.sin(h2), wrap(h2 + offset))
    return pts, d


def _spin_time(dyaw: float, vmax: float, amax: float) -> float:
    dist = abs(dyaw)
    if dist <= 0:
        return 0.0
    if dist >= vmax * vmax / amax:
        return dist / vmax + vmax / amax
    return 2.0 * math.sqrt(dist / amax)


def blend_corners(
    poses: Sequence[Pose2D],
    space: ConfigurationSpace,
    max_speed_mps: float,
    max_yaw_rate_rps: float,
    max_accel_mps2: float,
    max_yaw_accel_rps2: float,
) -> list[Piece]:
    """The path's pieces with "drive, turn on the spot, drive" corners rounded where that is free and faster.

    A corner between two drives at constant yaw (both forwards or both backwards) becomes a half-cosine
    curve of the length that keeps the top speed within the yaw rate and acceleration limits, or a
    shorter one (``BLEND_SCALES``; slower on it) where that does not fit. A curve may use a drive's
    length up to its end (half of it when the next corner may round too). Candidates are tried from the
    largest estimated saving (time on the spot and stopping, against time on the curve); the first
    one free in ``space`` by :class:`ExactMotion` is taken. A corner next to a drive that already turns
    while it translates (the planner's SE(2) fallback where turning on the spot is blocked) is rounded
    as in SE(2) (:func:`_se2_blend`), the largest of ``SE2_BLEND_M`` that fits and is free. Deterministic:
    no sampling.
    """
    lead, drives, between, trail = _parse(poses)
    if len(drives) < 2:
        return split_pieces(poses)
    exact = ExactMotion(space)
    vmax, wmax, amax, alpha = max_speed_mps, max_yaw_rate_rps, max_accel_mps2, max_yaw_accel_rps2
    n = len(drives)

    def candidate(k: int) -> tuple[float, float | None] | None:
        """(theta, offset) of corner k (between drives k-1 and k) if it may be rounded: offset None for
        a corner rounded in SE(2)."""
        p, q = drives[k - 1], drives[k]
        theta = wrap(q.direction - p.direction)
        if abs(theta) > math.radians(170.0):
            return None
        if p.offset is None or q.offset is None:
            return None if _continues(p, q, between[k]) else (theta, None)
        if p.offset != q.offset or abs(theta) < 1e-9:
            return None
        return theta, p.offset

    curves: dict[int, tuple[list[Pose2D], float]] = {}
    used_start = [0.0] * n  # length of each drive's start taken by the curve before it
    for k in range(1, n):
        cand = candidate(k)
        if cand is None:
            continue
        theta, offset = cand
        room_in = drives[k - 1].length - used_start[k - 1]
        room_out = drives[k].length * (0.5 if k + 1 < n and candidate(k + 1) is not None else 1.0)
        if offset is None:
            for d in SE2_BLEND_M:
                if d <= room_in - 1e-6 and d <= room_out - 1e-6:
                    pts = _se2_blend(drives[k - 1], drives[k], d)
                    if exact.path_free(pts):
                        curves[k] = (pts, d)
                        used_start[k] = d
                        break
            continue
        on_spot = sum(_spin_time(s.dyaw, wmax, alpha) for s in between[k]) + vmax / amax
        full = curve_length_for(theta, vmax, wmax, alpha)
        options = []
        for f in BLEND_SCALES:
            length = full * f
            if length < MIN_BLEND_M:
                continue
            v = curve_speed(theta, length, vmax, wmax, alpha)
            d = length * float(np.mean(np.cos(theta / 2 * np.cos(np.pi * (np.arange(64) + 0.5) / 64)))) / (
                2 * math.cos(theta / 2))
            if d > room_in - 1e-6 or d > room_out - 1e-6:
                continue
            slow = (vmax - v) ** 2 / (amax * vmax)
            saving = on_spot + 2 * d / vmax - (length / v + slow)
            if saving > 0:
                options.append((-saving, f, length))
        for _, _, length in sorted(options):
            corner = drives[k - 1].b
            pts, d = _curve(corner, drives[k - 1].direction, theta, length, offset)
            if d > room_in - 1e-6 or d > room_out - 1e-6:
                continue
            if exact.path_free(pts):
                curves[k] = (pts, d)
                used_start[k] = d
                break

    out: list[Piece] = list(lead)
    run: list[Pose2D] = []
    for k, dr in enumerate(drives):
        if k in curves:
            pts = curves[k][0]  # the run goes on through the curve
            joined = math.hypot(pts[0][0] - run[-1][0], pts[0][1] - run[-1][1]) <= EPS_M
            run.extend(pts[1:] if joined else pts)
        elif not _continues(drives[k - 1] if k else None, dr, between[k]):
            if run:
                out.append(Run(tuple(run)))
            out.extend(between[k])
            run = [dr.a]
        end = _along(dr, dr.length - curves[k + 1][1]) if k + 1 in curves else dr.b
        if math.hypot(end[0] - run[-1][0], end[1] - run[-1][1]) > EPS_M:
            run.append(end)
    if run:
        out.append(Run(tuple(run)))
    out.extend(trail)
    return out
