"""Robot models (simulation, B3-B5): the shipped URDFs written from the robot table, and a robot
loaded into PyBullet.

:func:`write_urdfs` writes the URDF of every robot of ``sim/robots/robots.toml``
(:mod:`kbplanner.robot.robot_table`) with :func:`~kbplanner.robot.urdf_generation.urdf_text` (checked in
as ``sim/robots/*.urdf``; ``python -m kbplanner.robot.robot_model --write-urdfs``). A
:class:`RobotModel` is a robot loaded into a PyBullet client with its arm joints, tool, lidar and camera
links found by name, named arm poses, base pose setting, link poses and clearances. Inverse kinematics
lives in :mod:`kbplanner.robot.arm_ik`.

Example:
    >>> robot = RobotModel.load("jackal")
    >>> robot.arm_joints, robot.lidar_link >= 0
    ((), True)
    >>> robot.close()
"""

from __future__ import annotations

import logging
import math
import struct
from collections.abc import Sequence
from pathlib import Path

from kbplanner.core.errors import InputFileError
from kbplanner.robot.robot_table import RobotSpec, load_robot_specs, robot_spec, robots_toml
from kbplanner.robot.urdf_generation import (
    ARM_JOINT_NAMES,
    ARM_LINK_NAMES,
    BASE_LINK,
    CAMERA_LINK,
    FLANGE_LINK,
    LIDAR_LINK,
    TOOL_LINK,
    urdf_text,
)

log = logging.getLogger(__name__)
_BOX_SLACK_M = 0.01  # arm_touches_body: link pairs whose bounding boxes are farther apart cannot touch


def write_urdfs(table: Path | None = None, out_dir: Path | None = None) -> list[Path]:
    """Generate the URDF of every robot of ``table`` into ``out_dir`` (default: next to the table)."""
    file = Path(table) if table is not None else robots_toml()
    out = Path(out_dir) if out_dir is not None else file.parent
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for spec in load_robot_specs(file).values():
        path = out / spec.urdf_name
        path.write_text(urdf_text(spec), encoding="utf-8")
        log.info("wrote %s", path)
        written.append(path)
    return written


Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


