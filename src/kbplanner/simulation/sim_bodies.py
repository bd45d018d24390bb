"""B5 simulation environment, the bodies that move with the run: the worker capsules and the held element,
placed in PyBullet only when something looks at them.

Takes the environment's PyBullet client, its robot and the workers' poses
(:class:`~kbplanner.simulation.sim_env.SimEnv`); gives

- :class:`WorkerBodies`: a kinematic capsule per worker (radius 0.25 m, 1.7 m tall, mass 0), put where
  the worker is when :meth:`WorkerBodies.place` is called (an unchanged pose is not set again, an
  unchanged heading keeps its quaternion);
- :class:`HeldPlacer` with :class:`SimRobot`: the held element follows the tool. :meth:`HeldPlacer.follow`
  only notes that it must; :meth:`HeldPlacer.place` puts it where the grasp held it then (tool frame
  times the inverse grasp). The robot tells the placer before it moves (:attr:`SimRobot.before_move`),
  which keeps the arguments of the robot's last base and arm settings; placing later puts the robot back
  in that pose for the tool's frame (the same PyBullet state, so the same numbers) and again where it is.

Nothing in the per-period loop reads these bodies from PyBullet except a lidar scan, a ray test, a key
frame, a body's frame or a physics step, before which the environment places them
(:meth:`~kbplanner.simulation.sim_env.SimEnv.sync`): they are where they would be had they been placed
every period, at a fraction of the calls.

The robot itself (:class:`SimRobot`) is placed the same way: its base and arm settings are noted and put
in PyBullet by :meth:`SimRobot.place_pending`, which every reader of its PyBullet state calls first;
its base pose is answered without placing it, from the pose PyBullet will report (:func:`stored_pose`,
checked bit for bit against PyBullet once per robot).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from kbplanner.core.iris import slug
from kbplanner.planning.carry import Matrix
from kbplanner.robot.robot_model import Quat, RobotModel, Vec3
from kbplanner.simulation.held_pose import matrix_of, quat_of
from kbplanner.simulation.workers import WORKER_RADIUS_M, WorkerMotion, WorkerSpec
from kbplanner.world.world_types import WorldElement

WORKER_HEIGHT_M = 1.7
_RGBA_WORKER = (0.1, 0.6, 0.2, 1.0)

RobotPose = tuple[tuple[float, float, float, float | None], tuple[float, ...]]  # base and arm settings


@dataclass
class Held:
    """The element in the gripper: its body, the constraint and the tool frame in its frame."""

    element: WorldElement
    body: int
    constraint: int
    tool_in_element: Matrix
    element_in_tool: Matrix | None = None  # inv(tool_in_element), computed once
    com_in_element: Matrix | None = None  # the body's centre of mass frame in the element's, once

    def __post_init__(self) -> None:
        if self.element_in_tool is None:
            self.element_in_tool = np.asarray(np.linalg.inv(self.tool_in_element), dtype=np.float64)


@dataclass(frozen=True)
class WorkerBody:
    """A worker's capsule body and the column slug used in the trajectories (``motion``: scripted)."""

    motion: WorkerMotion | None
    body: int
    slug: str
    label: str


