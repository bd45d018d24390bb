"""B5 speed-ups of session 7 (simstep) that claim identical results, each against the former code
(copied here as the reference): the social-force accelerations, the crowd's via-point check and the
grid yardstick's line of sight."""

from __future__ import annotations

import math

import numpy as np

from kbplanner.simulation.crowd import Crowd
from kbplanner.simulation.grid_yardstick import _dijkstra_cells, grid_shortest_path_length
from kbplanner.simulation.separation import WORKER_RADIUS_M, rects_distance
from kbplanner.simulation.social_force import Obstacle, SocialForceParams, accelerations
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

_RIGHT = math.radians(-20.0)


def _former_accelerations(pos: np.ndarray, vel: np.ndarray, desired: np.ndarray,
                          params: list[SocialForceParams], seen: Obstacle | None, active: np.ndarray
                          ) -> np.ndarray:
    """social_force.accelerations as it was before the change."""
    def arr(name: str) -> np.ndarray:
        return np.array([getattr(p, name) for p in params])

    n = len(pos)
    acc = (desired - vel) / arr("relaxation_time_s")[:, None]
    lam = arr("anisotropy")
    if n > 1:
        d = pos[:, None, :] - pos[None, :, :]
        dist = np.hypot(d[..., 0], d[..., 1])
        np.fill_diagonal(dist, np.inf)
        nx, ny = d[..., 0] / np.where(dist > 0, dist, 1), d[..., 1] / np.where(dist > 0, dist, 1)
        a_p, b_p = arr("a_people")[:, None], arr("b_people")[:, None]
        s_p = arr("personal_distance_m")[:, None]
        mag = a_p / b_p * np.exp(-np.maximum(dist - 2 * WORKER_RADIUS_M - s_p, -s_p) / b_p)
        mag = np.where(np.isfinite(dist) & active[None, :], mag, 0.0)
        vx, vy, lm = vel[:, 0:1], vel[:, 1:2], lam[:, None]
        sp = np.hypot(vx, vy)
        cos_phi = np.where(sp > 1e-9, -(nx * vx + ny * vy) / np.maximum(sp, 1e-9), 1.0)
        w = lm + (1 - lm) * (1 + cos_phi) / 2
        fx, fy = mag * w * nx, mag * w * ny
        acc[:, 0] += fx.sum(axis=1)
        acc[:, 1] += fy.sum(axis=1)
    if seen is not None:
        dr, ux, uy = rects_distance(pos[:, 0], pos[:, 1], seen.pose, seen.rects)
        inside = (ux == 0) & (uy == 0)
        cx, cy = pos[:, 0] - seen.pose[0], pos[:, 1] - seen.pose[1]
        cn = np.maximum(np.hypot(cx, cy), 1e-9)
        ux, uy = np.where(inside, cx / cn, ux), np.where(inside, cy / cn, uy)
        a_r, b_r, s_c = arr("a_robot"), arr("b_robot"), arr("comfort_distance_m")
        mag = a_r / b_r * np.exp(-np.maximum(dr - WORKER_RADIUS_M - s_c, -s_c) / b_r)
        ahead = -(ux * vel[:, 0] + uy * vel[:, 1]) > 0
        c, s = math.cos(_RIGHT), math.sin(_RIGHT)
        rx = np.where(ahead, c * ux - s * uy, ux)
        ry = np.where(ahead, s * ux + c * uy, uy)
        acc[:, 0] += mag * 1.0 * rx
        acc[:, 1] += mag * 1.0 * ry
    return np.where(active[:, None], acc, 0.0)


def test_accelerations_are_bit_identical_to_the_former_code() -> None:
    rng = np.random.default_rng(5)
    rects = [Rect(0, 0, 0.99, 0.67), Rect(0.3, 0.1, 1.5, 0.4)]
    kinds = set()
    for _ in range(1500):
        n = int(rng.integers(1, 7))
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
        active = rng.random(n) > 0.2 if rng.random() < 0.3 else np.ones(n, dtype=bool)
        got = accelerations(pos, vel, desired, params, seen, active)
        want = _former_accelerations(pos, vel, desired, params, seen, active)
        assert got.tobytes() == want.tobytes()
        if seen is not None:
            d, _, _ = rects_distance(pos[:, 0], pos[:, 1], seen.pose, seen.rects)
            kinds.add(bool((d == 0).any()))
    assert kinds == {True, False}  # workers inside the footprint and outside it were both tried


