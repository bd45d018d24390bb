"""B4, pose values: plan inputs as 4x4 frames, rounded joint angles and base poses, the tool frame by
forward kinematics, and the installed pose's symmetric twin.

Takes the values a :class:`~kbplanner.planning.plan_model.SkillCall` carries (a pose as a list or a
dict, joint angles) and a robot loaded in PyBullet; gives site-frame transforms and the rounded
values written into the refined plan. Shared by the pick and install searches
(:mod:`kbplanner.planning.grasp_poses`, :mod:`kbplanner.planning.install_poses`), the refinement
(:mod:`kbplanner.planning.manipulation`) and the executor's skills (B5).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from kbplanner.planning.carry import Matrix, from_pos_quat, transform
from kbplanner.planning.plan_model import Pose2, Pose6
from kbplanner.robot.robot_model import RobotModel
from kbplanner.world.world_types import Bounds


def target_variants(bounds: Bounds, target: Matrix) -> list[tuple[bool, Matrix]]:
    """The installed pose, and the same pose turned 180 degrees about the element's vertical local axis
    when the element's box is symmetric about that axis (a stud frame: the same box either way).

    Example:
        >>> from kbplanner.world.build import Bounds
        >>> len(target_variants(Bounds(-0.3, -0.045, 0.0, 0.3, 0.045, 2.4), np.eye(4)))
        2
        >>> len(target_variants(Bounds(0.0, 0.0, 0.0, 0.6, 0.09, 2.4), np.eye(4)))
        1
    """
    out = [(False, target)]
    up = int(np.argmax(np.abs(target[2, :3])))  # the local axis nearest to the site's vertical
    centre = np.asarray(bounds.center)
    others = [i for i in range(3) if i != up]
    if all(abs(centre[i]) < 1e-3 for i in others):
        axis = np.zeros(3)
        axis[up] = 1.0
        half = np.eye(4)
        half[:3, :3] = Rotation.from_rotvec(math.pi * axis).as_matrix()
        out.append((True, np.asarray(target @ half, dtype=np.float64)))
    return out


def pose6_matrix(p: Pose6 | Sequence[float]) -> Matrix:
    """4x4 transform of a Pose6 or an [x, y, z, roll, pitch, yaw] list."""
    v = p.as_list() if isinstance(p, Pose6) else [float(a) for a in p]
    return transform(*v[:6])


def joints(q: Sequence[float]) -> list[float]:
    return [round(float(v), 9) + 0.0 for v in q]


def pose2(x: float, y: float, yaw: float) -> Pose2:
    return Pose2(round(float(x), 6) + 0.0, round(float(y), 6) + 0.0,
                 round((yaw + math.pi) % (2 * math.pi) - math.pi, 6) + 0.0)


def as_pose6_list(v: object) -> list[float] | None:
    if isinstance(v, (list, tuple)) and len(v) >= 3 and all(isinstance(a, (int, float)) for a in v):
        vals = [float(a) for a in v] + [0.0] * (6 - len(v))
        return vals[:6]
    if isinstance(v, dict) and {"x", "y", "z"} <= set(v):
        return [float(v.get(k, 0.0)) for k in ("x", "y", "z", "roll", "pitch", "yaw")]
    return None


def as_joints(v: object, n: int) -> tuple[float, ...] | None:
    if isinstance(v, (list, tuple)) and len(v) == n and all(isinstance(a, (int, float)) for a in v):
        return tuple(float(a) for a in v)
    return None


def tool_frame(robot: RobotModel, q: Sequence[float]) -> Matrix:
    """Forward kinematics of the tool (site frame) at the robot's current base pose; the arm is restored."""
    saved = robot.arm_positions()
    try:
        robot.set_arm(q)
        pos, orn = robot.tool_pose()
    finally:
        robot.set_arm(saved)
    return from_pos_quat(pos, orn)


def shifted(frame: Matrix, offset: npt.NDArray[np.float64]) -> Matrix:
    m = frame.copy()
    m[:3, 3] = m[:3, 3] + offset
    return m