class SimRobot(RobotModel):
    """The environment's robot: calls :attr:`before_move` before it moves, and keeps the arguments of
    its last :meth:`set_base_pose` and :meth:`set_arm`, which put it back in that pose (:meth:`put`)
    and are its arm joints until physics steps (:meth:`forget_base`).

    Placed in PyBullet when looked at: a base or arm setting is noted and put in PyBullet by
    :meth:`place_pending`, which every reader of the robot's PyBullet state calls first (its own
    reads, the lidar, inverse kinematics, :meth:`~kbplanner.simulation.sim_env.SimEnv.sync`). The
    settings still due are replayed in the order they were last made, the base's floor as it was
    when set: the same PyBullet calls as the last ones of placing at every setting, so the same state.
    """

    before_move: Callable[[], None] | None = None
    base_set: tuple[float, float, float, float | None] | None = None
    arm_set: tuple[float, ...] | None = None
    # the settings not yet put in PyBullet, in the order last made: ("base", (x, y, yaw, z)), ("arm", q)
    _due: tuple[tuple[str, Any], ...] = ()

    def _defer(self, kind: str, args: Any) -> None:
        self._due = (*(d for d in self._due if d[0] != kind), (kind, args))

    # whether PyBullet's base pose is known without asking it (checked once per robot: round_trip_ok)
    _round_trip: bool | None = None

    def set_base_pose(self, x: float, y: float, yaw: float, z: float | None = None) -> None:
        if self.before_move is not None:
            self.before_move()
        self._defer("base", (x, y, yaw, self.floor_z if z is None else z))
        self._base_fresh = False
        self.base_set = (x, y, yaw, z)

    def base_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the base frame: with a base setting still due, from the pose PyBullet will
        report once it is placed (:func:`stored_pose`, the same numbers), without placing it."""
        if self._base_fresh and self._base_read is not None:
            return self._base_read[1]
        due = next((args for kind, args in self._due if kind == "base"), None)
        if due is None or not self.round_trip_ok():
            return super().base_pose()
        com_pos, com_orn = stored_pose(self, *due)
        return self._base_from_com(com_pos, com_orn)

    def round_trip_ok(self) -> bool:
        """Whether :func:`stored_pose` gives PyBullet's reported base pose bit for bit on this PyBullet
        (checked on :data:`_CHECK_POSES` poses the first time; else every base pose asked is read from
        PyBullet after placing the robot). Asked with a base setting due, which is placed over the
        poses checked."""
        if self._round_trip is None:
            import pybullet as p

            assert any(kind == "base" for kind, _ in self._due)
            ok = True
            for k in range(_CHECK_POSES):
                pose = (math.sin(k * 12.9898) * 40.0, math.cos(k * 78.233) * 40.0, k * 0.1309 - 4.2, k * 0.37)
                self._reset_base(*pose)
                got = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
                ok = ok and _bits(*got[0], *got[1]) == _bits(*(v for part in stored_pose(self, *pose)
                                                                for v in part))
            self._round_trip = ok
        return self._round_trip

    def set_arm(self, q: Sequence[float]) -> None:
        if self.before_move is not None:
            self.before_move()
        self._check_arm(q)
        self._defer("arm", tuple(q))
        self.arm_set = tuple(float(v) for v in q)

    def place_pending(self) -> None:
        """Put the base and the arm settings still due in PyBullet (in the order last made)."""
        due = self._due
        if not due:
            return
        self._due = ()
        for kind, args in due:
            if kind == "base":
                self._reset_base(*args)
            else:
                self._reset_arm(args)

    def arm_positions(self) -> tuple[float, ...]:
        """The arm joint angles: those of the last :meth:`set_arm` (PyBullet gives back the very
        numbers it was given), else read."""
        if self.arm_set is not None:
            return self.arm_set
        return super().arm_positions()

    def forget_base(self) -> None:
        """Physics may have moved the base and the arm: read them again."""
        super().forget_base()
        self.arm_set = None

    def pose_set(self) -> RobotPose | None:
        """The base's and the arm's last setting (None: one of them was never set here)."""
        if self.base_set is None or self.arm_set is None:
            return None
        return self.base_set, self.arm_set

    def put(self, pose: RobotPose) -> None:
        """Set the base and the arm as :meth:`pose_set` gave them (the same PyBullet state)."""
        x, y, yaw, z = pose[0]
        self._defer("base", (x, y, yaw, self.floor_z if z is None else z))
        self._base_fresh = False
        self._defer("arm", pose[1])
        self.base_set, self.arm_set = pose


_CHECK_POSES = 64


def _bits(*values: float) -> bytes:
    return struct.pack(f"{len(values)}d", *values)


def stored_pose(robot: RobotModel, x: float, y: float, yaw: float, z: float) -> tuple[Vec3, Quat]:
    """The body pose PyBullet reports after :meth:`RobotModel.set_base_pose` ``(x, y, yaw, z)``: the
    position as given, the quaternion through Bullet's rotation matrix and back
    (``btMatrix3x3::setRotation``, ``getRotation``), in the same double arithmetic."""
    import pybullet as p

    pos, orn = p.multiplyTransforms((x, y, z), p.getQuaternionFromEuler((0.0, 0.0, yaw)),
                                    robot._com_pos, robot._com_orn)
    qx, qy, qz, qw = (float(v) for v in orn)
    s = 2.0 / (qx * qx + qy * qy + qz * qz + qw * qw)
    xs, ys, zs = qx * s, qy * s, qz * s
    wx, wy, wz = qw * xs, qw * ys, qw * zs
    xx, xy, xz = qx * xs, qx * ys, qx * zs
    yy, yz, zz = qy * ys, qy * zs, qz * zs
    m = ((1.0 - (yy + zz), xy - wz, xz + wy), (xy + wz, 1.0 - (xx + zz), yz - wx),
         (xz - wy, yz + wx, 1.0 - (xx + yy)))
    t = [0.0, 0.0, 0.0, 0.0]
    trace = m[0][0] + m[1][1] + m[2][2]
    if trace > 0.0:
        r = math.sqrt(trace + 1.0)
        t[3] = r * 0.5
        r = 0.5 / r
        t[0], t[1], t[2] = (m[2][1] - m[1][2]) * r, (m[0][2] - m[2][0]) * r, (m[1][0] - m[0][1]) * r
    else:
        i = (2 if m[1][1] < m[2][2] else 1) if m[0][0] < m[1][1] else (2 if m[0][0] < m[2][2] else 0)
        j, k = (i + 1) % 3, (i + 2) % 3
        r = math.sqrt(m[i][i] - m[j][j] - m[k][k] + 1.0)
        t[i] = r * 0.5
        r = 0.5 / r
        t[3] = (m[k][j] - m[j][k]) * r
        t[j] = (m[j][i] + m[i][j]) * r
        t[k] = (m[k][i] + m[i][k]) * r
    return (float(pos[0]), float(pos[1]), float(pos[2])), (t[0], t[1], t[2], t[3])


def _translation(v: Sequence[float]) -> Matrix:
    m = np.eye(4)
    m[:3, 3] = list(v)
    return m


def place_body(client: int, body: int, com: Matrix) -> None:
    """Put a body's centre of mass frame at ``com`` (site), kinematically."""
    import pybullet as p

    p.resetBasePositionAndOrientation(body, com[:3, 3].tolist(), quat_of(com), physicsClientId=client)


