"""Closed-form arm inverse kinematics (B4 arm poses per skill) for 6R arms of the UR structure.

Pipeline step: B4 (:mod:`kbplanner.planning.manipulation` via :func:`kbplanner.robot.arm_ik.solve_ik`)
asks for
joint angles that put the tool at a pose. For arms whose standard Denavit-Hartenberg table has the
structure of the Universal Robots arms this module answers in closed form, in numpy, instead of
PyBullet's iterative solver; other arms keep the numeric solver.

How it works: :class:`DhArm` holds a DH table (``d``, ``a``, ``alpha``, joint limits);
:func:`ur_structure` tests the *parameters* (not names): joints 2, 3 and 4 parallel
(``alpha[1] = alpha[2] = 0``), joints 1, 4 and 5 turned by a quarter turn (``alpha[0]``,
``alpha[3]``, ``alpha[4]`` = +-pi/2), ``a[4] = 0``, and upper arm and forearm of non-zero length.
Then (Hawkins 2013, derived here for either sign of each quarter turn, with ``a[0]``, ``a[3]``,
``d[1]``, ``d[2]``, ``a[5]`` and ``alpha[5]`` of any value):

1. ``q1``: the origin of frame 5 (flange minus ``d6`` along the tool axis) lies ``d2 + d3 + d4``
   along joint 2's axis, which is horizontal and set by ``q1`` alone: two solutions (shoulder
   left/right); none when the target is inside the cylinder of that radius (shoulder singularity:
   the two merge on its surface).
2. ``q5``: the tool axis against joint 2's axis gives ``cos q5``: two solutions (wrist up/down).
3. ``q6``: joint 2's axis seen from the flange; when ``sin q5 = 0`` (wrist singularity: joints 4
   and 6 aligned) ``q6`` is free and taken from the seed, and ``q4`` takes up the rest.
4. ``q2, q3, q4``: a planar two-link problem for the origin of frame 3 in frame 1 (elbow up/down),
   and ``q4`` from the summed angle of joints 2-4.

Up to 8 solutions; each is checked by :func:`forward_kinematics`, every angle is moved by whole
turns to the value nearest the seed that lies within the joint limits (a solution that cannot be
is dropped). :func:`ik_best_effort` gives, for an unreachable pose, the arm stretched towards it
(arguments clamped), so callers can report how far off the pose is. :func:`near_reach` searches,
for a pose just out of reach, a pose within given tolerances of it that the closed form solves: it
moves the pose (the tool point, and the tool turned about it) so that the start of the wrist (DH
frame 4) moves by the gap between where the pose puts it and where the stretched arm has it, a
few steps, clipped to the tolerances. No exceptions on singular poses; everything is deterministic.

Reference: K. P. Hawkins, "Analytic Inverse Kinematics for the Universal Robots UR-5/UR-10 Arms",
Georgia Institute of Technology, 2013 (the ``ur_kinematics`` package implements the same).

Example:
    >>> import math
    >>> ur5 = DhArm((0.089159, 0, 0, 0.10915, 0.09465, 0.0823), (0, -0.425, -0.39225, 0, 0, 0),
    ...             (math.pi / 2, 0, 0, math.pi / 2, -math.pi / 2, 0))
    >>> ur_structure(ur5) is not None
    True
    >>> q = (0.3, -1.2, 1.4, -1.7, -1.5, 0.2)
    >>> sols = ik_solutions(ur5, forward_kinematics(ur5, q), seed=q)
    >>> len(sols), max(abs(x - y) for x, y in zip(sols[0], q)) < 1e-9
    (8, True)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kbplanner.robot.arm_ik_joints import distinct, nearest_first, place_in_limits
from kbplanner.robot.arm_ik_joints import joint_distance as joint_distance
from kbplanner.robot.arm_ik_joints import wrap_to_limits as wrap_to_limits
from kbplanner.robot.arm_ik_matrices import cross3, dh_chain_many, dh_matrix, dh_stack, rigid_inverse_many
from kbplanner.robot.arm_ik_matrices import rigid_inverse as _inv

Matrix = npt.NDArray[np.float64]

TWO_PI = 2.0 * math.pi
_PARAM_TOL = 1e-6  # how close a DH parameter must be to 0 or pi/2 to count as such
_SINGULAR = 1e-9  # |sin q5| below this: wrist singular
_FK_TOL_M = 1e-6  # a closed-form solution must reproduce the pose this closely (m, and rad-ish)
# near_reach: the share of the tolerances a moved pose may use, its steps, and when it gives up
NEAR_SHARE = 0.97
NEAR_ROUNDS = 3
NEAR_GIVE_UP = 2.0
# (more branches find more poses -- 105 instead of 87 of B4's 852 near misses on the case study, storage-
# outside -- but cost more than they save: benchmarks/ik_polish_study.py, docs/scale.md, Session 10)
NEAR_BRANCHES = 1


@dataclass(frozen=True)
class DhArm:
    """A 6R arm by standard DH parameters (``T = prod Rz(q) Tz(d) Tx(a) Rx(alpha)``) and joint limits."""

    d: tuple[float, ...]
    a: tuple[float, ...]
    alpha: tuple[float, ...]
    lower: tuple[float, ...] = (-TWO_PI,) * 6
    upper: tuple[float, ...] = (TWO_PI,) * 6


@dataclass(frozen=True)
class UrStructure:
    """The signs and lengths the closed form needs (see the module docstring)."""

    s1: float  # sin alpha[0]
    s4: float  # sin alpha[3]
    s5: float  # sin alpha[4]
    shoulder_m: float  # d2 + d3 + d4: frame 5's offset along joint 2's axis
    a2: float
    a3: float


def _near(value: float, target: float) -> bool:
    """``value`` equals ``target`` up to whole turns, within the parameter tolerance."""
    diff = (value - target + math.pi) % TWO_PI - math.pi
    return abs(diff) < _PARAM_TOL


@functools.lru_cache(maxsize=64)
def ur_structure(arm: DhArm) -> UrStructure | None:
    """The UR structure of a DH table, or ``None`` if the closed form does not apply (memoised per table).

    Example:
        >>> ur_structure(DhArm((0.3,) * 6, (0.2,) * 6, (0.0,) * 6)) is None
        True
    """
    if len(arm.d) != 6 or len(arm.a) != 6 or len(arm.alpha) != 6:
        return None
    if not (_near(arm.alpha[1], 0.0) and _near(arm.alpha[2], 0.0)):
        return None
    signs = []
    for k in (0, 3, 4):
        if _near(arm.alpha[k], math.pi / 2):
            signs.append(1.0)
        elif _near(arm.alpha[k], -math.pi / 2):
            signs.append(-1.0)
        else:
            return None
    if abs(arm.a[4]) > _PARAM_TOL or abs(arm.a[1]) < _PARAM_TOL or abs(arm.a[2]) < _PARAM_TOL:
        return None
    return UrStructure(signs[0], signs[1], signs[2], arm.d[1] + arm.d[2] + arm.d[3], arm.a[1], arm.a[2])


def forward_kinematics(arm: DhArm, q: Sequence[float]) -> Matrix:
    """DH frame 6 (the flange) in DH frame 0 (the arm base) for joint angles ``q``."""
    t = np.eye(4)
    for i in range(6):
        t = t @ dh_matrix(float(q[i]), arm.d[i], arm.a[i], arm.alpha[i])
    return t


def forward_kinematics_many(arm: DhArm, qs: Sequence[Sequence[float]]) -> npt.NDArray[np.float64]:
    """:func:`forward_kinematics` of each of ``qs`` (n x 4 x 4), the same floats in six stacked products."""
    return dh_chain_many(arm.d, arm.a, arm.alpha, qs)


@functools.lru_cache(maxsize=64)
def _flange_strip(arm: DhArm) -> Matrix:
    """``inv(Tx(a6) Rx(alpha6))``, constant per arm (memoised, read-only)."""
    out = _inv(dh_matrix(0.0, 0.0, arm.a[5], arm.alpha[5]))
    out.setflags(write=False)
    return out


def pose_error(a: Matrix, b: Matrix) -> tuple[float, float]:
    """(position distance in m, rotation angle in rad) between two poses."""
    pos = float(np.linalg.norm(a[:3, 3] - b[:3, 3]))
    c = (float(np.trace(a[:3, :3].T @ b[:3, :3])) - 1.0) / 2.0
    return pos, math.acos(max(-1.0, min(1.0, c)))


def _raw_solutions(arm: DhArm, ur: UrStructure, target: Matrix, seed: Sequence[float],
                   clamp: bool) -> list[tuple[float, ...]]:
    """Closed-form candidates (angles in (-pi, pi]); ``clamp`` stretches towards unreachable poses.

    Both kinds come from one pass (:func:`_raw_both`), kept for the last pose asked: a query out of
    reach asks the closed form and then the stretched arm of the same pose."""
    key = (arm, target.tobytes(), tuple(float(v) for v in seed))
    if _LAST_RAW and _LAST_RAW[0][0] == key:
        both = _LAST_RAW[0][1]
    else:
        both = _raw_both(arm, ur, target, seed)
        _LAST_RAW[:] = [(key, both)]
    stretched, exact, reachable = both
    if clamp:
        return list(stretched)
    return [q for q, ok in zip(stretched, exact, strict=True) if ok] if reachable else []


#: the last :func:`_raw_both` asked: ((arm, target's bytes, seed), its answer)
_LAST_RAW: list[tuple[tuple[DhArm, bytes, tuple[float, ...]],
                      tuple[list[tuple[float, ...]], list[bool], bool]]] = []


def _raw_both(arm: DhArm, ur: UrStructure, target: Matrix, seed: Sequence[float]
              ) -> tuple[list[tuple[float, ...]], list[bool], bool]:
    """The clamped candidates (``clamp=True``), whether each is also one of the unclamped ones, and whether
    the unclamped form has any: the unclamped candidates are the clamped ones whose elbow was not clamped
    (by more than 1e-9), the very same floats, unless the pose is off the shoulder's reach."""
    d1, d5, d6 = arm.d[0], arm.d[4], arm.d[5]
    # strip the constant Tx(a6) Rx(alpha6) so that the flange is Rz(q6) Tz(d6) from frame 5
    t06 = target @ _flange_strip(arm)
    z6 = t06[:3, 2]
    p5 = t06[:3, 3] - d6 * z6
    r = math.hypot(p5[0], p5[1])
    big_d = ur.shoulder_m
    # q1: s1 * (p5x sin q1 - p5y cos q1) = D, i.e. r sin(q1 - phi) = s1 D
    reachable = True
    if r < 1e-12:
        if abs(big_d) > 1e-12:
            reachable = False
        q1s = [float(seed[0])]  # on the shoulder axis: q1 is free
    else:
        ratio = ur.s1 * big_d / r
        if abs(ratio) > 1.0:
            if abs(ratio) > 1.0 + 1e-12:
                reachable = False
            ratio = max(-1.0, min(1.0, ratio))
        phi = math.atan2(p5[1], p5[0])
        s = math.asin(ratio)
        q1s = [phi + s, phi + math.pi - s]
    # each shoulder's two wrists (q5, q6): (shoulder, q5, q6)
    wrists: list[tuple[int, float, float]] = []
    for i, q1 in enumerate(q1s):
        c1, s1q = math.cos(q1), math.sin(q1)
        z1 = np.array([ur.s1 * s1q, -ur.s1 * c1, 0.0])
        c5 = -float(z6 @ z1) / (ur.s4 * ur.s5)
        acos5 = math.acos(max(-1.0, min(1.0, c5)))
        v: Matrix | None = None  # joint 2's axis seen from the flange
        for q5 in (acos5, -acos5):
            sin5 = math.sin(q5)
            if abs(sin5) < _SINGULAR:
                q6 = float(seed[5])  # wrist singular: joints 4 and 6 aligned, q6 free
            else:
                if v is None:
                    v = t06[:3, :3].T @ z1
                q6 = math.atan2(-ur.s4 * v[1] / sin5, ur.s4 * v[0] / sin5)
            wrists.append((i, q5, q6))
    # frame 4 in frame 1 of each wrist: inv(T01) T06 inv(T46), as stacks (the same floats)
    t16 = rigid_inverse_many(dh_stack(q1s, d1, arm.a[0], arm.alpha[0])) @ t06
    t46 = (dh_stack([w[1] for w in wrists], d5, 0.0, arm.alpha[4])
           @ dh_stack([w[2] for w in wrists], d6, 0.0, 0.0))
    t14s = (t16[[w[0] for w in wrists]] @ rigid_inverse_many(t46)).tolist()
    out: list[tuple[float, ...]] = []
    exact: list[bool] = []
    for (i, q5, q6), t14 in zip(wrists, t14s, strict=True):
        q1 = q1s[i]
        x4 = (t14[0][0], t14[1][0])
        sum234 = math.atan2(x4[1], x4[0])
        px = t14[0][3] - arm.a[3] * x4[0]
        py = t14[1][3] - arm.a[3] * x4[1]
        c3 = (px * px + py * py - ur.a2 * ur.a2 - ur.a3 * ur.a3) / (2.0 * ur.a2 * ur.a3)
        elbow = abs(c3) <= 1.0 + 1e-9  # the unclamped form skips the others
        if abs(c3) > 1.0:
            c3 = max(-1.0, min(1.0, c3))
        acos3 = math.acos(c3)
        for q3 in (acos3, -acos3):
            q2 = math.atan2(py, px) - math.atan2(ur.a3 * math.sin(q3), ur.a2 + ur.a3 * math.cos(q3))
            q4 = sum234 - q2 - q3
            out.append(tuple((w + math.pi) % TWO_PI - math.pi for w in (q1, q2, q3, q4, q5, q6)))
            exact.append(elbow)
    return out, exact, reachable


