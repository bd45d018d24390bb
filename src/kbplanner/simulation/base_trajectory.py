"""Navigation (B5), time parameterisation: a planned base path as timed samples at a fixed rate.

Takes a :class:`~kbplanner.simulation.nav_path.NavPath` (or its poses), the base's limits (speed, yaw
rate, accelerations) and, optionally, the configuration space the path was planned in;
:func:`time_parameterize` gives a :class:`Trajectory`. The path is cut into pieces
(:mod:`kbplanner.simulation.path_pieces`): turns on the spot, timed rest to rest (trapezoid), and runs,
driven without stopping at their inner waypoints: the speed along a run is the largest that keeps
the top speed, the centripetal acceleration (within the acceleration limit), the yaw rate (speed x
yaw per metre) and the yaw acceleration within the limits and
reaches each point from rest at the start and to rest at the end within the acceleration (forward and
backward passes over 1 cm of path). With the configuration space, corners are rounded into curves
where they fit (the robot turns while driving). The executor moves the base kinematically along the
samples; speed and separation monitoring scales how far along them it gets per control period.
"""

from __future__ import annotations

import bisect
import contextlib
import math
import struct
import weakref
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kbplanner.core.errors import KbplannerError
from kbplanner.simulation.nav_path import NavPath, Pose2D
from kbplanner.simulation.path_pieces import Piece, Run, Spin, blend_corners, split_pieces
from kbplanner.world.footprint import ConfigurationSpace

PROFILE_STEP_M = 0.01  # path step of the speed profile of a run


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


@dataclass(frozen=True)
class _Profile:
    """A run's speed profile: at arc lengths ``s`` (m), speeds ``v`` and times ``t`` (constant
    acceleration between grid points); ``cum`` the arc length at each pose of the run, ``yaw`` the
    run's yaw without wraps there."""

    poses: npt.NDArray[np.float64]
    cum: npt.NDArray[np.float64]
    yaw: npt.NDArray[np.float64]
    s: npt.NDArray[np.float64]
    v: npt.NDArray[np.float64]
    t: npt.NDArray[np.float64]

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def at(self, times: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Poses (n, 3) at ``times`` from the run's start."""
        tt = np.clip(times, 0.0, self.duration)
        i = np.clip(np.searchsorted(self.t, tt, side="right") - 1, 0, len(self.t) - 2)
        ds = self.s[i + 1] - self.s[i]
        acc = (self.v[i + 1] ** 2 - self.v[i] ** 2) / (2.0 * ds)
        tau = tt - self.t[i]
        s = np.clip(self.s[i] + self.v[i] * tau + 0.5 * acc * tau * tau, self.s[i], self.s[i + 1])
        s = np.where(tt >= self.duration, self.cum[-1], s)
        x = np.interp(s, self.cum, self.poses[:, 0])
        y = np.interp(s, self.cum, self.poses[:, 1])
        yaw = np.interp(s, self.cum, self.yaw)
        return np.stack([x, y, yaw], axis=1)


def _profile(run: Run, vmax: float, wmax: float, amax: float, alpha: float) -> _Profile:
    """The fastest speed profile along ``run`` from rest to rest within the limits (module doc)."""
    p = np.asarray(run.poses, dtype=np.float64).reshape(-1, 3)
    seg = np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1]))
    keep = np.concatenate([[True], seg > 1e-12])
    p = p[keep]
    seg = np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1]))
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    dyaw = (np.diff(p[:, 2]) + math.pi) % (2 * math.pi) - math.pi
    yaw = p[0, 2] + np.concatenate([[0.0], np.cumsum(dyaw)])
    total = float(cum[-1])
    if total <= 0.0:
        zero = np.zeros(2)
        return _Profile(p[:1].repeat(2, axis=0), zero, np.full(2, p[0, 2]), np.array([0.0, 1.0]), zero, zero)
    n = max(3, math.ceil(total / PROFILE_STEP_M) + 1)
    s = np.linspace(0.0, total, n)
    ds = total / (n - 1)
    # yaw per metre (k1) and its change per metre (k2), per grid cell
    yg = np.interp(s, cum, yaw)
    k1c = np.diff(yg) / ds  # per cell
    k1 = np.concatenate([[k1c[0]], np.maximum(np.abs(k1c[:-1]), np.abs(k1c[1:])), [k1c[-1]]])
    k1 = np.abs(k1)
    k2 = np.zeros(n)
    k2[1:-1] = np.abs(np.diff(k1c)) / ds
    # curvature of the centre's path (direction of travel per metre), for the centripetal acceleration
    heading = np.arctan2(np.diff(np.interp(s, cum, p[:, 1])), np.diff(np.interp(s, cum, p[:, 0])))
    kappa = np.zeros(n)
    kappa[1:-1] = np.abs((np.diff(heading) + math.pi) % (2 * math.pi) - math.pi) / ds
    with np.errstate(divide="ignore"):
        vlim = np.minimum(vmax, np.where(kappa > 1e-12, np.sqrt(amax / np.maximum(kappa, 1e-300)), np.inf))
        vlim = np.minimum(vlim, np.where(k1 > 1e-12, wmax / np.maximum(k1, 1e-300), np.inf))
        vlim = np.minimum(vlim, np.where(k2 > 1e-12, np.sqrt(0.5 * alpha / np.maximum(k2, 1e-300)), np.inf))
        alim_pt = np.where(k1 > 1e-12, np.minimum(amax, 0.5 * alpha / np.maximum(k1, 1e-300)), amax)
    alim = np.minimum(alim_pt[:-1], alim_pt[1:])  # per cell
    v = np.asarray(_rest_to_rest(vlim, (2.0 * alim * ds).tolist()))
    dt = 2.0 * ds / (v[:-1] + v[1:])
    t = np.concatenate([[0.0], np.cumsum(dt)])
    return _Profile(p, cum, yaw, s, v, t)


