"""Grasp and carry geometry (B4 arm poses, B5 NV-2): how a held element sits on the robot.

Takes a robot loaded in PyBullet (:class:`~kbplanner.robot.robot_model.RobotModel`), an element's box in
its own frame (``local_bounds`` of :class:`~kbplanner.world.world_types.WorldElement`) and where it
lies; returns
:class:`Grasp` candidates (the tool frame in the element's frame) and the two carry modes of the
paper (section 4.4.3, Figure 14) as :class:`CarryGeometry`: the carry arm poses and, from forward
kinematics, the element's footprint in the robot frame as :class:`~kbplanner.world.footprint.Footprint`
objects for :func:`kbplanner.simulation.carry_paths.plan_with_carry_modes`.

Geometry (robot frame: x forward, y left, z up; element axes sorted by their extent: long, middle,
thin):

- **Grasp.** The tool centre point goes to the model's grasp point (its position, in the element's
  frame). The tool's z axis (pointing out of the flange) goes into the element along its *thin*
  axis, onto the face that is up where the element lies, so the gripper comes from above; the
  tool's x axis lies along the element's *long* axis. When the straight-down approach is out of
  reach (the top of a high stack), the approach is tilted about the long axis, towards the robot,
  in 15 degree steps up to 60 degrees. The grasp is rigid: the element's frame is
  ``T_tool @ inverse(tool_in_element)`` from then on.
- **Normal carry** (NV-2 pose, "frame over its head"): the element flat (thin axis vertical) above
  the robot, its long side across the heading (along y), the gripper under it.
- **Narrow carry** ("on its side", to pass a door): the element's thin axis across the heading
  (along y), its long side along the heading (along x), the middle side vertical.

Both are found by inverse kinematics from tool positions near the robot's named ``carry`` pose (its
table) and kept only when the element clears the robot (base, sensors and arm, except the wrist
and gripper that hold it) by :data:`MIN_CLEARANCE_M`. A carry mode's footprint is the robot's base
rectangle plus the smallest rectangle around the element's eight box corners projected on the
floor (forward kinematics of the chosen joint angles, so what is planned is what is simulated).

Example:
    >>> from kbplanner.robot.robot_model import RobotModel
    >>> from kbplanner.world.build import Bounds
    >>> robot = RobotModel.load("husky_ur16e")
    >>> box = Bounds(-0.36, -0.045, 0.0, 0.36, 0.045, 2.4)    # a 0.72 x 0.09 x 2.4 m frame
    >>> grasp = straight_grasp(box, transform(0, 0, 0.2, math.pi / 2, 0, 0), (0.0, 0.0, 1.2))
    >>> geo = carry_modes(robot, box, grasp.tool_in_element)
    >>> round(geo.normal.rect.width, 1), round(geo.narrow.rect.width, 2)  # across the heading
    (2.4, 0.09)
    >>> robot.close()
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
import shapely
from scipy.spatial.transform import Rotation

from kbplanner.planning.rotation_numbers import quat_of_matrix, rpy_of_matrix
from kbplanner.robot.arm_ik_matrices import cross3
from kbplanner.robot.robot_model import RobotModel
from kbplanner.world.footprint import Footprint, Rect
from kbplanner.world.world_types import Bounds

if TYPE_CHECKING:  # the IK is imported by carry_modes (B4), not by the simulation's carrying
    from kbplanner.robot.arm_ik import IkMethod

log = logging.getLogger(__name__)

Matrix = npt.NDArray[np.float64]
Vec3 = tuple[float, float, float]

NORMAL = "normal"
NARROW = "narrow"
MODES = (NORMAL, NARROW)
MIN_CLEARANCE_M = 0.01
TILTS_DEG = (0.0, 15.0, 30.0, 45.0, 60.0)
HOLDING_LINKS = ("wrist_3_link", "tool0", "gripper_link", "tool_link")


# --------------------------------------------------------------------------------------------
# Small transform helpers (4x4 homogeneous matrices; rpy = extrinsic x, y, z like PyBullet)
# --------------------------------------------------------------------------------------------


def transform(x: float, y: float, z: float, roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0
              ) -> Matrix:
    """The 4x4 transform of a pose (R = Rz(yaw) Ry(pitch) Rx(roll), then the translation)."""
    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("xyz", [roll, pitch, yaw]).as_matrix()
    m[:3, 3] = [x, y, z]
    return m


def pose_of(m: Matrix) -> tuple[float, float, float, float, float, float]:
    """(x, y, z, roll, pitch, yaw) of a 4x4 transform."""
    r, p, y = rpy_of(m)
    return (float(m[0, 3]), float(m[1, 3]), float(m[2, 3]), r, p, y)


def rpy_of(m: Matrix) -> Vec3:
    """roll, pitch, yaw of a rotation (3x3) or transform (4x4).

    At pitch +-90 deg (gimbal lock) roll and yaw are not unique; SciPy then sets the third angle to 0,
    which gives the same rotation, so its warning is silenced.
    """
    return rpy_of_matrix(m)  # SciPy's numbers without its dispatch (planning/rotation_numbers.py)


def from_pos_quat(pos: Sequence[float], quat: Sequence[float]) -> Matrix:
    """4x4 transform from a position and a PyBullet quaternion (x, y, z, w)."""
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(list(quat)).as_matrix()
    m[:3, 3] = list(pos)
    return m


def quat_of(m: Matrix) -> tuple[float, float, float, float]:
    """PyBullet quaternion (x, y, z, w) of a transform (SciPy's ``Rotation.from_matrix`` numbers)."""
    return quat_of_matrix(m)


def base_transform(x: float, y: float, yaw: float, z: float = 0.0) -> Matrix:
    """The robot base frame on the floor (at elevation ``z``)."""
    return transform(x, y, z, 0.0, 0.0, yaw)


def rotation_error_rad(a: Matrix, b: Matrix) -> float:
    """Angle of the rotation between two frames."""
    rel = a[:3, :3].T @ b[:3, :3]
    return float(np.linalg.norm(Rotation.from_matrix(rel).as_rotvec()))


def element_axes(bounds: Bounds) -> tuple[int, int, int]:
    """Indices (0 = x, 1 = y, 2 = z) of the element's long, middle and thin local axes."""
    size = bounds.size
    order = sorted(range(3), key=lambda i: (-size[i], i))
    return (order[0], order[1], order[2])


def _unit(i: int) -> npt.NDArray[np.float64]:
    v = np.zeros(3)
    v[i] = 1.0
    return v


def _frame(x_axis: npt.NDArray[np.float64], z_axis: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    x = x_axis / np.linalg.norm(x_axis)
    z = z_axis - np.dot(z_axis, x) * x
    z = z / np.linalg.norm(z)
    return np.column_stack([x, cross3(z, x), z])


# --------------------------------------------------------------------------------------------
# Grasp
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Grasp:
    """A way to hold an element: the tool frame in the element's frame, and how it was chosen."""

    tool_in_element: Matrix
    tilt_deg: float
    flip_x: bool
    label: str

    def tool_at(self, element_frame: Matrix) -> Matrix:
        """The tool frame (site) when the element's frame is at ``element_frame``."""
        return np.asarray(element_frame @ self.tool_in_element, dtype=np.float64)

    def element_at(self, tool_frame: Matrix) -> Matrix:
        """The element's frame (site) when the tool is at ``tool_frame``."""
        return np.asarray(tool_frame @ np.linalg.inv(self.tool_in_element), dtype=np.float64)


def grasp_candidates(
    bounds: Bounds,
    element_frame: Matrix,
    grasp_point: Vec3,
    towards_robot_xy: tuple[float, float] | None = None,
    tilts_deg: Sequence[float] = TILTS_DEG,
) -> list[Grasp]:
    """Grasps of an element lying at ``element_frame`` (site), in the order to try them.

    For each tilt (smallest first) the two tool x directions (along the long axis, both ways). The
    tilt turns the approach about the element's long axis so that the tool leans away from the
    robot (its wrist comes towards the robot, whose direction from the grasp point is
    ``towards_robot_xy``); without a direction only the straight approach is given.
    """
    long_i, _mid_i, thin_i = element_axes(bounds)
    rot = element_frame[:3, :3]
    thin_w = rot[:, thin_i]
    up_sign = 1.0 if thin_w[2] >= 0 else -1.0
    z0 = -up_sign * thin_w  # into the upper face
    long_w = rot[:, long_i]
    point_w = (element_frame @ np.array([*grasp_point, 1.0]))[:3]
    out: list[Grasp] = []
    for tilt in tilts_deg:
        if tilt and towards_robot_xy is None:
            continue
        z = z0
        if tilt:
            cands = [Rotation.from_rotvec(long_w * s * math.radians(tilt)).as_matrix() @ z0
                     for s in (1.0, -1.0)]
            tx, ty = towards_robot_xy if towards_robot_xy is not None else (0.0, 0.0)
            # Lean away from the robot: the tool's horizontal direction opposite to the robot.
            z = min(cands, key=lambda c: float(c[0] * tx + c[1] * ty))
        for flip in (False, True):
            r = _frame(-long_w if flip else long_w, z)
            tool_w = np.eye(4)
            tool_w[:3, :3] = r
            tool_w[:3, 3] = point_w
            tie = np.linalg.inv(element_frame) @ tool_w
            label = ("straight down onto the upper face" if not tilt
                     else f"onto the upper face, tilted {tilt:g} deg towards the robot")
            out.append(Grasp(np.asarray(tie, dtype=np.float64), float(tilt), flip, label))
    return out


def straight_grasp(bounds: Bounds, element_frame: Matrix, grasp_point: Vec3) -> Grasp:
    """The straight-down grasp of an element lying at ``element_frame`` (first candidate)."""
    return grasp_candidates(bounds, element_frame, grasp_point, None, (0.0,))[0]


# --------------------------------------------------------------------------------------------
# Carry modes
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class CarryMode:
    """One way of carrying: arm joint angles, the element's frame in the robot frame, its footprint."""

    name: str
    joints: tuple[float, ...]
    element_in_base: Matrix
    rect: Rect
    clearance_m: float

    def to_dict(self) -> dict[str, object]:
        """JSON-ready: joints, the element rectangle in the robot frame, clearance."""
        return {"mode": self.name, "joints": [round(v, 6) for v in self.joints],
                "rect": rect_dict(self.rect), "clearance_m": round(self.clearance_m, 4)}


@dataclass(frozen=True, eq=False)
class CarryGeometry:
    """The base footprint and both carry modes of one held element."""

    base: Footprint
    normal: CarryMode
    narrow: CarryMode

    def mode(self, name: str) -> CarryMode:
        """The mode called ``name`` (``"normal"`` or ``"narrow"``)."""
        return self.narrow if name == NARROW else self.normal

    def footprint(self, name: str) -> Footprint:
        """The robot plus the element carried in mode ``name``."""
        m = self.mode(name)
        return self.base.with_rect(m.rect, name=f"{self.base.name} + element carried {m.name}")


def rect_dict(r: Rect) -> dict[str, float]:
    """A rectangle as JSON (robot frame, metres, radians)."""
    return {"cx": round(r.cx, 4), "cy": round(r.cy, 4), "length": round(r.length, 4),
            "width": round(r.width, 4), "yaw": round(r.yaw, 4)}


def footprint_rect(element_in_base: Matrix, bounds: Bounds) -> Rect:
    """The smallest rectangle around the element's box corners projected on the floor (robot frame).

    ``length`` is the side nearer the robot's x axis; values rounded to 0.1 mm (stable files).
    """
    corners = np.c_[bounds.corners(), np.ones(8)] @ element_in_base.T
    hull = shapely.MultiPoint(corners[:, :2]).convex_hull
    if hull.geom_type != "Polygon":  # degenerate: a vertical line or a point
        hull = hull.buffer(0.005, cap_style="square")
    rect = shapely.minimum_rotated_rectangle(hull)
    pts = np.asarray(rect.exterior.coords)[:4]
    e1, e2 = pts[1] - pts[0], pts[2] - pts[1]
    a, b = (e1, e2) if abs(e1[0]) >= abs(e2[0]) else (e2, e1)  # a: the side more along x
    yaw = math.atan2(a[1], a[0])
    if yaw > math.pi / 2:
        yaw -= math.pi
    elif yaw <= -math.pi / 2:
        yaw += math.pi
    c = pts.mean(axis=0)
    return Rect(round(float(c[0]), 4), round(float(c[1]), 4), round(float(np.linalg.norm(a)), 4),
                round(float(np.linalg.norm(b)), 4), round(yaw, 4) + 0.0)


def element_in_base(robot: RobotModel, joints: Sequence[float], tool_in_element: Matrix) -> Matrix:
    """Forward kinematics: the held element's frame in the robot's base frame for arm ``joints``."""
    saved = robot.arm_positions()
    try:
        robot.set_arm(joints)
        pos, orn = robot.tool_pose()
        bx, by, byaw = robot.base_pose()
    finally:
        robot.set_arm(saved)
    tool_w = from_pos_quat(pos, orn)
    base_w = base_transform(bx, by, byaw, robot.floor_z)
    return np.asarray(np.linalg.inv(base_w) @ tool_w @ np.linalg.inv(tool_in_element), dtype=np.float64)


class ElementProbe:
    """A collision box of the held element in the robot's client, to measure its clearance."""

    def __init__(self, robot: RobotModel, bounds: Bounds) -> None:
        import pybullet as p

        self.robot = robot
        self.bounds = bounds
        half = [max(s / 2, 1e-4) for s in bounds.size]
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half,
                                       collisionFramePosition=list(bounds.center),
                                       physicsClientId=robot.client)
        self.body = int(p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape,
                                          basePosition=[0.0, 0.0, -50.0], physicsClientId=robot.client))
        holding = {robot.links[n] for n in HOLDING_LINKS if n in robot.links}
        self.links = sorted(set(robot.links.values()) - holding)

    def place(self, frame: Matrix) -> None:
        """Put the probe's element frame at ``frame`` (site)."""
        import pybullet as p

        p.resetBasePositionAndOrientation(self.body, frame[:3, 3].tolist(), quat_of(frame),
                                          physicsClientId=self.robot.client)

    def clearance(self, max_m: float = 0.5) -> float:
        """Smallest distance (m) from the element to the robot (without the holding links)."""
        import pybullet as p

        best = max_m
        self.robot.place_pending()
        for link in self.links:
            for c in p.getClosestPoints(self.body, self.robot.body, max_m, -1, link,
                                        physicsClientId=self.robot.client):
                best = min(best, float(c[8]))
        return best

    def close(self) -> None:
        """Remove the probe body."""
        import pybullet as p

        p.removeBody(self.body, physicsClientId=self.robot.client)