def closed_form(arm: DhArm, target: Matrix, seed: Sequence[float] | None = None) -> list[tuple[float, ...]]:
    """The distinct closed-form solutions for ``target`` (4x4, DH frame 6 in DH frame 0), angles in (-pi, pi].

    Each is checked by forward kinematics; joint limits are not applied (see :func:`place_nearest`).
    ``seed`` only sets the joints that are free at a singularity (default: zeros). Empty when the
    pose is out of reach or ``arm`` does not have the UR structure (see :func:`ur_structure`).
    """
    ur = ur_structure(arm)
    if ur is None:
        return []
    s = tuple(seed) if seed is not None else (0.0,) * 6
    target = np.asarray(target, dtype=float)
    raw = _raw_solutions(arm, ur, target, s, clamp=False)
    if not raw:
        return []
    found = distinct(raw, np.array(raw))
    reached = forward_kinematics_many(arm, found)
    # every solution's errors at once; a value within 1 % of the tolerance is decided by pose_error (the
    # stacked sums differ from its own by far less: ~1e-15 m, ~1e-10 rad near 1e-6 rad)
    pos = np.sqrt(((reached[:, :3, 3] - target[:3, 3]) ** 2).sum(axis=1)).tolist()
    cos = ((np.einsum("nij,ij->n", reached[:, :3, :3], target[:3, :3]) - 1.0) / 2.0).clip(-1.0, 1.0)
    rot = np.arccos(cos).tolist()
    good: list[tuple[float, ...]] = []
    for k, q in enumerate(found):
        if pos[k] < 0.99 * _FK_TOL_M and rot[k] < 0.99 * _FK_TOL_M:
            good.append(q)
        elif pos[k] <= 1.01 * _FK_TOL_M and rot[k] <= 1.01 * _FK_TOL_M:
            pe, re = pose_error(reached[k], target)
            if pe < _FK_TOL_M and re < _FK_TOL_M:
                good.append(q)
    return good


