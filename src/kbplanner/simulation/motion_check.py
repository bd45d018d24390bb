"""Navigation (B5), exact motion checks in a configuration space, and the path rewrites that rely on
them: greedy string pulling and the skid-steer turn-drive-turn.

Takes a :class:`~kbplanner.world.footprint.ConfigurationSpace` (one free map per yaw bin) and SE(2)
poses; :class:`ExactMotion` answers whether a straight SE(2) motion is free (cut at yaw-bin borders,
every cell of the centre's supercover checked; a short motion whose cells are all free in every yaw bin
is accepted at once, from a clearance table, and a long one is refuted by samples tried middle first),
which the OMPL query uses as its motion validator
(:mod:`kbplanner.simulation.navigation`) and the cell path as its check
(:mod:`kbplanner.simulation.cell_path`). :func:`turn_drive_turn` rewrites a path for a skid-steer base.
"""

from __future__ import annotations

import itertools
import math
import weakref
from collections.abc import Sequence

import numpy as np

from kbplanner.simulation.nav_path import Pose2D, densify, path_length, wrap
from kbplanner.world.footprint import ConfigurationSpace

_PI = math.pi
_TAU = 2 * math.pi
_PROBES: dict[int, tuple[float, ...]] = {}  # n -> the sample fractions of :func:`probe_fractions`
# Per configuration space with read-only free maps (those of the space cache): :func:`open_clearance`, made
# once for all the ExactMotion objects of a space (planner, dense re-check, turn-drive-turn, rounded corners).
_CLEARANCE: weakref.WeakKeyDictionary[ConfigurationSpace, bytes] = weakref.WeakKeyDictionary()


def open_clearance(cs: ConfigurationSpace) -> bytes:
    """Per cell (row-major, ``iy * nx + ix``), the chessboard distance in cells to the nearest cell that is
    blocked in some yaw bin or off the grid, capped at 255: every cell nearer than that is free in every
    yaw bin. A motion whose cells all lie within that distance of its start cell is free whatever its
    turn (the quick accept of :meth:`ExactMotion.free6`)."""
    from scipy import ndimage  # imported here: the module is imported by commands that never plan

    open_all = np.pad(cs.free.all(axis=0), 1, constant_values=False)
    dist = ndimage.distance_transform_cdt(open_all, metric="chessboard")[1:-1, 1:-1]
    return np.minimum(dist, 255).astype(np.uint8).tobytes()


def free_bytes(cs: ConfigurationSpace) -> bytes | memoryview:
    """The free maps as one byte per cell (``bin * ny * nx + iy * nx + ix``): read-only maps in one block
    (those of the space cache) are read in place, others copied (a copy cannot change under a check)."""
    free = cs.free
    if not free.flags.writeable and free.flags.c_contiguous:
        return free.data.cast("B")
    return free.tobytes()


def _clearance(cs: ConfigurationSpace) -> bytes:
    """:func:`open_clearance`, kept per space whose free maps are read-only (made anew where they may
    still change)."""
    got = _CLEARANCE.get(cs)
    if got is None:
        got = open_clearance(cs)
        if not cs.free.flags.writeable:
            _CLEARANCE[cs] = got
    return got


