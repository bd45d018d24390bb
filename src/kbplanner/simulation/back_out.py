"""Navigation (B5), a path's backward start or end made short: back out straight, turn, drive forwards.

A loaded base that stands facing the storage stack at its pickup cannot turn on the spot there; the
planner's SE(2) path backs it out diagonally (and :func:`~kbplanner.simulation.turn_around.turned_round`
turns it round only where a whole turn is free, often metres away), into the laser scanner's blind sector
behind it. :func:`backed_out` instead backs the base out straight along its yaw, ``STEP_M`` at a time,
only until it can turn to face a later waypoint of the path and drive there forwards (the farthest such
waypoint at the first distance where there is one); :func:`backed_in` does the same at the goal (it drives
forwards to a pose in front of the goal, turns there and backs in straight), as :func:`backed_out` of the
path reversed with the yaws turned round. Every motion checked exactly in the leg's configuration space
(:class:`~kbplanner.simulation.motion_check.ExactMotion`); no random numbers.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

from kbplanner.core.errors import KbplannerError
from kbplanner.simulation.motion_check import ExactMotion, backward_m
from kbplanner.simulation.nav_path import Pose2D, wrap
from kbplanner.world.footprint import ConfigurationSpace

STEP_M = 0.1  # spacing of the poses tried behind the start
MAX_BACK_M = 3.0  # no farther back than this
KEEP = 3  # rewrites kept per end, the quickest by the estimate
STOP_S = 1.0  # a turn on the spot: speeding up and slowing down its turn and the drives round it, roughly


def reversing_cost(value: object) -> float:
    """The navigation skill's ``kbp:reversingCost`` (seconds of drive time a metre less driven backwards is
    worth; ontology/kb/skills.ttl), checked: none is 0 (no rewrite); a number that is not finite and >= 0 is
    bad input."""
    if value is None:
        return 0.0
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)) \
            or float(value) < 0:
        raise KbplannerError(f"the navigation skill parameter kbp:reversingCost is {value!r}",
                             element="kbp:reversingCost",
                             fix="give a finite number of seconds per metre >= 0 (0: off) as its "
                                 "kbp:defaultValue in the knowledge base")
    return float(value)


def estimate_s(poses: Sequence[Pose2D], speed_mps: float, yaw_rate_rps: float,
               reverse_s_per_m: float) -> float:
    """A rough drive time of a path (each straight SE(2) motion at top speed or yaw rate, whichever takes
    longer, and ``STOP_S`` per turn on the spot) plus ``reverse_s_per_m`` (the skill's ``kbp:reversingCost``)
    per metre driven backwards or slid sideways: the cost by which rewrites of one path are compared."""
    s = 0.0
    for a, b in itertools.pairwise(poses):
        d = math.hypot(b[0] - a[0], b[1] - a[1])
        turn = abs(wrap(b[2] - a[2]))
        s += max(d / speed_mps, turn / yaw_rate_rps)
        if d <= 1e-9:
            s += STOP_S if turn > 1e-9 else 0.0
            continue
        way = math.atan2(b[1] - a[1], b[0] - a[0])
        off = max(abs(wrap(way - a[2])), abs(wrap(way - b[2])))
        if off > math.radians(60.0):
            s += reverse_s_per_m * (backward_m([a, b]) if off > math.pi / 2 else d)
    return s


def _turn_span(exact: ExactMotion, p: Pose2D) -> tuple[float, float]:
    """How far the base at ``p`` can turn on the spot: counter-clockwise and clockwise (radians, up to a
    whole turn), from its yaw bins free at its cell (a turn on the spot is free exactly where every bin
    it passes is)."""
    w = exact.w
    spans = []
    for sign in (1, -1):
        k = 1
        edge = (math.floor(p[2] / w + 0.5) + sign * 0.5) * w  # the border of the bin it stands in
        while k <= exact.n_bins and exact.pose_free(p[0], p[1], edge + sign * (k - 0.5) * w):
            k += 1
        spans.append(min(2 * math.pi, abs(edge - p[2]) + (k - 1) * w) - 1e-6)
    return spans[0], spans[1]


def _turn_free(exact: ExactMotion, p: Pose2D, yaw: float, span: tuple[float, float]) -> list[Pose2D] | None:
    """The poses of a free turn on the spot at ``p`` to ``yaw`` within ``span`` (:func:`_turn_span`: the
    short way first, else the long way round, in quarter-turn-or-less motions), None where both are
    blocked."""
    d = wrap(yaw - p[2])
    if abs(d) < 1e-9:
        return [p]
    for way in (d, d - math.copysign(2 * math.pi, d)):
        if (way > span[0]) if way > 0 else (-way > span[1]):
            continue
        n = max(1, math.ceil(abs(way) / (math.pi / 2)))
        seq = [(p[0], p[1], wrap(p[2] + k / n * way)) for k in range(n + 1)]
        if exact.path_free(seq):
            return seq
    return None


def backed_out(cs: ConfigurationSpace, poses: Sequence[Pose2D], speed_mps: float, yaw_rate_rps: float,
               limit_m: float = MAX_BACK_M, *, reverse_s_per_m: float) -> list[list[Pose2D]]:
    """``poses`` with the start rewritten (module doc): straight back from the start by a multiple of
    ``STEP_M`` (0 included, less than ``limit_m``, at most ``MAX_BACK_M``) to a pose from which a turn on
    the spot to face a later waypoint (the farthest) and the straight drive to it are free; the path goes
    on from there as planned. Up to ``KEEP`` of them (one per distance back), least :func:`estimate_s`
    first; none where the path is too short or none is found."""
    if len(poses) < 3:
        return []
    exact = ExactMotion(cs)
    x0, y0, t0 = poses[0]
    c, s = math.cos(t0), math.sin(t0)
    limit = min(limit_m, MAX_BACK_M + 1e-9)
    n = len(poses)
    r = 0.0
    prev: Pose2D = poses[0]
    found: list[tuple[float, float, list[Pose2D]]] = []
    while r < limit - 1e-9:
        m = (x0 - r * c, y0 - r * s, t0)
        if r > 0 and not exact.motion_free(prev, m):
            break
        prev = m
        span = _turn_span(exact, m)
        for j in range(n - 1, 0, -1):
            q = poses[j]
            if math.hypot(q[0] - m[0], q[1] - m[1]) <= 1e-6:
                continue
            way = math.atan2(q[1] - m[1], q[0] - m[0])
            turn = _turn_free(exact, m, way, span)
            if turn is None or not exact.motion_free(turn[-1], (q[0], q[1], way)):
                continue
            head = [poses[0], m] if r > 0 else [poses[0]]
            out = [*head, *turn[1:], (q[0], q[1], way), *poses[j:]]
            out = [p for k, p in enumerate(out) if k == 0 or p != out[k - 1]]
            found.append((estimate_s(out, speed_mps, yaw_rate_rps, reverse_s_per_m), r, out))
            break
        r = round(r + STEP_M, 9)
    found.sort(key=lambda f: (round(f[0], 9), f[1]))
    return [f[2] for f in found[:KEEP]]


def _reversed(poses: Sequence[Pose2D]) -> list[Pose2D]:
    """The path driven the other way, the base turned round: forwards stays forwards."""
    return [(p[0], p[1], wrap(p[2] + math.pi)) for p in reversed(poses)]


def backed_in(cs: ConfigurationSpace, poses: Sequence[Pose2D], speed_mps: float, yaw_rate_rps: float,
              limit_m: float = MAX_BACK_M, *, reverse_s_per_m: float) -> list[list[Pose2D]]:
    """``poses`` with the end rewritten as :func:`backed_out` rewrites the start (module doc)."""
    return [_reversed(p) for p in backed_out(cs, _reversed(poses), speed_mps, yaw_rate_rps, limit_m,
                                             reverse_s_per_m=reverse_s_per_m)]