class RobotModel:
    """A robot loaded into a PyBullet client, with its arm joints and named links found.

    Use :meth:`load`; ``close()`` disconnects the client when the model created it.

    Example:
        >>> robot = RobotModel.load("husky_ur5")
        >>> robot.set_base_pose(1.0, 2.0, 0.0)
        >>> robot.set_named_pose("stow")
        >>> len(robot.arm_joints), robot.tool_link is not None
        (6, True)
        >>> robot.close()
    """

    def __init__(self, spec: RobotSpec, client: int, body: int, owns_client: bool) -> None:
        import pybullet as p

        self.spec = spec
        self.client = client
        self.body = body
        self.floor_z = 0.0  # elevation of the floor the base stands on (B4/B5: the task storey's)
        self._owns_client = owns_client
        self.joints: dict[str, int] = {}
        self.links: dict[str, int] = {BASE_LINK: -1}
        self.movable: list[int] = []
        self.lower: dict[int, float] = {}
        self.upper: dict[int, float] = {}
        for j in range(p.getNumJoints(body, physicsClientId=client)):
            info = p.getJointInfo(body, j, physicsClientId=client)
            self.joints[info[1].decode()] = j
            self.links[info[12].decode()] = j
            if info[2] != p.JOINT_FIXED:
                self.movable.append(j)
                lo, hi = float(info[8]), float(info[9])
                if hi < lo:  # continuous joints report (0, -1)
                    lo, hi = -math.pi, math.pi
                self.lower[j], self.upper[j] = lo, hi
        self.arm_joints: tuple[int, ...] = (
            tuple(self.joints[n] for n in ARM_JOINT_NAMES) if spec.arm is not None else ()
        )
        self.tool_link: int | None = self.links.get(TOOL_LINK)
        self.flange_link: int | None = self.links.get(FLANGE_LINK)
        self.lidar_link: int = self.links[LIDAR_LINK]
        self.camera_link: int = self.links[CAMERA_LINK]
        self.arm_links: tuple[int, ...] = tuple(
            self.links[n] for n in (*ARM_LINK_NAMES, "gripper_link") if n in self.links
        )
        # PyBullet places a body by its root's centre of mass; keep the offset to the link frame.
        dyn = p.getDynamicsInfo(body, -1, physicsClientId=client)
        self._com_pos: Vec3 = tuple(float(v) for v in dyn[3])  # type: ignore[assignment]
        self._com_orn: Quat = tuple(float(v) for v in dyn[4])  # type: ignore[assignment]
        # the link frame in the centre of mass frame (constant), and the last base pose read: the raw
        # pose's bytes (signed zeros told apart) and the base frame's (x, y, yaw) computed from it
        self._inv_com = p.invertTransform(self._com_pos, self._com_orn)
        self._base_read: tuple[bytes, tuple[float, float, float]] | None = None
        # kinematic: nothing but set_base_pose moves the base (no physics step in the client, e.g. the
        # simulation environment, which calls forget_base() when it steps): the last pose read stands
        # until the next set_base_pose, without asking PyBullet again
        self.kinematic = False
        self._base_fresh = False

    @classmethod
    def load(
        cls,
        spec: RobotSpec | str,
        client: int | None = None,
        urdf: Path | None = None,
        pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> RobotModel:
        """Load a robot (a spec or a name from the shipped table) into ``client`` (default: a new DIRECT one).

        Raises:
            InputFileError: the URDF is missing or PyBullet cannot parse it.
        """
        import pybullet as p

        if isinstance(spec, str):
            spec = robot_spec(spec)
        path = Path(urdf) if urdf is not None else spec.urdf_path()
        if not path.is_file():
            raise InputFileError("robot URDF not found", file=path, element=spec.name,
                                 fix="regenerate it with `python sim/tools/make_urdf.py`")
        owns = client is None
        cid = p.connect(p.DIRECT) if client is None else client
        try:
            body = p.loadURDF(str(path), basePosition=(pose[0], pose[1], 0.0),
                              baseOrientation=p.getQuaternionFromEuler((0.0, 0.0, pose[2])),
                              flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
        except p.error as exc:
            if owns:
                p.disconnect(cid)
            raise InputFileError(f"PyBullet cannot load the URDF: {exc}", file=path, element=spec.name,
                                 fix="regenerate it with `python sim/tools/make_urdf.py`") from exc
        model = cls(spec, cid, body, owns)
        if "stow" in spec.poses:
            model.set_named_pose("stow")
        return model

    def close(self) -> None:
        """Remove the robot, and disconnect the client if this model created it (idempotent)."""
        import pybullet as p

        if self.client < 0:
            return
        if self._owns_client:
            p.disconnect(self.client)
        else:
            p.removeBody(self.body, physicsClientId=self.client)
        self.client = -1

    # --- base -------------------------------------------------------------------------------

    def set_base_pose(self, x: float, y: float, yaw: float, z: float | None = None) -> None:
        """Place the base frame (on the ground below the chassis centre) at (x, y, z) facing ``yaw``.

        ``z`` defaults to :attr:`floor_z`, the floor the robot works on (a storey's elevation).
        """
        self._reset_base(x, y, yaw, self.floor_z if z is None else z)

    def _reset_base(self, x: float, y: float, yaw: float, z: float) -> None:
        """Put the base frame at (x, y, z) facing ``yaw`` in PyBullet now."""
        import pybullet as p

        pos, orn = p.multiplyTransforms((x, y, z), p.getQuaternionFromEuler((0.0, 0.0, yaw)),
                                        self._com_pos, self._com_orn)
        p.resetBasePositionAndOrientation(self.body, pos, orn, physicsClientId=self.client)
        self._base_fresh = False

    def place_pending(self) -> None:
        """Put the robot in PyBullet where it was last set, before PyBullet is asked about it (a
        distance, a ray test, an image, a link's pose, inverse kinematics). This model places it when
        set: nothing to do (the simulation environment's robot defers the placing, see
        :class:`~kbplanner.simulation.sim_bodies.SimRobot`)."""

    def forget_base(self) -> None:
        """The base may have moved other than by :meth:`set_base_pose` (physics stepped): read it again."""
        self._base_fresh = False

    def base_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the base frame in the site frame.

        (Computed again only when PyBullet's pose of the body differs, bit for bit, from the last one
        read: the same numbers, a fraction of the calls; for a :attr:`kinematic` robot not even read
        again until the base is set.)"""
        import pybullet as p

        if self._base_fresh and self._base_read is not None:
            return self._base_read[1]
        self.place_pending()
        com_pos, com_orn = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        return self._base_from_com(com_pos, com_orn)

    def _base_from_com(self, com_pos: Sequence[float],
                       com_orn: Sequence[float]) -> tuple[float, float, float]:
        """(x, y, yaw) of the base frame for PyBullet's pose of the body (its centre of mass frame)."""
        import pybullet as p

        key = struct.pack("7d", *com_pos, *com_orn)
        if self._base_read is not None and self._base_read[0] == key:
            self._base_fresh = self.kinematic
            return self._base_read[1]
        pos, orn = p.multiplyTransforms(com_pos, com_orn, self._inv_com[0], self._inv_com[1])
        orn = (float(orn[0]), float(orn[1]), float(orn[2]), float(orn[3]))
        yaw = p.getEulerFromQuaternion(orn)[2]
        out = (float(pos[0]), float(pos[1]), float(yaw))
        self._base_read = (key, out)
        self._base_fresh = self.kinematic
        return out

    # --- arm ----------------------------------------------------------------------------------

    def _need_arm(self) -> None:
        if not self.arm_joints:
            raise InputFileError("this robot has no arm", file=robots_toml(), element=self.spec.name,
                                 fix="choose a robot with an arm (e.g. husky_ur5)")

    def set_arm(self, q: Sequence[float]) -> None:
        """Set the six arm joint angles (radians) without simulating.

        One ``resetJointStatesMultiDof`` call for the six joints: the same joint states, link poses and
        distances as a ``resetJointState`` per joint (velocities zero), in a quarter of the time
        (``tests/test_robot_model.py`` compares them).
        """
        self._check_arm(q)
        self._reset_arm(q)

    def _check_arm(self, q: Sequence[float]) -> None:
        self._need_arm()
        if len(q) != len(self.arm_joints):
            raise InputFileError(f"expected {len(self.arm_joints)} joint angles, got {len(q)}",
                                 element=self.spec.name, fix="give one angle per arm joint")

    def _reset_arm(self, q: Sequence[float]) -> None:
        """Set the arm joints in PyBullet now."""
        import pybullet as p

        p.resetJointStatesMultiDof(self.body, self.arm_joints, [[float(v)] for v in q], [[0.0]] * len(q),
                                   physicsClientId=self.client)

    def arm_positions(self) -> tuple[float, ...]:
        """The six arm joint angles (radians)."""
        import pybullet as p

        if not self.arm_joints:
            return ()
        self.place_pending()
        return tuple(float(st[0]) for st in p.getJointStates(self.body, self.arm_joints,
                                                               physicsClientId=self.client))

    def named_pose(self, name: str) -> tuple[float, ...]:
        """Joint angles of a named arm pose of the robot table (``stow``, ``carry``, ``pre_grasp``, ...)."""
        self._need_arm()
        if name not in self.spec.poses:
            raise InputFileError(f"unknown arm pose '{name}'", file=robots_toml(),
                                 element=f"robot.{self.spec.name}.poses",
                                 fix=f"use one of {sorted(self.spec.poses)} or add it to the table")
        return self.spec.poses[name]

    def set_named_pose(self, name: str) -> None:
        """Put the arm in a named pose."""
        self.set_arm(self.named_pose(name))

    def arm_limits(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """(lower, upper) joint limits of the arm joints."""
        return (tuple(self.lower[j] for j in self.arm_joints), tuple(self.upper[j] for j in self.arm_joints))

    # --- links --------------------------------------------------------------------------------

    def link_pose(self, link: int) -> tuple[Vec3, Quat]:
        """World position and quaternion (x, y, z, w) of a link frame (``-1``: the base)."""
        import pybullet as p

        self.place_pending()
        if link == -1:
            com_pos, com_orn = p.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
            inv_pos, inv_orn = p.invertTransform(self._com_pos, self._com_orn)
            pos, orn = p.multiplyTransforms(com_pos, com_orn, inv_pos, inv_orn)
        else:
            state = p.getLinkState(self.body, link, computeForwardKinematics=True,
                                   physicsClientId=self.client)
            pos, orn = state[4], state[5]
        return ((float(pos[0]), float(pos[1]), float(pos[2])),
                (float(orn[0]), float(orn[1]), float(orn[2]), float(orn[3])))

    def tool_pose(self) -> tuple[Vec3, Quat]:
        """World pose of the tool centre point."""
        self._need_arm()
        assert self.tool_link is not None
        return self.link_pose(self.tool_link)

    def min_distance(self, links_a: Sequence[int], links_b: Sequence[int], max_m: float = 1.0) -> float:
        """Smallest distance (m) between two sets of this robot's links (negative: penetration)."""
        import pybullet as p

        self.place_pending()
        best = max_m
        for a in links_a:
            for b in links_b:
                for c in p.getClosestPoints(self.body, self.body, max_m, a, b, physicsClientId=self.client):
                    best = min(best, float(c[8]))
        return best

    def _body_links(self) -> list[int]:
        """Base, plate, lidar, camera and wheels: what the arm must not touch."""
        body_links = [-1, self.links["top_plate_link"], self.lidar_link, self.camera_link]
        return body_links + [self.links[n] for n in self.links if n.endswith("_wheel_link")]

    def arm_clearance(self) -> float:
        """Smallest distance (m) from the arm (from the upper arm on) to base, plate, lidar and camera."""
        if not self.arm_joints:
            return math.inf
        return self.min_distance(self.arm_links[1:], self._body_links())

    def arm_touches_body(self) -> bool:
        """``arm_clearance() < 0``, the same answer, cheaper.

        Only link pairs whose bounding boxes (PyBullet's, with the collision margin) come within 1 cm
        are asked (shapes that overlap have overlapping boxes), with the same query as
        :meth:`arm_clearance`, and the first overlap answers.
        """
        import pybullet as p

        if not self.arm_joints:
            return False
        self.place_pending()
        body_links = self._body_links()
        boxes = [p.getAABB(self.body, b, physicsClientId=self.client) for b in body_links]
        for a in self.arm_links[1:]:
            lo_a, hi_a = p.getAABB(self.body, a, physicsClientId=self.client)
            for b, (lo_b, hi_b) in zip(body_links, boxes, strict=True):
                slack = _BOX_SLACK_M
                if any(lo_a[k] > hi_b[k] + slack or lo_b[k] > hi_a[k] + slack for k in range(3)):
                    continue
                for c in p.getClosestPoints(self.body, self.body, 1.0, a, b, physicsClientId=self.client):
                    if float(c[8]) < 0.0:
                        return True
        return False


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m kbplanner.robot.robot_model --write-urdfs``: regenerate the shipped URDFs."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m kbplanner.robot.robot_model")
    parser.add_argument("--write-urdfs", action="store_true", help="regenerate sim/robots/*.urdf")
    args = parser.parse_args(argv)
    if args.write_urdfs:
        write_urdfs()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