def probe_fractions(n: int) -> tuple[float, ...]:
    """The fractions u = i / n, i = 1 ... n, of a motion's quick samples, in the order they are tried.

    First the middle (n // 2) and the end (n), then the middles of the halves, of the quarters, and so on
    (breadth first): a motion that runs into a wall is mostly refuted within a few samples wherever the
    wall is (trying them from the start took three times as many samples on the case study). The order
    decides only how soon a blocked sample is met, not the answer. Memoised per ``n``.
    """
    got = _PROBES.get(n)
    if got is None:
        order = [n // 2, n]
        spans = [(0, n // 2), (n // 2, n)]
        while spans:
            halves: list[tuple[int, int]] = []
            for lo, hi in spans:
                if hi - lo > 1:
                    mid = (lo + hi) // 2
                    order.append(mid)
                    halves += ((lo, mid), (mid, hi))
            spans = halves
        got = _PROBES[n] = tuple(i / n for i in order)
    return got


class ExactMotion:
    """Exact motion checks in a configuration space for SE(2) straight-line motions.

    A motion (x, y, yaw linear, yaw the short way round) is cut where the yaw crosses a bin border;
    within each piece the bin is fixed and the centre moves along a straight segment, so the piece
    is free exactly when every cell that segment touches (its supercover) is free in that bin.
    Sampled checks can miss a cell that a segment only clips at a corner; this cannot.
    """

    def __init__(self, cs: ConfigurationSpace) -> None:
        self.free = free_bytes(cs)
        self.clearance = _clearance(cs)
        self.ny, self.nx = cs.grid.shape
        self.ox, self.oy = cs.grid.origin
        self.inv_res = 1.0 / cs.grid.resolution
        self.n_bins = cs.n_bins
        self.w = cs.bin_width
        self.plane = self.ny * self.nx
        self._consts = (self.inv_res, self.ox, self.oy, self.nx, self.ny, self.w, self.n_bins, self.plane,
                        self.free, self.clearance)

    def pose_free(self, x: float, y: float, yaw: float) -> bool:
        ix = math.floor((x - self.ox) * self.inv_res)
        iy = math.floor((y - self.oy) * self.inv_res)
        if not (0 <= ix < self.nx and 0 <= iy < self.ny):
            return False
        k = math.floor(yaw / self.w + 0.5) % self.n_bins
        return self.free[k * self.plane + iy * self.nx + ix] == 1

    def _segment_free(self, k: int, x0: float, y0: float, x1: float, y1: float) -> bool:
        """Every cell the segment touches is free in bin ``k`` (cell units)."""
        if x0 > x1:
            x0, y0, x1, y1 = x1, y1, x0, y0
        nx, ny = self.nx, self.ny
        base = k * self.plane
        ixa, ixb = math.floor(x0), math.floor(x1)
        if ixa < 0 or ixb >= nx:
            return False
        slope = (y1 - y0) / (x1 - x0) if x1 > x0 else 0.0
        for ix in range(ixa, ixb + 1):
            if x1 > x0:
                ya = y0 + (max(x0, ix) - x0) * slope
                yb = y0 + (min(x1, ix + 1) - x0) * slope
            else:
                ya, yb = y0, y1
            lo, hi = math.floor(min(ya, yb)), math.floor(max(ya, yb))
            if lo < 0 or hi >= ny:
                return False
            if 0 in self.free[base + lo * nx + ix : base + hi * nx + ix + 1 : nx]:
                return False
        return True

    def motion_free(self, a: Sequence[float], b: Sequence[float]) -> bool:
        """Whether the straight SE(2) motion from ``a`` to ``b`` is free (both ends included)."""
        return self.free6(a[0], a[1], a[2], b[0], b[1], b[2])

    def free6(self, a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> bool:
        """:meth:`motion_free` of ``(a0, a1, a2)`` to ``(b0, b1, b2)``, the six numbers passed one by one
        (the OMPL motion validator's call, without building tuples)."""
        inv_res, ox, oy, nx, ny, w, n_bins, plane, free, clearance = self._consts
        floor = math.floor
        t0 = float(a2)
        d = (float(b2) - t0 + _PI) % _TAU - _PI  # nav_path.wrap inlined
        # Cheap rejection first: most motions a planner tries run into a wall somewhere, most of them
        # half-way. (pose_free inlined: the same arithmetic, without a method call per sample.) The
        # samples are u = i / n for i = 1 ... n, in the order of probe_fractions.
        bx, by = b0 - a0, b1 - a1
        n = max(2, math.ceil(max(abs(bx), abs(by)) * inv_res / 2))
        probes = _PROBES.get(n) or probe_fractions(n)
        for u in probes:
            ix = floor((a0 + u * bx - ox) * inv_res)
            iy = floor((a1 + u * by - oy) * inv_res)
            if not (0 <= ix < nx and 0 <= iy < ny):
                return False
            if free[(floor((t0 + u * d) / w + 0.5) % n_bins) * plane + iy * nx + ix] != 1:
                return False
        # Quick accept: every cell that the exact check below looks at lies within one cell of the box of
        # the end cells (rounding moves a coordinate across at most one cell border), so within
        # max(|jx|, |jy|) + 1 of the start cell; if all cells that near are free in every yaw bin (and on
        # the grid), every piece passes.
        ax, ay = (a0 - ox) * inv_res, (a1 - oy) * inv_res
        ix, iy = floor(ax), floor(ay)
        if 0 <= ix < nx and 0 <= iy < ny:
            r = clearance[iy * nx + ix]
            if r > 2:
                jx, jy = floor((b0 - ox) * inv_res) - ix, floor((b1 - oy) * inv_res) - iy
                if (jx if jx > 0 else -jx) + 2 < r and (jy if jy > 0 else -jy) + 2 < r:
                    return True
        # The exact check, piece by piece between yaw-bin borders: :meth:`_segment_free` inlined (the
        # same arithmetic; a one-cell column is read directly rather than sliced).
        cuts = [0.0]
        if d != 0.0:
            k0 = floor(t0 / w + 0.5)
            k1 = floor((t0 + d) / w + 0.5)
            borders = range(k0, k1) if d > 0 else range(k0 - 1, k1 - 1, -1)
            cuts += [((k + 0.5) * w - t0) / d for k in borders]
        cuts.append(1.0)
        dx, dy = (b0 - ox) * inv_res - ax, (b1 - oy) * inv_res - ay
        ua = 0.0
        for ub in cuts[1:]:
            base = (floor((t0 + 0.5 * (ua + ub) * d) / w + 0.5) % n_bins) * plane
            x0, y0, x1, y1 = ax + ua * dx, ay + ua * dy, ax + ub * dx, ay + ub * dy
            ua = ub
            if x0 > x1:
                x0, y0, x1, y1 = x1, y1, x0, y0
            ixa, ixb = floor(x0), floor(x1)
            if ixa < 0 or ixb >= nx:
                return False
            if x1 > x0:
                slope = (y1 - y0) / (x1 - x0)
                for ix in range(ixa, ixb + 1):
                    ya = y0 + ((ix if ix > x0 else x0) - x0) * slope
                    yb = y0 + ((ix + 1 if ix + 1 < x1 else x1) - x0) * slope
                    if ya > yb:
                        ya, yb = yb, ya
                    lo, hi = floor(ya), floor(yb)
                    if lo < 0 or hi >= ny:
                        return False
                    if lo == hi:
                        if free[base + lo * nx + ix] != 1:
                            return False
                    elif 0 in free[base + lo * nx + ix : base + hi * nx + ix + 1 : nx]:
                        return False
            else:
                lo, hi = (floor(y0), floor(y1)) if y0 <= y1 else (floor(y1), floor(y0))
                if lo < 0 or hi >= ny:
                    return False
                for ix in range(ixa, ixb + 1):
                    if 0 in free[base + lo * nx + ix : base + hi * nx + ix + 1 : nx]:
                        return False
        return True

    def path_free(self, poses: Sequence[Sequence[float]]) -> bool:
        """Whether every motion between consecutive poses is free."""
        if len(poses) == 1:
            return self.pose_free(*poses[0][:3])
        return all(self.motion_free(p, q) for p, q in itertools.pairwise(poses))


def shortcut(motion: ExactMotion, poses: Sequence[Pose2D], step_m: float) -> list[Pose2D]:
    """Greedy string pulling: from each kept pose, jump to the farthest free pose of the densified path."""
    dense = densify(poses, step_m, math.pi)
    out = [dense[0]]
    i, n = 0, len(dense)
    while i < n - 1:
        j = n - 1
        while j > i + 1 and not motion.motion_free(dense[i], dense[j]):
            j -= 1
        out.append(dense[j])
        i = j
    return out if path_length(out) <= path_length(poses) else list(poses)


def path_is_free(cs: ConfigurationSpace, poses: Sequence[Sequence[float]]) -> bool:
    """Exact check of a path (straight SE(2) motions between waypoints) in a configuration space."""
    return ExactMotion(cs).path_free(poses)


def backward_m(poses: Sequence[Pose2D]) -> float:
    """How far the straight SE(2) motions between ``poses`` travel backwards: the direction of travel
    more than 90 degrees off the yaw (the yaw linear along each motion, 16 samples; as
    ``benchmarks/reverse_driving.py`` counts it on a trajectory)."""
    back = 0.0
    for p, q in itertools.pairwise(poses):
        dx, dy = q[0] - p[0], q[1] - p[1]
        d = math.hypot(dx, dy)
        if d <= 1e-9:
            continue
        turn = wrap(q[2] - p[2])
        for k in range(16):
            yaw = p[2] + (k + 0.5) / 16 * turn
            if dx * math.cos(yaw) + dy * math.sin(yaw) < -0.01 * d:
                back += d / 16
    return back


def turn_drive_turn(
    cs: ConfigurationSpace,
    poses: Sequence[Pose2D],
    *,
    allow_reverse: bool = True,
    trace: list[tuple[str, float]] | None = None,
) -> tuple[list[Pose2D], int]:
    """Rewrite an SE(2) path for a skid-steer base: turn in place, drive straight, turn at the goal.

    Each segment becomes a rotation on the spot to face along it (or away from it, driving backwards,
    when that turns less and ``allow_reverse``) and a straight drive; the goal yaw is reached by a
    final turn. Where such a turn is blocked (next to a door jamb, say), the shortest leading part of
    the segment (1/8, 1/4, ... of it) is driven as in SE(2), turning while moving, and the rest turn-
    drive-turn. Every motion is checked densely. Returns the waypoints and how many segments needed
    such an SE(2) part; if one cannot be rejoined at all, the SE(2) path itself is returned.

    ``trace``, where given, gets one ``(how, backward_m)`` per segment: how it was rewritten ("tdt",
    "mixed u=...", "se2 segment", "se2 path") and how far its motions travel backwards (direction of
    travel over 90 degrees off the yaw, :func:`backward_m`); for measuring only, the result is the same.
    """
    if len(poses) < 2:
        return list(poses), 0
    exact = ExactMotion(cs)

    def free(seq: Sequence[Pose2D]) -> bool:
        return exact.path_free(seq)

    def tdt(frm: Pose2D, b: Pose2D, last: bool) -> list[Pose2D]:
        x, y, cur = frm
        moves: list[Pose2D] = []
        if math.hypot(b[0] - x, b[1] - y) > 1e-9:
            heading = math.atan2(b[1] - y, b[0] - x)
            back = wrap(heading + math.pi)
            if allow_reverse and abs(wrap(back - cur)) < abs(wrap(heading - cur)):
                heading = back
            moves = [(x, y, heading), (b[0], b[1], heading)]
        if last:
            moves.append(b)
        return [m for i, m in enumerate(moves) if m != ([frm, *moves][i])]

    out: list[Pose2D] = [poses[0]]
    mixed = 0
    n = len(poses) - 1
    for i, (a, b) in enumerate(itertools.pairwise(poses)):
        last = i == n - 1
        moves = tdt(out[-1], b, last)
        if free([out[-1], *moves]):
            if trace is not None:
                trace.append(("tdt", backward_m([out[-1], *moves])))
            out.extend(moves)
            continue
        for u in (0.125, 0.25, 0.5, 0.75, 1.0):
            m = (a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]), wrap(a[2] + u * wrap(b[2] - a[2])))
            rest = tdt(m, b, last) if u < 1.0 else []
            if free([out[-1], m]) and free([m, *rest]):
                if trace is not None:
                    trace.append((f"mixed u={u:g}", backward_m([out[-1], m, *rest])))
                out.append(m)
                out.extend(rest)
                mixed += 1
                break
        else:
            if not (free([out[-1], a]) and free([a, b])):
                if trace is not None:
                    trace.append(("se2 path", backward_m(poses)))
                return list(poses), n
            if trace is not None:
                trace.append(("se2 segment", backward_m([out[-1], a, b])))
            out.extend(p for p in (a, b) if p != out[-1])
            mixed += 1
    return out, mixed
