"""B5 simulation environment: the world at a date, the robot and the workers in one PyBullet client.

Takes a :class:`~kbplanner.world.world_types.World` (A6), the robot's name in the robot table, worker motions
(:func:`kbplanner.simulation.workers.plan_workers`) and the storey's occupancy grid; gives a Gymnasium-style
environment: :meth:`SimEnv.reset` (connect, load, place the robot at its start), :meth:`SimEnv.step`
(advance the simulated clock by one control period: workers move along their motions, a held
element follows the tool), an idempotent :meth:`SimEnv.close`. Skills
(:mod:`kbplanner.simulation.skills`) move
the robot kinematically between steps: base pose set directly, arm joints reset, no motor models;
physics is not stepped except by :meth:`SimEnv.settle` where it matters.

- The client is ``p.DIRECT``; ``gui=True`` uses ``p.GUI`` when a display exists (``DISPLAY`` set),
  else it logs a warning and stays headless.
- The world: :func:`kbplanner.simulation.sim_world.load_world` (static elements merged, task elements as
  bodies at their storage, solid site objects), visual shapes only when images are wanted.
- Workers: kinematic capsules (radius 0.25 m, 1.7 m tall, mass 0), either reactive
  (:class:`kbplanner.simulation.crowd.Crowd`, stepped each period with the robot's hazard footprint
  from :attr:`SimEnv.hazard`) or scripted (``WorkerMotion.position(t)``, e.g. for tests).
- Floors: workers walk on the ground (``World.ground_z``), the robot works on the task storey
  (:attr:`SimEnv.robot_floor_z`). When the two are more than :data:`FLOOR_GAP_M` apart
  (:attr:`SimEnv.workers_on_robot_floor` false: the robot works upstairs, or below ground), the
  workers are out of the robot's hazard scope: the crowd steps them without the robot's footprint
  (no yielding, no making way), and the separation monitor and the contact check pass them by. They
  then walk on the ground storey's map (``walk_grid``, :func:`kbplanner.simulation.floors.walk_grid`),
  not on the robot's.
- Holding: :meth:`SimEnv.attach` ties the element to the tool link with a ``p.JOINT_FIXED``
  constraint at the grasp and filters collisions between the element and every robot link off; as
  the robot moves kinematically, :meth:`SimEnv.step` also puts the element where the constraint
  holds it (tool frame times the inverse grasp). :meth:`SimEnv.detach` removes the constraint and
  :meth:`SimEnv.fix` makes the element static where it is (it is fixed to the structure).
- Bodies placed when looked at (:mod:`kbplanner.simulation.sim_bodies`): the worker capsules and the
  held element are put where they are (the crowd's positions, the grasp on the tool) only before
  something looks at them - a lidar scan or a ray test (:meth:`SimEnv.sync`), a key frame, a task
  body's frame, a physics step -; nothing else in the loop reads them from PyBullet.
- The navigation grid: the storey's occupancy grid plus every element installed so far.

Example:
    >>> env = SimEnv(world, "husky_ur16e", grid=grid)  # doctest: +SKIP
    >>> env.reset(seed=7)  # doctest: +SKIP
    >>> env.step(); env.t  # doctest: +SKIP
    0.1
    >>> env.close()  # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
from collections.abc import Callable, Sequence

import numpy as np

from kbplanner.core.errors import KbplannerError
from kbplanner.planning.base_poses import element_polygon, mark_polygon
from kbplanner.planning.carry import Matrix
from kbplanner.robot.robot_model import RobotModel
from kbplanner.simulation.crowd import Crowd
from kbplanner.simulation.floors import FLOOR_GAP_M, robot_floor_z
from kbplanner.simulation.held_pose import matrix_of, quat_of
from kbplanner.simulation.sim_bodies import (
    WORKER_HEIGHT_M,
    Held,
    HeldPlacer,
    SimRobot,
    WorkerBodies,
    WorkerBody,
    place_body,
)
from kbplanner.simulation.sim_world import SimWorld, element_frame, load_world
from kbplanner.simulation.social_force import Obstacle
from kbplanner.simulation.workers import WORKER_RADIUS_M, WorkerMotion, WorkerSpec
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import World, WorldElement

log = logging.getLogger(__name__)

__all__ = ["FLOOR_GAP_M", "WORKER_HEIGHT_M", "WORKER_RADIUS_M", "Held", "SimEnv", "WorkerBody",
           "angle_between"]


class SimEnv:
    """The simulation environment (see module docstring)."""

    def __init__(
        self,
        world: World,
        robot: str,
        *,
        grid: OccupancyGrid,
        walk_grid: OccupancyGrid | None = None,
        workers: Sequence[WorkerMotion] = (),
        reactive: Sequence[WorkerSpec] = (),
        control_hz: float = 10.0,
        gui: bool = False,
        visuals: bool = False,
    ) -> None:
        if control_hz <= 0:
            raise KbplannerError(f"control rate must be positive, got {control_hz}", element="control_hz",
                                 fix="give the control rate in Hz, e.g. 10")
        self.world = world
        self.robot_name = robot
        self.base_grid = grid
        self.grid = grid
        self.walk_grid = walk_grid if walk_grid is not None else grid  # where the reactive workers walk
        self.worker_motions = tuple(workers)
        self.reactive = tuple(reactive)
        self.crowd: Crowd | None = None
        # the robot's hazard footprint now (pose, robot-frame rectangles); set by the executor
        self.hazard: Callable[[], Obstacle] | None = None
        self.control_hz = float(control_hz)
        self.gui = gui
        self.visuals = visuals
        self.client = -1
        self.sim: SimWorld | None = None
        self._robot: RobotModel | None = None
        self.workers: tuple[WorkerBody, ...] = ()
        self._bodies: WorkerBodies | None = None  # the workers' capsules
        self._placer = HeldPlacer(-1)  # where the held element goes (placed when looked at)
        self._on_floor: tuple[World, str | None, float, bool] | None = None  # workers_on_robot_floor
        self._nearest: tuple[list[tuple[float, float]], float, float, float] | None = None  # nearest_centre_m
        self._workers_due = False  # the workers moved since their bodies were last placed
        self._xy: tuple[np.ndarray | None, int, np.ndarray] | None = None  # worker_xy(): of what, tick, xy
        self.tick = 0
        self.held: Held | None = None
        self.installed: list[str] = []
        self.seed = 0

    # ---- Gymnasium-style lifecycle --------------------------------------------------------------
    def reset(self, *, seed: int) -> None:
        """(Re)connect and load the world, the robot at its start and the workers; the clock is 0."""
        import pybullet as p

        self.close()
        self.seed = int(seed)
        mode = p.DIRECT
        if self.gui:
            if os.environ.get("DISPLAY"):
                mode = p.GUI
            else:
                log.warning("--gui: no display (DISPLAY is not set); running headless")
        self.client = int(p.connect(mode))
        if mode == p.GUI:
            p.configureDebugVisualizer(p.COV_ENABLE_GUI, 0, physicsClientId=self.client)
        self.sim = load_world(self.world, self.client, visuals=self.visuals or mode == p.GUI)
        robot = SimRobot.load(self.robot_name, client=self.client)
        assert isinstance(robot, SimRobot)
        robot.before_move = self._robot_moves
        self._robot = robot
        self._robot.floor_z = self.robot_floor_z
        self._robot.kinematic = True  # only settle() steps physics here (and tells the robot)
        start = self.world.robot_start
        self._robot.set_base_pose(start.x if start else 0.0, start.y if start else 0.0,
                                  start.yaw if start else 0.0)
        self.crowd = Crowd(self.reactive, self.walk_grid, seed=self.seed, control_hz=self.control_hz) \
            if self.reactive else None
        self._bodies = WorkerBodies(self.client, [(None, s) for s in self.reactive] +
                                    [(m, m.spec) for m in self.worker_motions])
        self.workers = self._bodies.bodies
        self.tick = 0
        self.held = None
        self._placer = HeldPlacer(self.client)
        self.installed = []
        self.grid = self.base_grid
        self._xy = self._nearest = None
        self._move_workers()

    def step(self) -> float:
        """Advance the clock by one control period; move workers and the held element (their bodies
        are placed when looked at, :meth:`sync`). Returns t (s)."""
        self.tick += 1
        if self.crowd is not None:
            hazard = self.hazard if self.workers_on_robot_floor else None
            self.crowd.step(hazard() if hazard is not None else None)
        if self.workers:
            self._workers_due = True
        self.follow()
        return self.t

    def sync(self) -> None:
        """Place the worker bodies and the held element where they are now, before PyBullet is asked
        about them (a scan, a ray test, an image, a physics step, a body's pose); then the robot where
        it was last set (:meth:`~kbplanner.simulation.sim_bodies.SimRobot.place_pending`)."""
        if self._workers_due:
            self._move_workers()
        self._place_held()
        if self._robot is not None:
            self._robot.place_pending()

    def close(self) -> None:
        """Disconnect (idempotent)."""
        import pybullet as p

        if self.client >= 0:
            with contextlib.suppress(p.error):
                p.disconnect(self.client)
        self.client = -1
        self.sim = None
        self._robot = None

    # ---- state ----------------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulated time (s)."""
        return self.tick / self.control_hz

    @property
    def dt(self) -> float:
        """Control period (s)."""
        return 1.0 / self.control_hz

    @property
    def robot(self) -> RobotModel:
        """The robot (after :meth:`reset`)."""
        if self._robot is None:
            raise KbplannerError("the environment is not reset", element="SimEnv", fix="call reset(seed=...)")
        return self._robot

    @property
    def world_bodies(self) -> SimWorld:
        """The loaded world's bodies (after :meth:`reset`)."""
        if self.sim is None:
            raise KbplannerError("the environment is not reset", element="SimEnv", fix="call reset(seed=...)")
        return self.sim

    def base_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the robot base."""
        robot = self._robot
        return robot.base_pose() if robot is not None else self.robot.base_pose()

    @property
    def robot_floor_z(self) -> float:
        """Elevation of the floor the robot works on: the task storey's, else the site's ground."""
        return robot_floor_z(self.world)

    @property
    def workers_on_robot_floor(self) -> bool:
        """Whether the workers' ground is within :data:`FLOOR_GAP_M` of the robot's floor (in its hazard
        scope); else they are on another floor: no yielding, monitoring or contact with the robot.
        (Asked several times per period: kept while the world, its task storey and ground stay.)"""
        w = self.world
        last = self._on_floor
        if last is None or last[0] is not w or last[1] != w.task_storey or last[2] != w.ground_z:
            last = (w, w.task_storey, w.ground_z,
                    abs(self.robot_floor_z - float(w.ground_z)) <= FLOOR_GAP_M)
            self._on_floor = last
        return last[3]

    def set_base_pose(self, x: float, y: float, yaw: float) -> None:
        """Place the robot base (kinematically) on its floor."""
        self.robot.set_base_pose(x, y, yaw)

    def set_arm(self, q: Sequence[float]) -> None:
        """Set the arm joints (kinematically)."""
        self.robot.set_arm(q)

    def tool_frame(self) -> Matrix:
        """The tool frame (site) now."""
        pos, orn = self.robot.tool_pose()
        return matrix_of(pos, orn)

    def element(self, iri: str) -> WorldElement:
        """A task element of the world."""
        for e in self.world.task_elements:
            if e.iri == iri:
                return e
        raise KbplannerError("not a task element of the world", element=iri,
                             fix="use an element of the plan's task that is at a storage")

    def element_frame(self, iri: str) -> Matrix:
        """Where a task element's own frame is now (site)."""
        self._place_held()
        return np.asarray(element_frame(self.world_bodies, self.element(iri)), dtype=np.float64)

    def set_element_frame(self, iri: str, frame: Matrix) -> None:
        """Put a task element's own frame at ``frame`` (site), kinematically."""

        e = self.element(iri)
        assert e.local_bounds is not None
        self._place(self.world_bodies.task_bodies[iri], frame @ _translation(e.local_bounds.center))

    def _place(self, body: int, com: Matrix) -> None:
        """Put a body's centre of mass frame at ``com`` (site), kinematically."""
        place_body(self.client, body, com)

    def worker_poses(self) -> list[tuple[float, float, float]]:
        """(x, y, heading) of every worker now, in :attr:`workers` order."""
        out = self.crowd.positions() if self.crowd is not None else []
        out += [w.motion.position(self.t) for w in self.workers if w.motion is not None]
        return out

    def worker_positions(self) -> list[tuple[str, float, float]]:
        """(slug, x, y) of every worker now."""
        return [(w.slug, x, y) for w, (x, y, _) in zip(self.workers, self.worker_poses(), strict=True)]

    def worker_xy_list(self) -> list[tuple[float, float]]:
        """(x, y) of every worker now, as floats (the numbers of :meth:`worker_xy`)."""
        if self.crowd is not None and not self.worker_motions:
            return self.crowd.xy()
        return [(x, y) for x, y, _ in self.worker_poses()]

    def nearest_centre_m(self, x: float, y: float) -> float:
        """The smallest centre distance (``math.hypot``) of a worker from (x, y); inf with no worker, NaN
        when a distance is not a number (so ``nearest_centre_m(x, y) > r`` is ``all(d > r)``).
        (The robot's checks of one period ask it of the same positions and base centre: worked out once
        while the crowd's positions - the very list - and the point stay.)"""
        xy = self.worker_xy_list()
        last = self._nearest
        if last is not None and last[0] is xy and last[1] == x and last[2] == y:
            return last[3]
        d = math.inf
        for wx, wy in xy:
            h = math.hypot(wx - x, wy - y)
            if not h >= d:  # nearer, or not a number (then "all farther than ..." is false: kept)
                d = h
                if h != h:
                    break
        self._nearest = (xy, x, y, d)
        return d

    def worker_xy(self) -> np.ndarray:
        """(n, 2) positions of every worker now (read only; the same array until a worker moves)."""
        crowd_pos = self.crowd.pos if self.crowd is not None else None
        tick = self.tick if self.worker_motions else -1
        cached = self._xy
        if cached is not None and cached[0] is crowd_pos and cached[1] == tick:
            return cached[2]
        if crowd_pos is not None and not self.worker_motions:  # the crowd's positions (a copy)
            xy = np.array(crowd_pos, dtype=np.float64).reshape(-1, 2)
        else:
            xy = np.array([(x, y) for x, y, _ in self.worker_poses()], dtype=np.float64).reshape(-1, 2)
        xy.flags.writeable = False
        self._xy = (crowd_pos, tick, xy)
        return xy

    # ---- holding ----------------------------------------------------------------------------------
    def attach(self, iri: str) -> Held:
        """Grasp: tie the element to the tool where both are now (``p.JOINT_FIXED``, no collisions)."""
        import pybullet as p

        if self.held is not None:
            raise KbplannerError("the gripper already holds an element", element=self.held.element.iri,
                                 fix="release it first")
        e = self.element(iri)
        assert e.local_bounds is not None
        body = self.world_bodies.task_bodies[iri]
        robot = self.robot
        assert robot.tool_link is not None
        tool = self.tool_frame()
        tie = np.linalg.inv(self.element_frame(iri)) @ tool
        # constraint frames: the tool link's frame (parent) and the body's centre of mass frame (child)
        com_in_tool = np.linalg.inv(tool) @ self.element_frame(iri) @ _translation(e.local_bounds.center)
        cid = p.createConstraint(robot.body, robot.tool_link, body, -1, p.JOINT_FIXED, [0.0, 0.0, 0.0],
                                 parentFramePosition=com_in_tool[:3, 3].tolist(),
                                 childFramePosition=[0.0, 0.0, 0.0],
                                 parentFrameOrientation=quat_of(com_in_tool),
                                 physicsClientId=self.client)
        p.changeConstraint(cid, maxForce=10_000.0, physicsClientId=self.client)
        for link in [-1, *range(p.getNumJoints(robot.body, physicsClientId=self.client))]:
            p.setCollisionFilterPair(robot.body, body, link, -1, 0, physicsClientId=self.client)
        self.held = Held(e, body, int(cid), np.asarray(tie, dtype=np.float64))
        return self.held

    def follow(self) -> None:
        """The held element follows the tool (after a kinematic robot motion): placed where the grasp
        holds it now when something looks at it (:meth:`sync`), even if the robot has moved since
        (:class:`~kbplanner.simulation.sim_bodies.HeldPlacer`)."""
        if self.held is not None:
            self._placer.follow()

    def _robot_moves(self) -> None:
        """The robot is about to move: the held element still to be placed keeps the robot's pose."""
        self._placer.robot_moves(self.held, self.robot)

    def _place_held(self) -> None:
        """Put the held element where the grasp held it when :meth:`follow` was last asked."""
        self._placer.place(self.held, self.robot)

    def detach(self) -> WorldElement:
        """Release: remove the constraint (collisions with the robot stay filtered until fixed)."""
        import pybullet as p

        if self.held is None:
            raise KbplannerError("the gripper holds nothing", element="SimEnv.detach", fix="grasp first")
        self._place_held()
        held = self.held
        p.removeConstraint(held.constraint, physicsClientId=self.client)
        self.held = None
        return held.element

    def fix(self, iri: str) -> None:
        """Fix a released element where it is: a static body, part of the structure; the grid marks it."""
        import pybullet as p

        body = self.world_bodies.task_bodies[iri]
        p.changeDynamics(body, -1, mass=0.0, physicsClientId=self.client)
        p.resetBaseVelocity(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=self.client)
        e = self.element(iri)
        assert e.local_bounds is not None
        self.grid = mark_polygon(self.grid, element_polygon(e.local_bounds, self.element_frame(iri)))
        self.installed.append(iri)

    def put_back(self, iri: str) -> None:
        """Return an element to its storage pose (after a failed step; not simulated)."""
        import pybullet as p

        if self.held is not None and self.held.element.iri == iri:
            self.detach()
        e = self.element(iri)
        assert e.pose is not None
        frame = _pose_frame(e)
        self.set_element_frame(iri, frame)
        body = self.world_bodies.task_bodies[iri]
        robot = self.robot
        for link in [-1, *range(p.getNumJoints(robot.body, physicsClientId=self.client))]:
            p.setCollisionFilterPair(robot.body, body, link, -1, 1, physicsClientId=self.client)

    def settle(self, seconds: float, time_step_s: float = 1.0 / 240.0) -> float:
        """Step physics for ``seconds`` (the clock does not move); largest displacement (m) of a task body."""
        import pybullet as p

        self.sync()
        bodies = self.world_bodies.task_bodies
        before = {i: np.array(p.getBasePositionAndOrientation(b, physicsClientId=self.client)[0])
                  for i, b in bodies.items()}
        p.setTimeStep(time_step_s, physicsClientId=self.client)
        for _ in range(max(1, round(seconds / time_step_s))):
            p.stepSimulation(physicsClientId=self.client)
        self.robot.forget_base()
        moved = 0.0
        for i, b in bodies.items():
            now = np.array(p.getBasePositionAndOrientation(b, physicsClientId=self.client)[0])
            moved = max(moved, float(np.linalg.norm(now - before[i])))
        return moved

    # ---- workers ---------------------------------------------------------------------------------
    def _move_workers(self) -> None:
        """Put the worker capsules where the workers are now."""
        self._workers_due = False
        if self._bodies is not None:
            self._bodies.place(self.worker_poses(), self.world.ground_z + WORKER_HEIGHT_M / 2)


def _translation(v: Sequence[float]) -> Matrix:
    m = np.eye(4)
    m[:3, 3] = list(v)
    return m


def _pose_frame(e: WorldElement) -> Matrix:
    from kbplanner.planning.carry import transform

    assert e.pose is not None
    return transform(e.pose.x, e.pose.y, e.pose.z, e.pose.roll, e.pose.pitch, e.pose.yaw)


def angle_between(a: Matrix, b: Matrix) -> float:
    """Angle (rad) of the rotation between two frames."""
    rel = a[:3, :3].T @ b[:3, :3]
    c = (float(np.trace(rel)) - 1.0) / 2.0
    return math.acos(max(-1.0, min(1.0, c)))
