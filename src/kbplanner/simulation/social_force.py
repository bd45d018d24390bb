"""B5 reactive workers: a small social-force model (Helbing & Molnar 1995) for people on a site.

Each worker is a disc (radius 0.25 m) with a position and a velocity, stepped once per control
period (explicit Euler) together with the robot. Per unit mass, the acceleration is

    dv/dt = (v0 e - v) / tau                                        driving term (desired velocity)
          + sum_j  w(phi_ij) (A_p / B_p) exp(-(d_ij - 2r - s_p) / B_p) n_ij    other workers
          + w(phi_iR) (A_r / B_r) exp(-(d_iR - r - s_c) / B_r) n_iR            the robot and its load

with ``e`` the direction to the next waypoint of the worker's route and ``v0`` their walking speed,
``tau`` the relaxation time, ``d_ij`` the centre distance to another worker, ``d_iR`` the distance
from the worker's centre to the robot's hazard footprint (:mod:`kbplanner.simulation.separation`),
``s_p`` the personal distance kept from other workers and ``s_c`` the comfort distance kept from the
robot (both shift the exponential repulsion outwards), ``n`` the unit vector away from the other
party, and ``w(phi) = lam + (1 - lam) (1 + cos phi) / 2`` the anisotropy (what is ahead matters more
than what is behind; phi between the walking direction and the other party). A worker sees the
robot as it was ``reaction_time_s`` ago (perception delay). Speeds are capped at 1.3 v0 (Helbing et
al. 2000). Two rules make the model usable on a site, documented as additions to it:

- **Pass on the right.** Repulsion from an obstacle ahead is turned 20 degrees to the worker's right
  (pedestrians' side preference; Helbing & Molnar 1995, section 3), which breaks head-on deadlocks.
- **No contact by the worker's own step.** A step that would bring the worker's disc into the robot's
  footprint, another worker or an occupied cell of the walking map is cut back (the component into
  the obstacle removed, else no move): people do not walk into a machine or a wall they see. Contact
  can then only come from the robot's own motion, which speed and separation monitoring must
  prevent (:mod:`kbplanner.simulation.separation_monitor`).

Parameters (defaults, overridable per worker in the site Turtle): ``tau`` 0.5 s, ``A_p`` 2.1 m^2/s^2
and ``B_p`` 0.3 m (Helbing & Molnar 1995: V0 = 2.1 m^2/s^2, sigma = 0.3 m), robot repulsion
``A_r`` 10 m^2/s^2 and ``B_r`` 0.2 m (their obstacle potential U0 = 10 m^2/s^2, R = 0.2 m), ``lam``
0.5 (anisotropy, Helbing et al. 2000), personal distance 0.45 m (Hall 1966, the edge of intimate
space), comfort distance to the robot 1.2 m (the outer edge of Hall's 0.45-1.2 m personal zone;
Pacchierotti et al. 2006 found people prefer a passing robot to keep to that zone's edge or beyond),
reaction time 0.5 s. The anisotropy applies among people only: a moving machine is heard all round.

Helbing, D. & Molnar, P. (1995) Social force model for pedestrian dynamics. Phys. Rev. E 51, 4282.
Helbing, D., Farkas, I. & Vicsek, T. (2000) Simulating dynamical features of escape panic. Nature 407.
Hall, E. T. (1966) The Hidden Dimension. Pacchierotti, E., Christensen, H. I. & Jensfelt, P. (2006)
Evaluation of passing distance for social robots. IEEE RO-MAN.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.separation import (
    WORKER_RADIUS_M,
    _rect_constants,
    points_rects_nearest,
    points_rects_offsets,
    rects_distance,
)
from kbplanner.simulation.social_force_few import Frame, accelerations_few, robot_push, same_people_terms
from kbplanner.world.footprint import Rect

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
_hypot = np.hypot  # on two floats: the numbers of np.hypot on arrays

_RIGHT = math.radians(-20.0)
_COS_R, _SIN_R = math.cos(_RIGHT), math.sin(_RIGHT)
SMALL_CROWD = 8  # up to this many workers, accelerations() works on plain floats (the same numbers)


@dataclass(frozen=True)
class SocialForceParams:
    """The social-force constants of one worker (see module docstring; SI units)."""

    relaxation_time_s: float = 0.5
    personal_distance_m: float = 0.45
    comfort_distance_m: float = 1.2
    reaction_time_s: float = 0.5
    a_people: float = 2.1
    b_people: float = 0.3
    a_robot: float = 10.0
    b_robot: float = 0.2
    anisotropy: float = 0.5
    max_speed_factor: float = 1.3


@dataclass
class Obstacle:
    """The robot as the workers see it: a pose and its hazard footprint (robot frame)."""

    pose: tuple[float, float, float]
    rects: Sequence[Rect]


@functools.lru_cache(maxsize=64)
def _constants(params: tuple[SocialForceParams, ...]) -> dict[str, FloatArray]:
    """The per-worker constants as arrays (the same arrays for the same workers; read only)."""
    out = {
        "tau": np.array([p.relaxation_time_s for p in params]),
        "lam": np.array([p.anisotropy for p in params]),
        "a_p": np.array([p.a_people for p in params])[:, None],
        "b_p": np.array([p.b_people for p in params])[:, None],
        "s_p": np.array([p.personal_distance_m for p in params])[:, None],
        "a_r": np.array([p.a_robot for p in params]),
        "b_r": np.array([p.b_robot for p in params]),
        "s_c": np.array([p.comfort_distance_m for p in params]),
        "vmax_factor": np.array([p.max_speed_factor for p in params]),
    }
    # derived once, element-wise the same numbers as computed in each step
    out["a_over_b_p"] = out["a_p"] / out["b_p"]
    out["neg_b_p"] = -out["b_p"]
    out["neg_s_p"] = -out["s_p"]
    out["one_minus_lam"] = (1 - out["lam"])[:, None]
    out["a_over_b_r"] = out["a_r"] / out["b_r"]
    out["neg_b_r"] = -out["b_r"]
    out["neg_s_c"] = -out["s_c"]
    for a in out.values():
        a.flags.writeable = False
    return out


def accelerations(pos: FloatArray, vel: FloatArray, desired: FloatArray, params: Sequence[SocialForceParams],
                  seen: Obstacle | None, active: BoolArray, *, constants: dict[str, FloatArray] | None = None
                  ) -> FloatArray:
    """The social-force acceleration (n, 2) of every worker (inactive ones: none); ``constants``: those
    of ``params`` (:func:`constants_of`) when the caller keeps them.

    (Written for few workers, where each numpy call's fixed cost dominates: constants derived once
    per crowd, shared terms computed once; ``-x / b`` as ``x / -b`` and ``x * 1.0`` left out are the
    same numbers.)"""
    n = len(pos)
    k = constants if constants is not None else _constants(tuple(params))
    if n <= SMALL_CROWD:
        return _accelerations_few(pos, vel, desired, k, seen, active)
    acc = (desired - vel) / k["tau"][:, None]
    if n > 1:
        d = pos[:, None, :] - pos[None, :, :]
        dx, dy = d[..., 0], d[..., 1]
        dist = np.hypot(dx, dy)
        np.fill_diagonal(dist, np.inf)
        norm = np.where(dist > 0, dist, 1)
        nx, ny = dx / norm, dy / norm
        gap = np.maximum(dist - 2 * WORKER_RADIUS_M - k["s_p"], k["neg_s_p"])
        mag = k["a_over_b_p"] * np.exp(gap / k["neg_b_p"])
        mag = np.where(np.isfinite(dist) & active[None, :], mag, 0.0)
        # anisotropy: n points from the other party to the worker, ahead when -n . v > 0
        vx, vy = vel[:, 0:1], vel[:, 1:2]
        sp = np.hypot(vx, vy)
        cos_phi = np.where(sp > 1e-9, -(nx * vx + ny * vy) / np.maximum(sp, 1e-9), 1.0)
        mw = mag * (k["lam"][:, None] + k["one_minus_lam"] * (1 + cos_phi) / 2)
        acc[:, 0] += (mw * nx).sum(axis=1)
        acc[:, 1] += (mw * ny).sum(axis=1)
    if seen is not None:
        dr, ux, uy = rects_distance(pos[:, 0], pos[:, 1], seen.pose, seen.rects)
        # inside the footprint (ux = uy = 0): away from the robot's centre
        inside = (ux == 0) & (uy == 0)
        if inside.any():
            cx, cy = pos[:, 0] - seen.pose[0], pos[:, 1] - seen.pose[1]
            cn = np.maximum(np.hypot(cx, cy), 1e-9)
            ux, uy = np.where(inside, cx / cn, ux), np.where(inside, cy / cn, uy)
        gap = np.maximum(dr - WORKER_RADIUS_M - k["s_c"], k["neg_s_c"])
        mag = k["a_over_b_r"] * np.exp(gap / k["neg_b_r"])
        # a moving machine is heard all round: no anisotropy for the robot (weight 1)
        ahead = -(ux * vel[:, 0] + uy * vel[:, 1]) > 0
        acc[:, 0] += mag * np.where(ahead, _COS_R * ux - _SIN_R * uy, ux)
        acc[:, 1] += mag * np.where(ahead, _SIN_R * ux + _COS_R * uy, uy)
    return acc if active.all() else np.where(active[:, None], acc, 0.0)


def _accelerations_few(pos: FloatArray, vel: FloatArray, desired: FloatArray, k: dict[str, FloatArray],
                       seen: Obstacle | None, active: BoolArray) -> FloatArray:
    """:func:`accelerations` for a few workers in plain floats (:func:`accelerations_of`)."""
    n = len(pos)
    on = active.tolist()
    ax, ay = accelerations_of(pos[:, 0].tolist(), pos[:, 1].tolist(), vel[:, 0].tolist(), vel[:, 1].tolist(),
                              desired.tolist(), k, seen, on)
    acc = np.array([ax, ay], dtype=np.float64).T.reshape(n, 2)
    return acc if all(on) else np.where(active[:, None], acc, 0.0)


_Frame = Frame
_FRAME: list[tuple[object, object, _Frame]] = []


def _frame(seen: Obstacle) -> _Frame:
    """The robot's x, y, cos and sin of its yaw and its rectangles' constants
    (:func:`~kbplanner.simulation.separation.points_rects_offsets`' numbers), kept while the workers see
    the same pose and footprint objects."""
    if _FRAME and _FRAME[0][0] is seen.pose and _FRAME[0][1] is seen.rects:
        return _FRAME[0][2]
    pose = seen.pose
    frame = (pose[0], pose[1], math.cos(pose[2]), math.sin(pose[2]), list(_rect_constants(seen.rects)))
    _FRAME[:] = [(seen.pose, seen.rects, frame)]
    return frame


def accelerations_of(xs: list[float], ys: list[float], vxs: list[float], vys: list[float],
                     des: Sequence[Sequence[float]], k: dict[str, FloatArray], seen: Obstacle | None,
                     on: list[bool]) -> tuple[list[float], list[float]]:
    """:func:`accelerations` on plain floats (positions, velocities, desired velocities as lists; ``k``
    the crowd's :func:`constants_of`): the x and y accelerations, inactive workers' too (the caller
    zeroes them). The same operations in the same order, element by element, with numpy's ``hypot``
    and ``exp`` where the array code takes them (Python's ``math.hypot`` and ``math.exp`` may differ in
    the last bit; numpy's give the same number for an element wherever it is in an array, so one call
    serves the footprint offsets' norms, all the centre distances and the speeds, one all the
    exponentials), and the row sums added up in order from 0.0 (numpy's sum of a row of fewer than
    eight numbers), so the results are bit-identical.

    (Fewer than eight workers: :func:`kbplanner.simulation.social_force_few.accelerations_few`, the robot's
    frame kept while it stands; :func:`_accelerations_of_any` otherwise.)"""
    n = len(xs)
    if n >= 8:
        return _accelerations_of_any(xs, ys, vxs, vys, des, k, seen, on)
    c = _lists(k)
    hit = _SYMMETRIC.get(id(c))
    if hit is None or hit[0] is not c:
        hit = (c, same_people_terms(c))
        _SYMMETRIC[id(c)] = hit
    if seen is None:
        return accelerations_few(xs, ys, vxs, vys, des, c, hit[1], None, None, on)
    return accelerations_few(xs, ys, vxs, vys, des, c, hit[1], _frame(seen), seen.pose, on)


_SYMMETRIC: dict[int, tuple[dict[str, list[float]], bool]] = {}  # per constants' lists: same_people_terms


def _accelerations_of_any(xs: list[float], ys: list[float], vxs: list[float], vys: list[float],
                     des: Sequence[Sequence[float]], k: dict[str, FloatArray], seen: Obstacle | None,
                     on: list[bool]) -> tuple[list[float], list[float]]:
    """:func:`accelerations_of` for any number of workers (numpy's row sums from eight on).

    :func:`accelerations` on plain floats (positions, velocities, desired velocities as lists; ``k``
    the crowd's :func:`constants_of`): the x and y accelerations, inactive workers' too (the caller
    zeroes them). The same operations in the same order, element by element, with numpy's ``hypot``
    and ``exp`` where the array code takes them (Python's ``math.hypot`` and ``math.exp`` may differ in
    the last bit; numpy's give the same number for an element wherever it is in an array, so one call
    serves the footprint offsets' norms, all the centre distances and the speeds, one all the
    exponentials), and the row sums added up in order from 0.0 (numpy's sum of a row of fewer than
    eight numbers), so the results are bit-identical; a few dozen microseconds less per step than some
    fifty numpy calls on tiny arrays."""
    n = len(xs)
    c = _lists(k)
    tau, lam, oml = c["tau"], c["lam"], c["one_minus_lam"]
    ax = [(des[i][0] - vxs[i]) / tau[i] for i in range(n)]
    ay = [(des[i][1] - vys[i]) / tau[i] for i in range(n)]
    # one hypot call: the offsets from the footprint's rectangles, the centre distances (n x n, row i:
    # from worker i to each j) and the speeds
    if seen is not None:
        exs, eys = points_rects_offsets(xs, ys, seen.pose, seen.rects)
    else:
        exs, eys = [], []
    m0 = len(exs)
    if n > 1:
        h = _hypot(np.array(exs + [xi - xj for xi in xs for xj in xs] + vxs, dtype=np.float64),
                   np.array(eys + [yi - yj for yi in ys for yj in ys] + vys, dtype=np.float64)).tolist()
    elif m0:
        h = _hypot(np.array(exs, dtype=np.float64), np.array(eys, dtype=np.float64)).tolist()
    else:
        h = []
    near = points_rects_nearest(h, exs, eys, n, seen.pose, seen.rects) if seen is not None else None
    expo: list[float] = []
    inf = math.inf
    if n > 1:
        for i in range(n):
            h[m0 + i * n + i] = inf  # fill_diagonal
        s_p, neg_s_p, neg_b_p = c["s_p"], c["neg_s_p"], c["neg_b_p"]
        two_r = 2 * WORKER_RADIUS_M
        expo = [max(h[m0 + i * n + j] - two_r - s_p[i], neg_s_p[i]) / neg_b_p[i]
                for i in range(n) for j in range(n)]
    if near is not None:
        s_c, neg_s_c, neg_b_r = c["s_c"], c["neg_s_c"], c["neg_b_r"]
        expo += [max(near[i][0] - WORKER_RADIUS_M - s_c[i], neg_s_c[i]) / neg_b_r[i] for i in range(n)]
    e = np.exp(np.array(expo, dtype=np.float64)).tolist() if expo else []
    if n > 1:
        a_over_b_p = c["a_over_b_p"]
        rows: list[list[float]] = []
        fy: list[list[float]] = []
        for i in range(n):
            xi, yi, vx, vy = xs[i], ys[i], vxs[i], vys[i]
            spi = h[m0 + n * n + i]
            moving, m = spi > 1e-9, max(spi, 1e-9)
            li, oi, ai = lam[i], oml[i], a_over_b_p[i]
            base = i * n
            rx, ry = [], []
            for j in range(n):
                if j == i:  # oneself: at an infinite distance, no force (0.0 * 0.0, as the former code)
                    rx.append(0.0)
                    ry.append(0.0)
                    continue
                dij = h[m0 + base + j]
                norm = dij if dij > 0 else 1.0
                nx, ny = (xi - xs[j]) / norm, (yi - ys[j]) / norm
                mag = ai * e[base + j] if dij < inf and on[j] else 0.0  # (a distance is never -inf)
                cos_phi = -(nx * vx + ny * vy) / m if moving else 1.0
                mw = mag * (li + oi * (1 + cos_phi) / 2)
                rx.append(mw * nx)
                ry.append(mw * ny)
            rows.append(rx)
            fy.append(ry)
        if n < 8:  # numpy's row sum: from 0.0, one after the other
            sums = []
            for r in rows + fy:
                t = 0.0
                for v in r:
                    t += v
                sums.append(t)
        else:
            sums = np.array(rows + fy, dtype=np.float64).sum(axis=1).tolist()  # row by row, as before
        ax = [ax[i] + sums[i] for i in range(n)]
        ay = [ay[i] + sums[n + i] for i in range(n)]
    if seen is not None:
        assert near is not None
        robot_push(ax, ay, near, xs, ys, vxs, vys, seen.pose[0], seen.pose[1], c["a_over_b_r"], e,
                   n * n if n > 1 else 0)
    return ax, ay


_LISTS: dict[int, tuple[dict[str, FloatArray], dict[str, list[float]]]] = {}


def _lists(k: dict[str, FloatArray]) -> dict[str, list[float]]:
    """The constants of :func:`_constants` as lists of floats (the same numbers; once per crowd)."""
    hit = _LISTS.get(id(k))
    if hit is None or hit[0] is not k:
        if len(_LISTS) >= 64:
            _LISTS.clear()
        hit = (k, {name: np.asarray(a, dtype=np.float64).ravel().tolist() for name, a in k.items()})
        _LISTS[id(k)] = hit
    return hit[1]


def constants_of(params: Sequence[SocialForceParams]) -> dict[str, FloatArray]:
    """The per-worker constants of ``params`` as read-only arrays (for :func:`accelerations`)."""
    return _constants(tuple(params))


def cap_speed(vel: FloatArray, v0: FloatArray, params: Sequence[SocialForceParams], *,
              vmax: FloatArray | None = None) -> FloatArray:
    """Velocities limited to ``max_speed_factor`` times each worker's walking speed (``vmax``: that
    product, when the caller keeps it)."""
    if vmax is None:
        vmax = v0 * _constants(tuple(params))["vmax_factor"]
    sp = np.hypot(vel[:, 0], vel[:, 1])
    f = np.where(sp > vmax, vmax / np.maximum(sp, 1e-12), 1.0)
    return np.asarray(vel * f[:, None], dtype=np.float64)