def place_nearest(arm: DhArm, solutions: Sequence[tuple[float, ...]],
                  seed: Sequence[float]) -> list[tuple[float, ...]]:
    """Solutions moved by whole turns into the joint limits nearest ``seed``, nearest first.

    A solution none of whose whole-turn equivalents fits the limits is dropped.
    """
    out = place_in_limits(arm.lower, arm.upper, solutions, seed)
    out.sort(key=nearest_first(seed))
    return out


def ik_solutions(arm: DhArm, target: Matrix, seed: Sequence[float] | None = None) -> list[tuple[float, ...]]:
    """All joint solutions (up to 8) putting DH frame 6 at ``target`` (4x4, in DH frame 0).

    Every angle lies within the joint limits, moved by whole turns to the value nearest ``seed``
    (default: zeros); solutions are sorted by their distance to the seed. Empty when the pose is out
    of reach or ``arm`` does not have the UR structure (see :func:`ur_structure`).
    """
    s = tuple(seed) if seed is not None else (0.0,) * 6
    return place_nearest(arm, closed_form(arm, target, s), s)


def ik_best_effort(arm: DhArm, target: Matrix,
                   seed: Sequence[float] | None = None) -> list[tuple[float, ...]]:
    """For a pose out of reach: the arm stretched towards it (clamped closed form), nearest the seed first.

    Angles are clipped into the joint limits; the poses these reach are *not* the target.
    """
    ur = ur_structure(arm)
    if ur is None:
        return []
    s = tuple(seed) if seed is not None else (0.0,) * 6
    raw = _raw_solutions(arm, ur, np.asarray(target, dtype=float), s, clamp=True)
    out = place_in_limits(arm.lower, arm.upper, raw, s, clip=True)
    out.sort(key=nearest_first(s))
    return out


