"""B5 per-tick speed-ups of session 8 (tickfast) that claim identical results, each against the
former code (kept here, or in the library, as the reference)."""

from __future__ import annotations

import math

import numpy as np

from kbplanner.planning import carry
from kbplanner.simulation import crowd as crowd_mod
from kbplanner.simulation import held_pose, recorder, separation, social_force
from kbplanner.simulation.crowd import Crowd
from kbplanner.simulation.social_force import Obstacle, SocialForceParams
from kbplanner.simulation.workers import RouteStop, WorkerSpec
from kbplanner.world.footprint import Rect
from kbplanner.world.occupancy import OccupancyGrid


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
        assert held_pose.quat_of(m) == held_pose.REFERENCE["quat_of"](m), m  # SciPy's Rotation
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


class _FormerCrowd(Crowd):
    """The crowd's per-step code as it was before session 8 (desired velocities on numpy rows, every
    step through _constrain, the delay masks, no memory of a vain look for a way round, the
    social force by its array code)."""

    def _desired(self) -> np.ndarray:
        out = np.zeros_like(self.pos)
        for i, a in enumerate(self.agents):
            p = self.pos[i]
            if not a.walking and self.t >= a.until and a.yielding is None:
                a.making_way = False
                there = a.spec.stops[(a.k + 1) % len(a.spec.stops)]
                a.path = self.router.path((float(p[0]), float(p[1])), (there.x, there.y))
                a.wp, a.walking = 1, True
            if a.walking:
                reached = crowd_mod.WAYPOINT_REACHED_M
                while a.wp < len(a.path) - 1 and math.hypot(*(a.path[a.wp] - p)) < reached:
                    a.wp += 1
                goal = a.path[a.wp]
                d = math.hypot(*(goal - p))
                if a.wp == len(a.path) - 1 and d < crowd_mod.ARRIVED_M:
                    a.walking = False
                    a.k = (a.k + 1) % len(a.spec.stops)
                    stop = a.spec.stops[a.k]
                    a.anchor = (stop.x, stop.y)
                    a.until = self.t + stop.dwell_s * float(a.rng.uniform(0.8, 1.2))
                else:
                    out[i] = (goal - p) / max(d, 1e-9) * a.v0
                    continue
            target = self._way_target(a, p)
            d_vec = target - p
            d = float(np.hypot(*d_vec))
            if d > 0.05:
                out[i] = d_vec / d * min(a.v0, d / a.params.relaxation_time_s)
        return out

    def step(self, robot: Obstacle | None) -> None:
        self._history.append(robot)
        self._release(robot)
        if robot is not None:
            self._detours(robot)
        desired = self._desired()
        params = self._params
        active = np.ones(len(self.agents), dtype=bool)
        acc = np.zeros_like(self.pos)
        for delay, mask in zip(self._delays, self._masks, strict=True):
            seen = self._history[max(len(self._history) - 1 - delay, 0)]
            if mask.any():
                a_all = _numpy_accelerations(self.pos, self.vel, desired, params, seen, active)
                acc[mask] = a_all[mask]
        vel = social_force.cap_speed(self.vel + acc * self.dt, self._v0, params)
        new = self.pos + vel * self.dt
        for i, a in enumerate(self.agents):
            new[i], vel[i] = self._constrain(self.pos[i], new[i], vel[i], robot)
            if a.making_way and desired[i].any() and (not vel[i].any() or a.way_slow_s >= crowd_mod.STUCK_S):
                new[i], vel[i] = self._constrain(self.pos[i], self.pos[i] + desired[i] * self.dt, desired[i],
                                                 robot)
        moving = np.hypot(vel[:, 0], vel[:, 1]) > 0.05
        self.heading = np.where(moving, np.arctan2(vel[:, 1], vel[:, 0]), self.heading)
        self.pos, self.vel = new, vel
        self.t += self.dt

    def _detours(self, robot: Obstacle) -> None:
        self._no_detour.clear()  # never skip: look every time
        super()._detours(robot)