class HeldPlacer:
    """Where the held element goes: noted by :meth:`follow`, put by :meth:`place` (see module docstring)."""

    def __init__(self, client: int) -> None:
        self.client = client
        self.due = False  # follow() asked since the held element was last placed
        self._at: RobotPose | None = None  # the robot's pose when follow() was asked, once it moved since
        self._followed: tuple[Held, Any, Any] | None = None  # what was put, the tool, the body's pose

    def follow(self) -> None:
        """The held element follows the tool where it is now."""
        self.due = True
        self._at = None

    def robot_moves(self, held: Held | None, robot: RobotModel) -> None:
        """The robot is about to move: keep its pose for the held element still to be placed."""
        if self.due and self._at is None:
            at = robot.pose_set() if isinstance(robot, SimRobot) else None
            if at is None:
                self.place(held, robot)  # (a pose it was not given here: place the element now)
            else:
                self._at = at

    def place(self, held: Held | None, robot: RobotModel) -> None:
        """Put the held element where the grasp held it when :meth:`follow` was last asked, if it was
        asked since the element was last put: with the robot put back in the pose it had then for the
        tool's frame, and again where it is."""
        if not self.due:
            return
        self.due = False
        at, self._at = self._at, None
        if at is None or not isinstance(robot, SimRobot):
            self._put(held, robot)
            return
        now = robot.pose_set()
        assert now is not None
        robot.put(at)
        try:
            self._put(held, robot)
        finally:
            robot.put(now)

    def _put(self, held: Held | None, robot: RobotModel) -> None:
        """Put the held element where the grasp holds it now.

        Skipped when neither the tool nor the element has moved since the last time (the same
        pose would be set again): the tool's pose and the element body's are compared as PyBullet
        reports them, which is cheaper than the frames."""
        import pybullet as p

        if held is None:
            return
        assert held.element_in_tool is not None
        body = held.body
        tool = robot.tool_pose()
        last = self._followed
        if last is not None and last[0] is held and last[1] == tool and \
                last[2] == p.getBasePositionAndOrientation(body, physicsClientId=self.client):
            return
        pos, orn = tool
        if held.com_in_element is None:
            assert held.element.local_bounds is not None
            held.com_in_element = _translation(held.element.local_bounds.center)
        place_body(self.client, body, matrix_of(pos, orn) @ held.element_in_tool @ held.com_in_element)
        self._followed = (held, tool, p.getBasePositionAndOrientation(body, physicsClientId=self.client))


class WorkerBodies:
    """The workers' capsules: made once, put where the workers are by :meth:`place`."""

    def __init__(self, client: int, specs: Sequence[tuple[WorkerMotion | None, WorkerSpec]]) -> None:
        import pybullet as p

        self.client = client
        out = []
        used: set[str] = set()
        cyl = WORKER_HEIGHT_M - 2 * WORKER_RADIUS_M
        shape = p.createCollisionShape(p.GEOM_CAPSULE, radius=WORKER_RADIUS_M, height=cyl,
                                       physicsClientId=client)
        visual = p.createVisualShape(p.GEOM_CAPSULE, radius=WORKER_RADIUS_M, length=cyl,
                                     rgbaColor=_RGBA_WORKER, physicsClientId=client)
        for m, spec in specs:
            name = slug(spec.label) or "worker"
            base, n = name, 2
            while name in used:
                name = f"{base}-{n}"
                n += 1
            used.add(name)
            body = p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape, baseVisualShapeIndex=visual,
                                     basePosition=[0.0, 0.0, -20.0], physicsClientId=client)
            out.append(WorkerBody(m, int(body), name, spec.label))
        self.bodies: tuple[WorkerBody, ...] = tuple(out)
        self._placed: list[tuple[float, float, float] | None] = [None] * len(out)  # where each was put last
        self._orn: dict[int, Any] = {}  # the quaternion of each body's last heading

    def place(self, poses: Sequence[tuple[float, float, float]], z: float) -> None:
        """Put each capsule at its worker's (x, y, heading), centred at height ``z``."""
        import pybullet as p

        placed = self._placed
        for k, (w, pose) in enumerate(zip(self.bodies, poses, strict=True)):
            last = placed[k]
            if last == pose:  # standing where the body already is (kinematic, mass 0)
                continue
            x, y, heading = pose
            if last is not None and last[2] == heading and math.copysign(1.0, last[2]) == \
                    math.copysign(1.0, heading) and k in self._orn:
                orn = self._orn[k]  # the same heading (bit for bit): the same quaternion
            else:
                orn = p.getQuaternionFromEuler([0.0, 0.0, heading])
                self._orn[k] = orn
            p.resetBasePositionAndOrientation(w.body, [x, y, z], orn, physicsClientId=self.client)
            placed[k] = pose