def _turn(rotvec: npt.NDArray[np.float64]) -> Matrix:
    """The rotation matrix of a rotation vector (Rodrigues)."""
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-15:
        return np.eye(3)
    k = rotvec / angle
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * cross + (1.0 - math.cos(angle)) * cross @ cross


def _frame4_origin(arm: DhArm, flange: Matrix, q: Sequence[float]) -> npt.NDArray[np.float64]:
    """Origin of DH frame 4 for a flange pose with the wrist joints (``q[4]``, ``q[5]``) of ``q``."""
    t46 = dh_matrix(float(q[4]), arm.d[4], arm.a[4], arm.alpha[4]) @ \
        dh_matrix(float(q[5]), arm.d[5], arm.a[5], arm.alpha[5])
    return np.asarray((flange @ _inv(t46))[:3, 3], dtype=float)


def near_reach(arm: DhArm, tool: Matrix, tool_in_flange: Matrix, seed: Sequence[float], pos_tol_m: float,
               rot_tol_rad: float, *, share: float = NEAR_SHARE, rounds: int = NEAR_ROUNDS,
               give_up: float = NEAR_GIVE_UP, branches: int | None = None,
               stretched: Sequence[tuple[float, ...]] | None = None
               ) -> Iterator[tuple[Matrix, list[tuple[float, ...]]]]:
    """For a tool pose just out of reach: tool poses within the tolerances of it that the arm reaches.

    ``tool`` is the tool pose asked for and ``tool_in_flange`` the tool in DH frame 6 (both 4x4, DH
    frame 0). Yields each tool pose found and its closed-form solutions (as :func:`closed_form`), one
    per branch of the stretched arm (:func:`ik_best_effort`: the ``branches`` nearest ``seed``, in
    that order; default :data:`NEAR_BRANCHES`). Per branch the search is the closed form on the tool
    pose moved within ``share`` of the tolerances (at most ``share * pos_tol_m`` and turned by at most
    ``share * rot_tol_rad`` about the tool point), in up to ``rounds`` steps: each step takes the arm
    stretched towards the moved pose (that branch) and the gap ``g`` between its frame 4 origin (where
    the wrist starts) and where the moved pose puts it, then moves the pose so that the wrist moves
    along ``g``: the tool point by ``f * share * pos_tol_m`` along ``g`` and the tool turned by ``f *
    share * rot_tol_rad`` about ``v x g`` (``v``: tool point to frame 4 origin, the lever of the
    turn), ``f`` such that the wrist moves ``|g|`` plus 1 mm; the summed move is clipped to the
    tolerances. A branch gives up when ``|g|`` exceeds ``give_up`` times what the tolerances can move
    the wrist, or the stretched arm lands on the pose. ``stretched``: :func:`ik_best_effort` of
    ``tool`` from ``seed`` when the caller has it (``tool`` is then known to be out of reach).
    Deterministic; the caller checks each solution (only the moved pose is reproduced exactly, within
    the tolerances of ``tool``).
    """
    tool = np.asarray(tool, dtype=float)
    if stretched is None:
        sols = closed_form(arm, tool @ _inv(np.asarray(tool_in_flange, dtype=float)), seed)
        if sols:
            yield tool, sols
            return
        stretched = ik_best_effort(arm, tool @ _inv(np.asarray(tool_in_flange, dtype=float)), seed)
    for branch in range(min(NEAR_BRANCHES if branches is None else branches, len(stretched))):
        found = _near_branch(arm, tool, tool_in_flange, seed, pos_tol_m, rot_tol_rad, share, rounds, give_up,
                             branch, stretched[branch])
        if found is not None:
            yield found


