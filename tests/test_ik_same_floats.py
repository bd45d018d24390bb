"""B4's closed-form IK made cheaper (session 14, b4first14) gives the very floats of the form before it:
the pre-session code is kept here as the reference and compared bit for bit on random, singular and
out-of-reach poses of both shipped arms (the case study's 2710 queries are compared end to end by
``benchmarks/ik_replay.py``)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pytest

from kbplanner.robot import arm_analytic_ik as ak
from kbplanner.robot.arm_analytic_ik import DhArm, UrStructure
from kbplanner.robot.robot_model import RobotModel

TWO_PI = 2.0 * math.pi


def _dh_ref(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct],
                     [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d],
                     [0.0, 0.0, 0.0, 1.0]])


def _fk_ref(arm: DhArm, q: Sequence[float]) -> np.ndarray:
    t = np.eye(4)
    for i in range(6):
        t = t @ _dh_ref(float(q[i]), arm.d[i], arm.a[i], arm.alpha[i])
    return t


def _inv_ref(t: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    r = t[:3, :3].T
    out[:3, :3] = r
    out[:3, 3] = -r @ t[:3, 3]
    return out


def _raw_ref(arm: DhArm, ur: UrStructure, target: np.ndarray, seed: Sequence[float],
             clamp: bool) -> list[tuple[float, ...]]:
    """``_raw_solutions`` as it was before session 14."""
    d1, d5, d6 = arm.d[0], arm.d[4], arm.d[5]
    t06 = target @ _inv_ref(_dh_ref(0.0, 0.0, arm.a[5], arm.alpha[5]))
    z6 = t06[:3, 2]
    p5 = t06[:3, 3] - d6 * z6
    r = math.hypot(p5[0], p5[1])
    big_d = ur.shoulder_m
    if r < 1e-12:
        if abs(big_d) > 1e-12 and not clamp:
            return []
        q1s = [float(seed[0])]
    else:
        ratio = ur.s1 * big_d / r
        if abs(ratio) > 1.0:
            if not clamp and abs(ratio) > 1.0 + 1e-12:
                return []
            ratio = max(-1.0, min(1.0, ratio))
        phi = math.atan2(p5[1], p5[0])
        s = math.asin(ratio)
        q1s = [phi + s, phi + math.pi - s]
    out: list[tuple[float, ...]] = []
    for q1 in q1s:
        c1, s1q = math.cos(q1), math.sin(q1)
        z1 = np.array([ur.s1 * s1q, -ur.s1 * c1, 0.0])
        c5 = -float(z6 @ z1) / (ur.s4 * ur.s5)
        acos5 = math.acos(max(-1.0, min(1.0, c5)))
        for q5 in (acos5, -acos5):
            sin5 = math.sin(q5)
            if abs(sin5) < 1e-9:
                q6 = float(seed[5])
            else:
                v = t06[:3, :3].T @ z1
                q6 = math.atan2(-ur.s4 * v[1] / sin5, ur.s4 * v[0] / sin5)
            t46 = _dh_ref(q5, d5, 0.0, arm.alpha[4]) @ _dh_ref(q6, d6, 0.0, 0.0)
            t14 = _inv_ref(_dh_ref(q1, d1, arm.a[0], arm.alpha[0])) @ t06 @ _inv_ref(t46)
            x4 = t14[:3, 0]
            sum234 = math.atan2(x4[1], x4[0])
            px = t14[0, 3] - arm.a[3] * x4[0]
            py = t14[1, 3] - arm.a[3] * x4[1]
            c3 = (px * px + py * py - ur.a2 * ur.a2 - ur.a3 * ur.a3) / (2.0 * ur.a2 * ur.a3)
            if abs(c3) > 1.0:
                if not clamp and abs(c3) > 1.0 + 1e-9:
                    continue
                c3 = max(-1.0, min(1.0, c3))
            acos3 = math.acos(c3)
            for q3 in (acos3, -acos3):
                q2 = math.atan2(py, px) - math.atan2(ur.a3 * math.sin(q3), ur.a2 + ur.a3 * math.cos(q3))
                q4 = sum234 - q2 - q3
                out.append(tuple((w + math.pi) % TWO_PI - math.pi for w in (q1, q2, q3, q4, q5, q6)))
    return out


def _closed_form_ref(arm: DhArm, target: np.ndarray, seed: Sequence[float]) -> list[tuple[float, ...]]:
    ur = ak.ur_structure(arm)
    assert ur is not None
    good: list[tuple[float, ...]] = []
    seen: set[tuple[float, ...]] = set()
    for q in _raw_ref(arm, ur, target, seed, clamp=False):
        key = tuple(round(v, 9) for v in q)
        if key in seen:
            continue
        seen.add(key)
        pe, re = ak.pose_error(_fk_ref(arm, q), target)
        if pe < 1e-6 and re < 1e-6:
            good.append(q)
    return good


@pytest.fixture(scope="module", params=("husky_ur5", "husky_ur16e"))
def arm(request: pytest.FixtureRequest) -> DhArm:
    robot = RobotModel.load(request.param)
    try:
        spec = robot.spec.arm
        assert spec is not None
        lo, hi = robot.arm_limits()
        return DhArm(tuple(spec.d), tuple(spec.a), tuple(spec.alpha), tuple(lo), tuple(hi))
    finally:
        robot.close()


def _targets(arm: DhArm, n: int) -> list[tuple[np.ndarray, tuple[float, ...]]]:
    """Poses the arm reaches (some wrist-singular: q5 = 0), poses moved off them (some out of reach)."""
    rng = np.random.default_rng(14)
    out = []
    for k in range(n):
        q = [float(v) for v in rng.uniform(-math.pi, math.pi, 6)]
        if k % 7 == 0:
            q[4] = 0.0
        t = _fk_ref(arm, q)
        if k % 3 == 1:
            t = t.copy()
            t[:3, 3] *= float(rng.uniform(1.2, 2.0))  # stretched: often out of reach
        seed = tuple(float(v) for v in rng.uniform(-math.pi, math.pi, 6))
        out.append((t, seed))
    return out


def test_forward_kinematics_of_a_stack_is_the_lone_products_bit_for_bit(arm: DhArm) -> None:
    rng = np.random.default_rng(3)
    for n in (1, 2, 5, 8):
        qs = [tuple(float(v) for v in rng.uniform(-4.0, 4.0, 6)) for _ in range(n)]
        many = ak.forward_kinematics_many(arm, qs)
        for q, t in zip(qs, many, strict=True):
            assert t.tobytes() == _fk_ref(arm, q).tobytes()
            assert ak.forward_kinematics(arm, q).tobytes() == t.tobytes()


def test_closed_form_and_stretched_arm_are_the_floats_of_the_reference(arm: DhArm) -> None:
    ur = ak.ur_structure(arm)
    assert ur is not None
    solved = stretched = 0
    for target, seed in _targets(arm, 400):
        got = ak.closed_form(arm, target, seed)
        assert repr(got) == repr(_closed_form_ref(arm, target, seed))
        solved += bool(got)
        for clamp in (False, True):
            assert repr(ak._raw_solutions(arm, ur, target, seed, clamp)) == \
                repr(_raw_ref(arm, ur, target, seed, clamp))
        t06 = target @ _inv_ref(_dh_ref(0.0, 0.0, arm.a[5], arm.alpha[5]))
        assert ak.wrist_centre(arm, target).tobytes() == (t06[:3, 3] - arm.d[5] * t06[:3, 2]).tobytes()
        stretched += not got
    assert solved > 100 and stretched > 40  # both kinds of pose were compared


def test_inverse_and_dh_matrix_are_the_reference_floats() -> None:
    rng = np.random.default_rng(5)
    for _ in range(500):
        theta, d, a, alpha = (float(v) for v in rng.uniform(-4.0, 4.0, 4))
        m = ak.dh_matrix(theta, d, a, alpha)
        assert m.tobytes() == _dh_ref(theta, d, a, alpha).tobytes()
        t = _fk_ref(DhArm((d,) * 6, (a,) * 6, (alpha,) * 6), rng.uniform(-3, 3, 6))
        assert ak._inv(t).tobytes() == _inv_ref(t).tobytes()


def test_cross3_is_numpys_cross_bit_for_bit() -> None:
    rng = np.random.default_rng(9)
    vectors = [rng.standard_normal(3) * 10.0 ** float(rng.integers(-8, 8)) for _ in range(3000)]
    vectors += [np.array([0.0, -0.0, 1.0]), np.array([-0.0, 0.0, -0.0]), np.array([1e-300, -1e300, 3.0])]
    for a, b in zip(vectors, vectors[1:] + vectors[:1], strict=True):
        assert ak.cross3(a, b).tobytes() == np.cross(a, b).tobytes()


def test_distinct_drops_the_rows_the_rounding_to_9_decimals_drops() -> None:
    from kbplanner.robot.arm_ik_joints import distinct

    rng = np.random.default_rng(11)
    for trial in range(2000):
        base = [tuple(float(v) for v in rng.uniform(-3.0, 3.0, 6)) for _ in range(int(rng.integers(1, 9)))]
        rows = list(base)
        for _ in range(int(rng.integers(0, 4))):  # near copies: within, at and beyond the rounding
            src = rows[int(rng.integers(0, len(rows)))]
            step = float(rng.choice([0.0, 1e-12, 4e-10, 1e-9, 1.5e-9, 3e-9]))
            rows.insert(int(rng.integers(0, len(rows) + 1)), tuple(v + step for v in src))
        want: list[tuple[float, ...]] = []
        seen: set[tuple[float, ...]] = set()
        for r in rows:
            key = tuple(round(v, 9) for v in r)
            if key not in seen:
                seen.add(key)
                want.append(r)
        assert distinct(rows, np.array(rows)) == want, trial
