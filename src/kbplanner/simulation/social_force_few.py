"""B5 reactive workers, the social force of a few workers (fewer than eight) on plain floats.

:func:`kbplanner.simulation.social_force.accelerations_of` hands its small crowds here: the same
operations in the same order, element by element, as the array code of
:func:`~kbplanner.simulation.social_force.accelerations`, so the accelerations are bit-identical; what is
left out is work whose result is known: the distance of a worker to themselves (infinite, no force) and,
numpy's ``hypot`` being even in both arguments, the second of the two equal distances of each pair (one
``hypot`` per pair, ``j`` to ``i`` the number of ``i`` to ``j``); when every worker has the same personal
distance and range, the second of each pair's two equal exponentials too. The offsets of the workers
from the robot's footprint rectangles are worked out inline (those of
:func:`~kbplanner.simulation.separation.points_rects_offsets`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.separation import WORKER_RADIUS_M

FloatArray = npt.NDArray[np.float64]
_hypot = np.hypot

_RIGHT = math.radians(-20.0)  # pass on the right (social_force's module docstring)
_COS_R, _SIN_R = math.cos(_RIGHT), math.sin(_RIGHT)

# the robot's x, y, cos and sin of its yaw and per rectangle its constants (centre, cos, sin, half sizes)
Frame = tuple[float, float, float, float, list[tuple[float, float, float, float, float, float]]]


@functools.lru_cache(maxsize=16)
def _pairs(n: int) -> tuple[tuple[tuple[int, int], ...], tuple[int, ...]]:
    """The pairs i < j of ``n`` workers, and per ordered (i, j) (row-major, i != j) its pair's number
    (-1 on the diagonal)."""
    pairs = tuple((i, j) for i in range(n) for j in range(i + 1, n))
    number = {p: k for k, p in enumerate(pairs)}
    of = tuple(-1 if i == j else number[(min(i, j), max(i, j))] for i in range(n) for j in range(n))
    return pairs, of


def same_people_terms(c: dict[str, list[float]]) -> bool:
    """Whether every worker has the same personal distance and range (then a pair's two exponentials
    are one number)."""
    return all(len(set(c[name])) <= 1 for name in ("s_p", "neg_s_p", "neg_b_p"))


def accelerations_few(xs: list[float], ys: list[float], vxs: list[float], vys: list[float],
                      des: Sequence[Sequence[float]], c: dict[str, list[float]], symmetric: bool,
                      frame: Frame | None, pose: tuple[float, float, float] | None,
                      on: list[bool]) -> tuple[list[float], list[float]]:
    """The x and y accelerations of ``n`` < 8 workers (see module docstring): ``c`` the crowd's constants
    as lists, ``symmetric`` :func:`same_people_terms` of them, ``frame`` and ``pose`` those of the robot
    as the workers see it (None: no robot)."""
    n = len(xs)
    tau = c["tau"]
    ax = [(des[i][0] - vxs[i]) / tau[i] for i in range(n)]
    ay = [(des[i][1] - vys[i]) / tau[i] for i in range(n)]
    exs: list[float] = []
    eys: list[float] = []
    if frame is not None:  # the offsets of each worker from each rectangle (rectangle frame)
        x0, y0, cy, sy, consts = frame
        for i in range(n):
            dx, dy = xs[i] - x0, ys[i] - y0
            lx, ly = cy * dx + sy * dy, -sy * dx + cy * dy
            for rcx, rcy, cr, sr, hl, hw in consts:
                qx, qy = lx - rcx, ly - rcy
                ux, uy = cr * qx + sr * qy, -sr * qx + cr * qy
                # ((u > 0) - (u < 0)) * max(abs(u) - half, 0.0), zeros signed as that product signs them
                e = abs(ux) - hl
                exs.append((e if ux > 0 else -e) if e > 0 else (-0.0 if ux < 0 else 0.0))
                e = abs(uy) - hw
                eys.append((e if uy > 0 else -e) if e > 0 else (-0.0 if uy < 0 else 0.0))
    m0 = len(exs)
    pairs, pair_of = _pairs(n)
    npairs = len(pairs)
    if n > 1:  # one hypot call: the offsets' norms, one distance per pair, the speeds
        h = _hypot(np.array(exs + [xs[i] - xs[j] for i, j in pairs] + vxs, dtype=np.float64),
                   np.array(eys + [ys[i] - ys[j] for i, j in pairs] + vys, dtype=np.float64)).tolist()
    elif m0:
        h = _hypot(np.array(exs, dtype=np.float64), np.array(eys, dtype=np.float64)).tolist()
    else:
        h = []
    expo: list[float] = []
    two_r = 2 * WORKER_RADIUS_M
    if n > 1:
        s_p, neg_s_p, neg_b_p = c["s_p"], c["neg_s_p"], c["neg_b_p"]
        if symmetric:  # one exponent per pair (the same number for i to j and j to i)
            si, ni, bi = s_p[0], neg_s_p[0], neg_b_p[0]
            expo = [max(h[m0 + p] - two_r - si, ni) / bi for p in range(npairs)]
        else:  # per ordered pair (row-major, the diagonal left out)
            expo = [max(h[m0 + pair_of[i * n + j]] - two_r - s_p[i], neg_s_p[i]) / neg_b_p[i]
                    for i in range(n) for j in range(n) if j != i]
    near: list[tuple[float, float, float]] = []
    if frame is not None:  # the nearest rectangle of each worker: distance, direction away from it
        x0, y0, cy, sy, consts = frame
        k0 = 0
        for _ in range(n):
            best, bx, by = math.inf, 0.0, 0.0
            for _rcx, _rcy, cr, sr, _hl, _hw in consts:
                d = h[k0]
                if d < best:
                    ex, ey = exs[k0], eys[k0]
                    best = d
                    bx, by = cr * ex - sr * ey, sr * ex + cr * ey
                k0 += 1
            if not best > 0:
                near.append((best, 0.0, 0.0))
            else:
                near.append((best, (cy * bx - sy * by) / best, (sy * bx + cy * by) / best))
        s_c, neg_s_c, neg_b_r = c["s_c"], c["neg_s_c"], c["neg_b_r"]
        expo += [max(near[i][0] - WORKER_RADIUS_M - s_c[i], neg_s_c[i]) / neg_b_r[i] for i in range(n)]
    e_all = np.exp(np.array(expo, dtype=np.float64)).tolist() if expo else []
    off = 0
    if n > 1:
        off = npairs if symmetric else n * (n - 1)
        lam, oml, a_over_b_p = c["lam"], c["one_minus_lam"], c["a_over_b_p"]
        inf = math.inf
        sp0 = m0 + npairs
        for i in range(n):
            xi, yi, vx, vy = xs[i], ys[i], vxs[i], vys[i]
            spi = h[sp0 + i]
            moving, m = spi > 1e-9, max(spi, 1e-9)
            li, oi, ai = lam[i], oml[i], a_over_b_p[i]
            base = i * n
            tx = ty = 0.0  # numpy's row sum: from 0.0, one after the other
            for j in range(n):
                if j == i:  # oneself: at an infinite distance, no force (0.0 * 0.0, as the former code)
                    tx += 0.0
                    ty += 0.0
                    continue
                p = pair_of[base + j]
                dij = h[m0 + p]
                norm = dij if dij > 0 else 1.0
                nx, ny = (xi - xs[j]) / norm, (yi - ys[j]) / norm
                if dij < inf and on[j]:  # (a distance is never -inf)
                    mag = ai * e_all[p if symmetric else base - i + (j if j < i else j - 1)]
                else:
                    mag = 0.0
                cos_phi = -(nx * vx + ny * vy) / m if moving else 1.0
                mw = mag * (li + oi * (1 + cos_phi) / 2)
                tx += mw * nx
                ty += mw * ny
            ax[i] += tx
            ay[i] += ty
    if pose is not None:
        robot_push(ax, ay, near, xs, ys, vxs, vys, pose[0], pose[1], c["a_over_b_r"], e_all, off)
    return ax, ay


def robot_push(ax: list[float], ay: list[float], near: Sequence[tuple[float, float, float]],
               xs: Sequence[float], ys: Sequence[float], vxs: Sequence[float], vys: Sequence[float],
               px: float, py: float, a_over_b_r: Sequence[float], e: Sequence[float], off: int) -> None:
    """Adds the robot's repulsion to each worker's acceleration (``ax``, ``ay`` in place): along the
    unit vector from the footprint's nearest point ``near[i]`` (from the robot's centre ``px, py`` when
    inside it), of magnitude ``a_over_b_r[i] * e[off + i]``, turned to the right when the worker walks
    towards the robot. Shared by the few-worker and the array forms."""
    for i in range(len(ax)):
        _, ux, uy = near[i]
        if ux == 0 and uy == 0:  # inside the footprint: away from the robot's centre
            cx, cy = xs[i] - px, ys[i] - py
            cn = max(float(_hypot(cx, cy)), 1e-9)
            ux, uy = cx / cn, cy / cn
        mag = a_over_b_r[i] * e[off + i]
        if -(ux * vxs[i] + uy * vys[i]) > 0:
            ax[i] += mag * (_COS_R * ux - _SIN_R * uy)
            ay[i] += mag * (_SIN_R * ux + _COS_R * uy)
        else:
            ax[i] += mag * ux
            ay[i] += mag * uy