def _near_branch(arm: DhArm, tool: Matrix, tool_in_flange: Matrix, seed: Sequence[float], pos_tol_m: float,
                 rot_tol_rad: float, share: float, rounds: int, give_up: float, branch: int,
                 first: tuple[float, ...]) -> tuple[Matrix, list[tuple[float, ...]]] | None:
    """One branch of :func:`near_reach` (``first``: its stretched arm for ``tool``)."""
    fit = _inv(np.asarray(tool_in_flange, dtype=float))
    a_max, b_max = share * pos_tol_m, share * rot_tol_rad
    shift = np.zeros(3)
    turn = np.zeros(3)
    q: tuple[float, ...] | None = first
    for step in range(rounds):
        moved = tool.copy()
        moved[:3, :3] = _turn(turn) @ tool[:3, :3]
        moved[:3, 3] = tool[:3, 3] + shift
        flange = moved @ fit
        if step > 0:
            sols = closed_form(arm, flange, seed)
            if sols:
                return moved, sols
            stretched = ik_best_effort(arm, flange, seed)
            q = stretched[branch] if branch < len(stretched) else None
        if q is None:
            break
        want = _frame4_origin(arm, flange, q)
        gap = _frame4_origin(arm, forward_kinematics(arm, q), q) - want
        size = float(np.linalg.norm(gap))
        if size < 1e-12:
            break
        along = gap / size
        axis = cross3(want - moved[:3, 3], along)
        lever = float(np.linalg.norm(axis))
        reach = a_max + b_max * lever
        if size > give_up * reach:
            break
        f = (size + 1e-3) / reach
        shift = shift + f * a_max * along
        if lever > 1e-12:
            turn = turn + f * b_max * axis / lever
        norm = float(np.linalg.norm(shift))
        if norm > a_max:
            shift *= a_max / norm
        norm = float(np.linalg.norm(turn))
        if norm > b_max:
            turn *= b_max / norm
    return None