def _rest_to_rest(vlim: npt.NDArray[np.float64], two_a_ds: list[float]) -> list[float]:
    """The speeds of :func:`_profile`'s forward pass (from rest: ``v[i + 1] = min(vlim[i + 1],
    sqrt(v[i] ** 2 + two_a_ds[i]))``) and backward pass (to rest: ``v[i] = min(v[i], sqrt(v[i + 1] ** 2 +
    two_a_ds[i]))``), the very numbers of those loops with the work whose result is known left out.

    ``two_a_ds >= 0``, so ``sqrt(w * w + step) >= w`` in floats (the rounded square root of a rounded
    square is the number itself; adding, rounding and the square root never decrease): where the speed
    already reached is at least the next limit, the pass takes the limit (``min`` takes its first
    argument when equal). So once a pass meets its limit it runs on at the limits without a square
    root until a limit rises (forward) or, backward, the forward speeds fall; only the stretches
    between (speeding up, slowing down) are worked out step by step.
    """
    sqrt = math.sqrt
    n = len(vlim)
    vl = vlim.tolist()
    rises = np.flatnonzero(vlim[1:] > vlim[:-1]).tolist()  # j: vl[j + 1] > vl[j]
    fwd = list(vl)
    fwd[0] = w = 0.0
    i = 0
    while i < n - 1:  # forward: from rest, within the acceleration
        lim = vl[i + 1]
        u = sqrt(w * w + two_a_ds[i])
        if u < lim:
            fwd[i + 1] = w = u
            i += 1
            continue
        # at the limit at i + 1: the limits up to the next rise (fwd holds them)
        k = bisect.bisect_left(rises, i + 1)
        i = rises[k] if k < len(rises) else n - 1
        w = vl[i]
    fwd[-1] = 0.0
    f = np.asarray(fwd)
    falls = np.flatnonzero(f[:-1] > f[1:]).tolist()  # j: fwd[j] > fwd[j + 1]
    out = list(fwd)
    w = 0.0
    i = n - 2
    while i >= 0:  # backward: to rest
        cur = fwd[i]
        u = sqrt(w * w + two_a_ds[i])
        if u < cur:
            out[i] = w = u
            i -= 1
            continue
        # at the forward speed at i: the forward speeds down to the next fall below i (out holds them)
        k = bisect.bisect_right(falls, i - 1) - 1
        i = falls[k] if k >= 0 else -1
        w = fwd[i + 1]
    return out