def _site() -> OccupancyGrid:
    """A corridor with an alcove and a pillar: walls to slide along, people to pass."""
    res, x0, y0 = 0.05, -7.0, -2.0
    ys, xs = np.mgrid[0:140, 0:280]
    cx, cy = x0 + (xs + 0.5) * res, y0 + (ys + 0.5) * res
    free = (np.abs(cy) < 1.2) | ((cx > 2.0) & (cx < 4.0) & (cy < 4.5))
    free &= ~((np.abs(cx + 1.0) < 0.3) & (np.abs(cy - 0.3) < 0.3))
    return OccupancyGrid(occupied=~free, origin=(x0, y0), resolution=res)


def test_crowd_steps_are_bit_identical_to_the_former_step() -> None:
    specs = [WorkerSpec(f"urn:test:w{k}", f"W{k}", "carpenter", 1.1 + 0.1 * k,
                        (RouteStop("a", "A", -6.0 + k, -0.9 + 0.6 * k, 2.0 + k),
                         RouteStop("b", "B", 6.0 - k, 0.9 - 0.6 * k, 1.0),
                         RouteStop("c", "C", 3.0, 3.5, 4.0)))
             for k in range(4)]
    specs.append(WorkerSpec("urn:test:waiter", "Waiter", "carpenter", 1.2,
                            (RouteStop("s", "S", 0.5, 0.0, 1e6),)))
    rects = [Rect(0.0, 0.0, 0.99, 0.67), Rect(0.3, 0.0, 2.4, 0.3)]
    for seed in (1, 2):
        grid = _site()
        new, old = Crowd(specs, grid, seed=seed), _FormerCrowd(specs, grid, seed=seed)
        for k in range(900):
            x = -5.0 + 10.0 * abs(((k / 450.0) % 2.0) - 1.0)  # the robot drives to and fro along the corridor
            pose = (x, 0.05 * math.sin(k / 40), 0.1 * math.sin(k / 70))
            robot = None if 300 <= k < 330 else Obstacle(pose, rects)
            if k in (200, 600):
                path = np.array([[x + 0.5 * j, 0.0] for j in range(12)])
                assert new.make_way(4, path, 1.3) == old.make_way(4, path, 1.3)
            new.step(robot)
            old.step(robot)
            for a, b in ((new.pos, old.pos), (new.vel, old.vel), (new.heading, old.heading)):
                assert a.tobytes() == b.tobytes(), (seed, k)
            assert all(p.path.tobytes() == q.path.tobytes()
                       for p, q in zip(new.agents, old.agents, strict=True))


def test_base_pose_read_again_only_when_pybullet_moved_the_base_gives_the_former_numbers() -> None:
    import pybullet as p

    from kbplanner.robot.robot_model import RobotModel

    robot = RobotModel.load("husky_ur16e")
    try:
        def former() -> tuple[float, float, float]:
            pos, orn = robot.link_pose(-1)
            return (float(pos[0]), float(pos[1]), float(p.getEulerFromQuaternion(orn)[2]))

        rng = np.random.default_rng(16)
        for k in range(300):
            if k % 3 == 0:
                robot.set_base_pose(*rng.uniform(-50, 50, 2).tolist(), float(rng.uniform(-4, 4)))
            elif k % 3 == 1:  # moved behind the model's back: read again all the same
                quat = p.getQuaternionFromEuler([0.0, 0.0, float(rng.uniform(-4, 4))])
                p.resetBasePositionAndOrientation(robot.body, [*rng.uniform(-9, 9, 2).tolist(), 0.2], quat,
                                                  physicsClientId=robot.client)
            assert robot.base_pose() == former()
            assert robot.base_pose() == former()  # the kept one
        q = rng.uniform(-1, 1, len(robot.arm_joints)).tolist()
        robot.set_arm(q)
        assert robot.arm_positions() == tuple(
            float(p.getJointState(robot.body, j, physicsClientId=robot.client)[0]) for j in robot.arm_joints)
    finally:
        robot.close()