def wrist_centre(arm: DhArm, target: Matrix) -> npt.NDArray[np.float64]:
    """Origin of DH frame 5 (where joints 5 and 6 meet the tool axis) for a flange pose ``target``."""
    t06 = np.asarray(target, dtype=float) @ _flange_strip(arm)
    return np.asarray(t06[:3, 3] - arm.d[5] * t06[:3, 2], dtype=float)


def beyond_reach_m(arm: DhArm, target: Matrix) -> float:
    """A lower bound on how far the wrist centre of ``target`` lies outside what the arm can reach.

    Positive: no joint angles put DH frame 6 at ``target``, nor closer to it than that; zero or
    negative: maybe reachable. The wrist centre keeps ``d2 + d3 + d4`` from the base axis along
    joint 2's (horizontal) axis, and in the plane across it lies at most ``|a2| + |a3| + |a4| + |d5|``
    from joint 2's axis (``|a1|`` from the base axis). ``-inf`` for arms without the UR structure.
    """
    ur = ur_structure(arm)
    if ur is None:
        return -math.inf
    p5 = wrist_centre(arm, target)
    planar = abs(arm.a[1]) + abs(arm.a[2]) + abs(arm.a[3]) + abs(arm.d[4])
    far = math.hypot(planar, ur.shoulder_m) + abs(arm.a[0])
    out = float(np.linalg.norm(p5 - np.array([0.0, 0.0, arm.d[0]]))) - far
    inside = abs(ur.shoulder_m) - math.hypot(float(p5[0]), float(p5[1]))
    return max(out, inside)