def _mode_targets(robot: RobotModel, name: str, bounds: Bounds) -> list[tuple[Matrix, Vec3]]:
    """Element orientations (in the base frame) and tool positions (base frame) to try, in order."""
    long_i, mid_i, thin_i = element_axes(bounds)
    ex, ey, ez = np.eye(3)
    # named carry pose: where the robot table holds a load
    carry_q = robot.spec.poses.get("carry")
    anchor = np.array([robot.spec.arm_mount_xyz[0], 0.0, robot.floor_z + 1.25])
    if carry_q is not None:
        saved = robot.arm_positions()
        bx, by, byaw = robot.base_pose()
        robot.set_base_pose(0.0, 0.0, 0.0)
        robot.set_arm(carry_q)
        anchor = np.array(robot.tool_pose()[0])
        robot.set_arm(saved)
        robot.set_base_pose(bx, by, byaw)
    orientations: list[Matrix] = []
    if name == NORMAL:
        axes = [(ey * s_l, ez * s_t) for s_t in (1.0, -1.0) for s_l in (1.0, -1.0)]  # long -> y, thin -> z
    else:
        axes = [(ex * s_l, ey * s_t) for s_t in (1.0, -1.0) for s_l in (1.0, -1.0)]  # long -> x, thin -> y
    for long_dir, thin_dir in axes:
        r = np.zeros((3, 3))
        r[:, long_i] = long_dir
        r[:, thin_i] = thin_dir
        # middle axis completes a right-handed frame
        r[:, mid_i] = cross3(r[:, (mid_i + 1) % 3], r[:, (mid_i + 2) % 3])
        m = np.eye(4)
        m[:3, :3] = r
        orientations.append(m)
    if name == NORMAL:
        offsets = [(0.0, 0.0, 0.0), (0.0, 0.0, 0.1), (0.1, 0.0, 0.0), (-0.1, 0.0, 0.0), (0.0, 0.0, 0.2)]
    else:
        offsets = [(0.0, 0.0, 0.0), (0.1, 0.1, 0.0), (0.1, -0.1, 0.0), (0.1, 0.2, 0.0), (0.1, -0.2, 0.0),
                   (0.0, 0.0, 0.1)]
    out: list[tuple[Matrix, Vec3]] = []
    for d in offsets:
        x, y, z = (float(v) for v in anchor + np.array(d))
        out.extend((o, (x, y, z)) for o in orientations)
    return out


