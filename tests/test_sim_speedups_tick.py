"""B5 per-tick speed-ups of session 8 (tickfast) that claim identical results, each against the
former code (kept here, or in the library, as the reference)."""

from __future__ import annotations

import math

import numpy as np

from kbplanner.planning import carry
from kbplanner.simulation import held_pose, recorder, separation, social_force
from kbplanner.simulation.social_force import Obstacle, SocialForceParams
from kbplanner.world.footprint import Rect


def _random_quat(rng: np.random.Generator, k: int) -> list[float]:
    q = rng.normal(size=4)
    if k % 3 == 0:
        q /= np.linalg.norm(q)
    if k % 7 == 0:
        q[int(rng.integers(4))] = 0.0
    return [float(v) for v in q]


def test_held_element_matrix_is_bit_identical_to_scipys() -> None:
    rng = np.random.default_rng(11)
    for k in range(4000):
        q = _random_quat(rng, k)
        pos = rng.normal(size=3).tolist()
        assert held_pose.matrix_of(pos, q).tobytes() == carry.from_pos_quat(pos, q).tobytes(), (pos, q)


def test_held_element_quaternion_is_bit_identical_to_scipys() -> None:
    rng = np.random.default_rng(12)
    kinds = {"off orthogonal": 0, "orthogonal": 0}
    for k in range(4000):
        a = carry.from_pos_quat(rng.normal(size=3).tolist(), _random_quat(rng, k))
        m = a @ carry.transform(*rng.normal(size=6).tolist())  # a product: rounding off orthogonality
        if k % 5 == 0:  # farther off: past the direct path's bounds, or SciPy's own (its SVD)
            m[:3, :3] += rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-16, -4)
        if k % 11 == 0:  # quarter turns: ties in Shepperd's choice, zeros
            m = carry.transform(0, 0, 0, *(rng.integers(-2, 3, size=3) * math.pi / 2).tolist())
        gram = m[:3, :3] @ m[:3, :3].T
        kinds["off orthogonal" if np.abs(gram - np.eye(3)).max() > 1e-13 else "orthogonal"] += 1
        assert held_pose.quat_of(m) == carry.quat_of(m), m
    assert min(kinds.values()) > 100, kinds


def test_points_distance_at_once_is_bit_identical_to_point_by_point() -> None:
    rng = np.random.default_rng(13)
    rects = [Rect(0.0, 0.0, 0.99, 0.67), Rect(0.4, 0.1, 1.2, 0.3, 0.3), Rect(-0.2, 0.0, 0.5, 2.0, 1.2)]
    for _ in range(400):
        pose = (float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3)), float(rng.uniform(-4, 4)))
        n = int(rng.integers(0, 9))
        xs, ys = rng.uniform(-4, 4, n).tolist(), rng.uniform(-4, 4, n).tolist()
        if n and rng.random() < 0.3:
            xs[0], ys[0] = pose[0], pose[1]  # inside: distance 0, no direction
        some = rects[: int(rng.integers(1, 4))]
        former = [separation._point_rects_distance(x, y, pose, some) for x, y in zip(xs, ys, strict=True)]
        assert separation.points_rects_distance(xs, ys, pose, some) == former


def _numpy_accelerations(*args: object) -> np.ndarray:
    """social_force.accelerations by its array code (the former code for every crowd size)."""
    old = social_force.SMALL_CROWD
    social_force.SMALL_CROWD = -1
    try:
        return social_force.accelerations(*args)  # type: ignore[arg-type]
    finally:
        social_force.SMALL_CROWD = old


def test_accelerations_of_a_few_workers_in_floats_are_bit_identical_to_the_array_code() -> None:
    rng = np.random.default_rng(14)
    rects = [Rect(0, 0, 0.99, 0.67), Rect(0.3, 0.1, 1.5, 0.4)]
    for trial in range(1500):
        n = int(rng.integers(0, social_force.SMALL_CROWD + 1))
        pos = rng.uniform(0, 4, (n, 2))
        if n > 2 and rng.random() < 0.2:
            pos[1] = pos[0]  # two workers on one spot
        vel = rng.normal(0, 1, (n, 2)) * (rng.random((n, 1)) > 0.2)
        desired = rng.normal(0, 1, (n, 2))
        params = [SocialForceParams(anisotropy=float(rng.uniform(0, 1)),
                                    b_people=float(rng.uniform(0.1, 0.5)),
                                    comfort_distance_m=float(rng.uniform(0.5, 1.5))) for _ in range(n)]
        seen = None if rng.random() < 0.2 else Obstacle(
            (float(rng.uniform(0, 4)), float(rng.uniform(0, 4)), float(rng.uniform(-3, 3))), rects)
        if seen is not None and n and rng.random() < 0.2:
            pos[0] = seen.pose[:2]  # a worker inside the footprint
        active = rng.random(n) > 0.2 if rng.random() < 0.3 else np.ones(n, dtype=bool)
        got = social_force.accelerations(pos, vel, desired, params, seen, active)
        want = _numpy_accelerations(pos, vel, desired, params, seen, active)
        assert got.shape == want.shape and got.tobytes() == want.tobytes(), trial


def test_recorded_rows_are_the_cells_of_the_former_formatting() -> None:
    def former(v: float, nd: int) -> str:  # recorder._f
        text = f"{v:.{nd}f}"
        return "0." + "0" * nd if text.lstrip("-").strip("0.") == "" else text

    rng = np.random.default_rng(15)
    robot_format = ",".join(["%.2f", *["%.4f"] * 9])
    for _ in range(3000):
        scale = 10.0 ** rng.uniform(-6, 3)
        values = (rng.normal(size=14) * scale).tolist()
        values[int(rng.integers(14))] = -0.0
        values[int(rng.integers(14))] = -0.00004999
        values[0] = abs(values[0])
        want = ",".join([former(values[0], 2), *(former(v, 4) for v in values[1:10])]) + "," + ",".join(
            former(v, 3) for v in values[10:])
        got = recorder._fixed(robot_format % tuple(values[:10])) + recorder._fixed(
            "".join(",%.3f" for _ in values[10:]) % tuple(values[10:]))
        assert got == want