def _former_clear_many(crowd: Crowd, legs: list[tuple[np.ndarray, np.ndarray]], robot: Obstacle
                       ) -> list[bool]:
    """Crowd._clear_many as it was: per leg, np.linspace samples and the former walkability test."""
    free, g = crowd.router.free, crowd.router.grid
    assert free is not None and g is not None
    samples = []
    for p, q in legs:
        n = max(2, int(np.hypot(*(q - p)) / 0.1) + 1)
        f = np.linspace(0.0, 1.0, n)[:, None]
        samples.append(p[None, :] + f * (q - p)[None, :])
    pts = np.concatenate(samples)
    d_all, _, _ = rects_distance(pts[:, 0], pts[:, 1], robot.pose, robot.rects)
    out, start = [], 0
    for leg in samples:
        d = d_all[start : start + len(leg)]
        start += len(leg)
        ix = np.floor((leg[:, 0] - g.origin[0]) / g.resolution).astype(np.int64)
        iy = np.floor((leg[:, 1] - g.origin[1]) / g.resolution).astype(np.int64)
        inside = (ix >= 0) & (iy >= 0) & (iy < free.shape[0]) & (ix < free.shape[1])
        ok = np.zeros(len(leg), dtype=bool)
        ok[inside] = free[iy[inside], ix[inside]].astype(bool)
        out.append(float(d.min()) >= WORKER_RADIUS_M + 0.3 and bool(np.all(ok[1:] | ~ok[:-1])))
    return out


def test_via_points_checked_at_once_as_one_by_one() -> None:
    rng = np.random.default_rng(8)
    occ = rng.random((80, 100)) < 0.03
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    crowd = Crowd([], OccupancyGrid(occ, origin=(-1.0, -2.0), resolution=0.05), seed=1)
    answers = set()
    for _ in range(200):
        robot = Obstacle((float(rng.uniform(0, 3)), float(rng.uniform(-1, 1.5)), float(rng.uniform(-3, 3))),
                         [Rect(0, 0, 0.99, 0.67), Rect(0.2, 0.0, 1.2, 0.3)])
        p = rng.uniform([-1.5, -2.5], [4.5, 2.5])
        legs = [(p, rng.uniform([-1.5, -2.5], [4.5, 2.5])) for _ in range(int(rng.integers(1, 17)))]
        got = crowd._clear_many(legs, robot)
        assert got == _former_clear_many(crowd, legs, robot)
        answers.update(got)
    assert answers == {True, False}


def _former_length(cs: ConfigurationSpace, start: tuple[float, float], goal: tuple[float, float]) -> float:
    """grid_shortest_path_length as it was: one line-of-sight query per candidate."""
    free = cs.free_any_yaw()
    g = cs.grid
    ny, nx = g.shape
    (sx, sy), (gx, gy) = g.cell_of(*start), g.cell_of(*goal)
    if not (0 <= sx < nx and 0 <= sy < ny and 0 <= gx < nx and 0 <= gy < ny) or not (
            free[sy, sx] and free[gy, gx]):
        return math.inf
    cells = _dijkstra_cells(free, (sy, sx), (gy, gx))
    if cells is None:
        return math.inf
    pts = [start, *(g.center_of(x, y) for y, x in cells[1:-1]), goal]

    def visible(a: tuple[float, float], b: tuple[float, float]) -> bool:
        n = max(1, math.ceil(math.hypot(b[0] - a[0], b[1] - a[1]) / (g.resolution / 2)))
        u = np.linspace(0.0, 1.0, n + 1)
        xs, ys = a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])
        ix = np.floor((xs - g.origin[0]) / g.resolution).astype(np.int64)
        iy = np.floor((ys - g.origin[1]) / g.resolution).astype(np.int64)
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        return bool(inside.all() and free[iy, ix].all())

    length, i = 0.0, 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1 and not visible(pts[i], pts[j]):
            j -= 1
        length += math.hypot(pts[j][0] - pts[i][0], pts[j][1] - pts[i][1])
        i = j
    return length


def test_yardstick_line_of_sight_in_batches_gives_the_former_lengths() -> None:
    rng = np.random.default_rng(4)
    lengths = []
    for trial in range(6):
        occ = rng.random((90, 120)) < 0.01 * (trial + 1)
        occ[[0, -1], :] = True
        occ[:, [0, -1]] = True
        occ[20:70, 40 + trial * 5] = True  # a wall to go round
        cs = ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05),
                                      Footprint((Rect(0, 0, 0.3, 0.2),)), 16)
        for _ in range(6):
            a = (float(rng.uniform(0.2, 5.8)), float(rng.uniform(0.2, 4.3)))
            b = (float(rng.uniform(0.2, 5.8)), float(rng.uniform(0.2, 4.3)))
            want = _former_length(cs, a, b)
            assert grid_shortest_path_length(cs, a, b) == want
            assert grid_shortest_path_length(cs, a, b) == want  # kept with the space: the same again
            lengths.append(want)
    assert any(math.isfinite(v) and v > 2.0 for v in lengths)