def carry_modes(
    robot: RobotModel,
    bounds: Bounds,
    tool_in_element: Matrix,
    *,
    seeds: Sequence[Sequence[float]] = (),
    refinements: int = 8,
    method: IkMethod = "auto",
) -> CarryGeometry:
    """Both carry modes of an element held with ``tool_in_element`` (see module docstring).

    The robot's base is moved to the origin for the computation and put back. ``seeds`` (e.g. the
    knowledge base's NV-2 arm pose) are tried first by the IK.

    Raises nothing: a mode that cannot be found is returned as a :class:`CarryMode` with an empty
    ``joints`` tuple; use :func:`carry_problem` to get the reason.
    """
    from kbplanner.robot.arm_ik import solve_ik

    saved_base = robot.base_pose()
    saved_arm = robot.arm_positions()
    robot.set_base_pose(0.0, 0.0, 0.0)
    probe = ElementProbe(robot, bounds)
    named = [robot.spec.poses[k] for k in ("carry", "pre_grasp", "stow") if k in robot.spec.poses]
    element_in_tool = np.linalg.inv(tool_in_element)  # the same for every target
    try:
        modes: dict[str, CarryMode] = {}
        for name in MODES:
            found: CarryMode | None = None
            best_clear = -math.inf
            for orient, tool_pos in _mode_targets(robot, name, bounds):
                # element frame such that the tool is at tool_pos with the element in orientation `orient`
                tool_rot = orient[:3, :3] @ tool_in_element[:3, :3]
                if name == NORMAL and tool_rot[2, 2] < 0.3:
                    continue  # normal carry: the gripper under the element, its tool axis pointing up
                tool = np.eye(4)
                tool[:3, :3] = tool_rot
                tool[:3, 3] = tool_pos
                elem = tool @ element_in_tool
                ik = solve_ik(robot, tool_pos, rpy_of(tool), seeds=[*seeds, *named], refinements=refinements,
                              method=method)
                if not ik.reachable:
                    continue
                robot.set_arm(ik.joints)
                probe.place(elem)
                clear = probe.clearance()
                robot.set_arm(saved_arm)
                best_clear = max(best_clear, clear)
                if clear < MIN_CLEARANCE_M:
                    continue
                frame = element_in_base(robot, ik.joints, tool_in_element)
                found = CarryMode(name, tuple(round(v, 9) for v in ik.joints), frame,
                                  footprint_rect(frame, bounds), clear)
                break
            if found is None:
                why = ("no reachable tool pose" if best_clear == -math.inf
                       else f"the element would come within {max(best_clear, 0.0):.3f} m of the robot")
                found = CarryMode(name, (), np.eye(4), Rect(0.0, 0.0, 1e-3, 1e-3), best_clear)
                log.info("carry mode %s not found: %s", name, why)
            modes[name] = found
    finally:
        probe.close()
        robot.set_arm(saved_arm)
        robot.set_base_pose(*saved_base)
    return CarryGeometry(robot.spec.footprint(), modes[NORMAL], modes[NARROW])


def carry_problem(geo: CarryGeometry) -> str | None:
    """Why a carry geometry cannot be used (a mode without joint angles), or None."""
    missing = [m.name for m in (geo.normal, geo.narrow) if not m.joints]
    if not missing:
        return None
    return ("no carry pose for the " + " and ".join(missing) + " mode: no reachable tool pose near the "
            "robot's carry pose keeps the element clear of the robot")


def geometry_from_joints(
    robot: RobotModel,
    bounds: Bounds,
    tool_in_element: Matrix,
    normal: Sequence[float],
    narrow: Sequence[float],
) -> CarryGeometry:
    """Carry geometry from known carry joint angles (the plan's), by forward kinematics."""
    modes = []
    for name, q in ((NORMAL, normal), (NARROW, narrow)):
        frame = element_in_base(robot, q, tool_in_element)
        rect = footprint_rect(frame, bounds)
        modes.append(CarryMode(name, tuple(float(v) for v in q), frame, rect, math.nan))
    return CarryGeometry(robot.spec.footprint(), modes[0], modes[1])