def time_parameterize(
    path: NavPath | Sequence[Pose2D],
    max_speed_mps: float,
    max_yaw_rate_rps: float,
    max_accel_mps2: float = 1.0,
    max_yaw_accel_rps2: float = 2.0,
    rate_hz: float = 10.0,
    space: ConfigurationSpace | None = None,
) -> Trajectory:
    """Timed samples along a path: turns on the spot rest to rest, drives without stopping where the
    direction and yaw rate go on smoothly (module doc).

    Without ``space`` the path's geometry is kept: the robot stops at every waypoint where it turns
    (or where its yaw rate per metre changes). With ``space`` (the configuration space the path was
    planned in) corners are rounded into curves checked free in it
    (:func:`~kbplanner.simulation.path_pieces.blend_corners`), and the robot turns while it drives.
    Samples are ``1 / rate_hz`` apart, plus the final pose, which is the path's last waypoint.
    """
    poses = list(path.poses if isinstance(path, NavPath) else path)
    if min(max_speed_mps, max_yaw_rate_rps, max_accel_mps2, max_yaw_accel_rps2, rate_hz) <= 0:
        raise KbplannerError("speed, yaw rate, accelerations and rate must be positive",
                             element="time_parameterize", fix="give the robot's limits (> 0)")
    if not poses:
        return Trajectory((), ())
    limits = (max_speed_mps, max_yaw_rate_rps, max_accel_mps2, max_yaw_accel_rps2)
    key = _timed_key(poses, space, (*limits, rate_hz))
    if key is not None:
        hit = _TIMED.get(key)
        if hit is not None and hit[0]() is space:
            with contextlib.suppress(KeyError):  # (dropped meanwhile by another thread)
                _TIMED.move_to_end(key)
            return hit[1]
    pieces: list[Piece] = blend_corners(poses, space, *limits) if space is not None else split_pieces(poses)
    traj = time_pieces(pieces, poses[0], poses[-1], *limits, rate_hz=rate_hz)
    if key is not None:
        _TIMED[key] = (weakref.ref(space) if space is not None else _no_space, traj)
        while len(_TIMED) > TIMED_KEPT:
            with contextlib.suppress(KeyError):
                _TIMED.popitem(last=False)
    return traj


#: how many timed paths :func:`time_parameterize` keeps (the navigation times a leg to compare it with
#: others and again to drive it, the same poses in another list: about two in five calls repeat one)
TIMED_KEPT = 64
_TIMED: OrderedDict[tuple[object, ...], tuple[Callable[[], object], Trajectory]] = OrderedDict()


def _no_space() -> None:
    return None


def _timed_key(poses: Sequence[Pose2D], space: ConfigurationSpace | None,
               numbers: tuple[float, ...]) -> tuple[object, ...] | None:
    """What a timed path depends on, bit for bit: the poses' floats (None, not kept, unless every one
    is a Python float: a numpy scalar's arithmetic may differ in the last bit), the space (by identity;
    its entry holds a weak reference, checked on a hit) and the limits with their types."""
    flat = [v for p in poses for v in p]
    if len(flat) != 3 * len(poses) or not all(type(v) is float for v in flat):
        return None
    return (struct.pack(f"{len(flat)}d", *flat), id(space), tuple((type(v), v) for v in numbers))


def time_pieces(
    pieces: Sequence[Piece],
    first: Pose2D,
    last: Pose2D,
    max_speed_mps: float,
    max_yaw_rate_rps: float,
    max_accel_mps2: float,
    max_yaw_accel_rps2: float,
    rate_hz: float = 10.0,
) -> Trajectory:
    """Timed samples at ``rate_hz`` through ``pieces`` (from ``first``, ending exactly at ``last``)."""
    timed: list[tuple[float, Spin | _Profile]] = []
    for pc in pieces:
        if isinstance(pc, Spin):
            timed.append((_trapezoid_time(abs(pc.dyaw), max_yaw_rate_rps, max_yaw_accel_rps2), pc))
        else:
            prof = _profile(pc, max_speed_mps, max_yaw_rate_rps, max_accel_mps2, max_yaw_accel_rps2)
            timed.append((prof.duration, prof))
    starts = np.concatenate([[0.0], np.cumsum([d for d, _ in timed])])
    total = float(starts[-1])
    n = math.floor(total * rate_hz + 1e-9)
    times = np.arange(n + 1) / rate_hz
    if total - float(times[-1]) > 1e-9:
        times = np.append(times, total)
    out = np.empty((len(times), 3))
    out[:] = first
    which = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, max(0, len(timed) - 1))
    for k, (dur, item) in enumerate(timed):
        sel = np.flatnonzero(which == k)
        if not len(sel):
            continue
        local = times[sel] - starts[k]
        if isinstance(item, Spin):
            u = np.array([_trapezoid_progress(float(t), dur, abs(item.dyaw), max_yaw_rate_rps,
                                              max_yaw_accel_rps2) for t in local])
            out[sel, 0], out[sel, 1], out[sel, 2] = item.x, item.y, item.yaw0 + u * item.dyaw
        else:
            out[sel] = item.at(local)
    # (wrap inline: the same operations on the same floats)
    pi, two_pi = math.pi, 2 * math.pi
    result = [(x, y, (t + pi) % two_pi - pi) for x, y, t in out.tolist()]
    result[-1] = (float(last[0]), float(last[1]), float(last[2]))
    return Trajectory(tuple([round(t, 9) for t in times.tolist()]), tuple(result))
