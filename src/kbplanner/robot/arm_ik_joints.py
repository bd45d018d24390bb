"""Joint angles of the closed-form arm IK (B4 arm poses per skill, :mod:`kbplanner.robot.arm_analytic_ik`),
moved by whole turns into the joint limits nearest a seed and sorted by their distance to it (moved out of
that module in session 14, b4first14; it re-exports :func:`wrap_to_limits` and :func:`joint_distance`).

Example:
    >>> round(wrap_to_limits(3.0, -6.3, 6.3, -2.0), 4)
    -3.2832
    >>> placed = place_in_limits((-6.3,) * 6, (6.3,) * 6, [(3.0,) * 6], (-2.0,) * 6)
    >>> placed[0][0] == wrap_to_limits(3.0, -6.3, 6.3, -2.0)
    True
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

TWO_PI = 2.0 * math.pi


def wrap_to_limits(theta: float, lower: float, upper: float, near: float) -> float | None:
    """``theta`` plus whole turns, within ``[lower, upper]`` and nearest ``near``; ``None`` if none fits.

    Example:
        >>> round(wrap_to_limits(3.0, -6.3, 6.3, -2.0), 4)
        -3.2832
        >>> wrap_to_limits(3.0, -1.0, 1.0, 0.0) is None
        True
    """
    eps = 1e-9
    k_lo = math.ceil((lower - eps - theta) / TWO_PI)
    k_hi = math.floor((upper + eps - theta) / TWO_PI)
    if k_hi < k_lo:
        return None
    # the whole-turn shift nearest the seed, clamped into the feasible range of shifts
    k = min(max(round((near - theta) / TWO_PI), k_lo), k_hi)
    return min(max(theta + k * TWO_PI, lower), upper)


def place_in_limits(lower: Sequence[float], upper: Sequence[float], raw: Sequence[tuple[float, ...]],
                    seed: Sequence[float], clip: bool = False) -> list[tuple[float, ...]]:
    """Each candidate moved by whole turns into the limits nearest the seed (as :func:`wrap_to_limits`).

    A candidate with a joint that fits no whole-turn shift is dropped (``clip``: clipped into the
    limits instead); duplicates are dropped.
    """
    if not raw:
        return []
    q = np.asarray(raw, dtype=float)
    lo, hi = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    k_lo = np.ceil((lo - 1e-9 - q) / TWO_PI)
    k_hi = np.floor((hi + 1e-9 - q) / TWO_PI)
    k = np.minimum(np.maximum(np.round((np.asarray(seed, dtype=float) - q) / TWO_PI), k_lo), k_hi)
    placed = np.minimum(np.maximum(q + k * TWO_PI, lo), hi)
    fits = (k_hi >= k_lo).all(axis=1)
    if clip:
        placed = np.where(k_hi >= k_lo, placed, np.minimum(np.maximum(q, lo), hi))
        fits[:] = True
    rows = [tuple(row) for row, ok in zip(placed.tolist(), fits.tolist(), strict=True) if ok]
    return distinct(rows, placed[fits])


def distinct(rows: list[tuple[float, ...]], values: npt.NDArray[np.float64]) -> list[tuple[float, ...]]:
    """``rows`` (``values`` as an n x m array) without those whose angles rounded to 9 decimals are those
    of an earlier row, in order.

    Two rows that differ by more than 2e-9 in some angle have distinct roundings (two values rounded to
    the same multiple of 1e-9 lie within 1e-9 of each other): a row that far from every other row is
    kept without rounding, and only the others are rounded and compared among themselves.
    """
    if len(rows) < 2:
        return list(rows)
    apart = np.abs(values[:, None, :] - values[None, :, :]).max(axis=2) > 2e-9
    np.fill_diagonal(apart, True)
    alone = apart.all(axis=1).tolist()
    out: list[tuple[float, ...]] = []
    seen: set[tuple[float, ...]] = set()
    for sol, lone in zip(rows, alone, strict=True):
        if lone:
            out.append(sol)
            continue
        key = tuple(round(v, 9) for v in sol)
        if key not in seen:
            seen.add(key)
            out.append(sol)
    return out


def nearest_first(seed: Sequence[float]) -> Callable[[tuple[float, ...]], tuple[float, tuple[float, ...]]]:
    """The sort key (:func:`joint_distance` to ``seed``, then the angles), the seed's floats taken once."""
    sf = tuple(float(v) for v in seed)

    def key(q: tuple[float, ...]) -> tuple[float, tuple[float, ...]]:
        return math.sqrt(sum((x - y) ** 2 for x, y in zip(q, sf, strict=True))), q

    return key


def joint_distance(q: Sequence[float], seed: Sequence[float]) -> float:
    """Euclidean distance between two joint vectors (rad)."""
    return math.sqrt(sum((float(x) - float(y)) ** 2 for x, y in zip(q, seed, strict=True)))
