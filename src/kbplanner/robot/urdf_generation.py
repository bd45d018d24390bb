"""Robot models (simulation, B3-B5), URDF generation: the URDF text of a robot from its spec.

Takes a :class:`~kbplanner.robot.robot_table.RobotSpec` and returns deterministic URDF text
(:func:`urdf_text`; the files ``sim/robots/*.urdf`` are written by
:func:`kbplanner.robot.robot_model.write_urdfs`). Geometry is primitive (boxes, cylinders); the link
and joint names below are how :class:`~kbplanner.robot.robot_model.RobotModel` finds them.

Frames: the base frame is on the ground below the chassis centre, x forward, y left, z up. The arm
is built from standard Denavit-Hartenberg parameters: joint ``i`` sits at
``Tx(a[i-1]) Rx(alpha[i-1]) Tz(d[i])`` from joint ``i-1`` and turns about its local z axis, so the
URDF's zero pose is the DH zero pose (arm stretched out horizontally).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence

import numpy as np

from kbplanner.core.errors import InputFileError
from kbplanner.robot.robot_table import ArmSpec, BaseSpec, RobotSpec, robots_toml

ARM_JOINT_NAMES: tuple[str, ...] = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
ARM_LINK_NAMES: tuple[str, ...] = (
    "shoulder_link",
    "upper_arm_link",
    "forearm_link",
    "wrist_1_link",
    "wrist_2_link",
    "wrist_3_link",
)
TOOL_LINK = "tool_link"
FLANGE_LINK = "tool0"
LIDAR_LINK = "lidar_link"
CAMERA_LINK = "camera_link"
BASE_LINK = "base_link"


def _num(v: float) -> str:
    """Deterministic, compact number text (``-0`` normalised)."""
    r = round(float(v), 9)
    if r == 0.0:
        r = 0.0
    return f"{r:.9g}"


def _vec(vs: Sequence[float]) -> str:
    return " ".join(_num(v) for v in vs)


def _box_inertia(m: float, sx: float, sy: float, sz: float) -> tuple[float, float, float]:
    return (m * (sy * sy + sz * sz) / 12, m * (sx * sx + sz * sz) / 12, m * (sx * sx + sy * sy) / 12)


def _cyl_inertia(m: float, r: float, h: float) -> tuple[float, float, float]:
    """Inertia of a solid cylinder along z."""
    side = m * (3 * r * r + h * h) / 12
    return (side, side, m * r * r / 2)


def _rot_x(alpha: float) -> np.ndarray:
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rpy_z_to(v: np.ndarray) -> tuple[float, float, float]:
    """Roll/pitch/yaw turning the z axis onto the direction ``v`` (for a cylinder along ``v``)."""
    n = v / np.linalg.norm(v)
    pitch = math.atan2(math.hypot(n[0], n[1]), n[2])
    yaw = math.atan2(n[1], n[0]) if math.hypot(n[0], n[1]) > 1e-12 else 0.0
    return (0.0, pitch, yaw)


class _UrdfBuilder:
    def __init__(self, name: str) -> None:
        self.root = ET.Element("robot", {"name": name})

    def material(self, name: str, rgba: tuple[float, float, float, float]) -> None:
        mat = ET.SubElement(self.root, "material", {"name": name})
        ET.SubElement(mat, "color", {"rgba": _vec(rgba)})

    def link(
        self,
        name: str,
        *,
        mass: float,
        com: Sequence[float] = (0.0, 0.0, 0.0),
        inertia: tuple[float, float, float] = (1e-4, 1e-4, 1e-4),
        shapes: Sequence[tuple[str, Sequence[float], Sequence[float], Sequence[float], str]] = (),
        collide: bool = True,
    ) -> None:
        """A link; each shape is (kind, size, xyz, rpy, material) with kind 'box' or 'cylinder'."""
        link = ET.SubElement(self.root, "link", {"name": name})
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "origin", {"xyz": _vec(com), "rpy": "0 0 0"})
        ET.SubElement(inertial, "mass", {"value": _num(mass)})
        ixx, iyy, izz = (max(i, 1e-6) for i in inertia)
        ET.SubElement(inertial, "inertia", {"ixx": _num(ixx), "ixy": "0", "ixz": "0",
                                            "iyy": _num(iyy), "iyz": "0", "izz": _num(izz)})
        for tag in ("visual", "collision") if collide else ("visual",):
            for kind, size, xyz, rpy, material in shapes:
                el = ET.SubElement(link, tag)
                ET.SubElement(el, "origin", {"xyz": _vec(xyz), "rpy": _vec(rpy)})
                geom = ET.SubElement(el, "geometry")
                if kind == "box":
                    ET.SubElement(geom, "box", {"size": _vec(size)})
                else:
                    ET.SubElement(geom, "cylinder", {"radius": _num(size[0]), "length": _num(size[1])})
                if tag == "visual":
                    ET.SubElement(el, "material", {"name": material})

    def joint(
        self,
        name: str,
        kind: str,
        parent: str,
        child: str,
        xyz: Sequence[float],
        rpy: Sequence[float] = (0.0, 0.0, 0.0),
        axis: Sequence[float] | None = None,
        limits: tuple[float, float, float, float] | None = None,
    ) -> None:
        j = ET.SubElement(self.root, "joint", {"name": name, "type": kind})
        ET.SubElement(j, "parent", {"link": parent})
        ET.SubElement(j, "child", {"link": child})
        ET.SubElement(j, "origin", {"xyz": _vec(xyz), "rpy": _vec(rpy)})
        if axis is not None:
            ET.SubElement(j, "axis", {"xyz": _vec(axis)})
        if limits is not None:
            lo, hi, effort, velocity = limits
            ET.SubElement(j, "limit", {"lower": _num(lo), "upper": _num(hi),
                                       "effort": _num(effort), "velocity": _num(velocity)})
        if kind in ("revolute", "continuous"):
            ET.SubElement(j, "dynamics", {"damping": "0.1", "friction": "0.0"})

    def text(self, header: str) -> str:
        ET.indent(self.root, space="  ")
        body = ET.tostring(self.root, encoding="unicode")
        return f'<?xml version="1.0"?>\n<!-- {header} -->\n{body}\n'


def _add_base(b: _UrdfBuilder, base: BaseSpec) -> None:
    wheel_mass_total = 4 * base.wheel_mass_kg
    chassis_mass = base.mass_kg - wheel_mass_total - base.plate_mass_kg
    if chassis_mass <= 0:
        raise InputFileError("wheels and plate weigh more than the whole base",
                             file=robots_toml(), element=f"base.{base.name}",
                             fix="check mass_kg, wheel_mass_kg and plate_mass_kg")
    ch_h = base.chassis_top_m - base.ground_clearance_m
    ch_z = base.ground_clearance_m + ch_h / 2
    bumper_len = (base.length_m - base.chassis_length_m) / 2
    bumper_x = base.chassis_length_m / 2 + bumper_len / 2
    bumper_z = base.ground_clearance_m + base.bumper_height_m / 2
    bumper_w = base.width_m - 2 * base.wheel_width_m
    shapes: list[tuple[str, Sequence[float], Sequence[float], Sequence[float], str]] = [
        ("box", (base.chassis_length_m, base.chassis_width_m, ch_h), (0.0, 0.0, ch_z), (0, 0, 0), "body"),
    ]
    if bumper_len > 1e-6:
        for sx in (1.0, -1.0):
            shapes.append(("box", (bumper_len, bumper_w, base.bumper_height_m),
                           (sx * bumper_x, 0.0, bumper_z), (0, 0, 0), "bumper"))
    # The root link carries the chassis mass: a root of mass 0 would make PyBullet pin the robot.
    b.link(BASE_LINK, mass=chassis_mass, com=(0.0, 0.0, ch_z),
           inertia=_box_inertia(chassis_mass, base.chassis_length_m, base.chassis_width_m, ch_h),
           shapes=shapes)
    plate_z = base.chassis_top_m + base.plate_thickness_m / 2
    b.link("top_plate_link", mass=base.plate_mass_kg,
           inertia=_box_inertia(base.plate_mass_kg, base.plate_length_m, base.plate_width_m,
                                base.plate_thickness_m),
           shapes=[("box", (base.plate_length_m, base.plate_width_m, base.plate_thickness_m),
                    (0, 0, 0), (0, 0, 0), "plate")])
    b.joint("top_plate_joint", "fixed", BASE_LINK, "top_plate_link", (0.0, 0.0, plate_z))
    wheel_y = base.track_m / 2
    wheel_x = base.wheelbase_m / 2
    for fx, front in ((1.0, "front"), (-1.0, "rear")):
        for fy, side in ((1.0, "left"), (-1.0, "right")):
            name = f"{front}_{side}_wheel"
            b.link(f"{name}_link", mass=base.wheel_mass_kg,
                   inertia=_cyl_inertia(base.wheel_mass_kg, base.wheel_radius_m, base.wheel_width_m),
                   shapes=[("cylinder", (base.wheel_radius_m, base.wheel_width_m), (0, 0, 0),
                            (math.pi / 2, 0.0, 0.0), "tyre")])
            b.joint(f"{name}_joint", "continuous", BASE_LINK, f"{name}_link",
                    (fx * wheel_x, fy * wheel_y, base.wheel_radius_m), axis=(0.0, 1.0, 0.0))
    for link, sensor, material in ((LIDAR_LINK, base.lidar, "sensor"), (CAMERA_LINK, base.camera, "camera")):
        b.link(link, mass=sensor.mass_kg, inertia=_box_inertia(sensor.mass_kg, *sensor.size),
               shapes=[("box", sensor.size, (0, 0, 0), (0, 0, 0), material)])
        b.joint(f"{link[:-5]}_joint", "fixed", BASE_LINK, link, sensor.xyz)


def _add_arm(b: _UrdfBuilder, spec: RobotSpec, arm: ArmSpec) -> None:
    b.link("arm_base_link", mass=arm.base_mass_kg, com=(0.0, 0.0, arm.base_height_m / 2),
           inertia=_cyl_inertia(arm.base_mass_kg, arm.base_radius_m, arm.base_height_m),
           shapes=[("cylinder", (arm.base_radius_m, arm.base_height_m), (0, 0, arm.base_height_m / 2),
                    (0, 0, 0), "arm")])
    b.joint("arm_mount_joint", "fixed", BASE_LINK, "arm_base_link", spec.arm_mount_xyz,
            (0.0, 0.0, spec.arm_mount_yaw_rad))
    # Joint i sits at Tx(a[i-1]) Rx(alpha[i-1]) Tz(d[i]) in the frame of joint i-1 (standard DH).
    parent = "arm_base_link"
    for i in range(6):
        a_prev = arm.a[i - 1] if i > 0 else 0.0
        alpha_prev = arm.alpha[i - 1] if i > 0 else 0.0
        xyz = (a_prev, -math.sin(alpha_prev) * arm.d[i], math.cos(alpha_prev) * arm.d[i])
        # Link i spans from joint i to joint i+1 (or to the flange for the last link).
        nxt_a, nxt_alpha = arm.a[i], arm.alpha[i]
        nxt_d = arm.d[i + 1] if i < 5 else 0.0
        nxt = np.array([nxt_a, -math.sin(nxt_alpha) * nxt_d, math.cos(nxt_alpha) * nxt_d])
        # Published centres of mass are in DH frame i = Tx(a[i]) Rx(alpha[i]) of this link frame.
        com = np.array([arm.a[i], 0.0, 0.0]) + _rot_x(arm.alpha[i]) @ np.array(arm.com_m[i])
        r = arm.link_radius_m[i]
        # The real upper arm and forearm sit beside the DH plane along their (parallel) joint axes;
        # the offsets move only geometry, the kinematics stay the published DH chain.
        side = {1: arm.shoulder_offset_m, 2: arm.elbow_offset_m}.get(i, 0.0)
        shapes: list[tuple[str, Sequence[float], Sequence[float], Sequence[float], str]] = [
            ("cylinder", (r, 2 * r), (0, 0, side), (0, 0, 0), "arm"),  # joint housing about the axis
        ]
        length = float(np.linalg.norm(nxt))
        if length > 2 * r:
            mid = nxt / 2 + np.array([0.0, 0.0, side])
            shapes.append(("cylinder", (0.8 * r, length), tuple(mid), _rpy_z_to(nxt), "arm_link"))
            if side:  # the housing at the far joint of the offset link
                shapes.append(("cylinder", (r, 2 * r), tuple(nxt + np.array([0.0, 0.0, side])), (0, 0, 0),
                               "arm"))
        b.link(ARM_LINK_NAMES[i], mass=arm.masses_kg[i], com=tuple(com),
               inertia=_cyl_inertia(arm.masses_kg[i], r, max(length, 2 * r)), shapes=shapes)
        b.joint(ARM_JOINT_NAMES[i], "revolute", parent, ARM_LINK_NAMES[i], xyz,
                (alpha_prev, 0.0, 0.0), axis=(0.0, 0.0, 1.0),
                limits=(arm.lower_rad[i], arm.upper_rad[i], arm.effort_nm[i], arm.velocity_rps[i]))
        parent = ARM_LINK_NAMES[i]
    # Flange (tool0): DH frame 6, z pointing out of the flange.
    b.link(FLANGE_LINK, mass=0.0)
    b.joint("flange_joint", "fixed", parent, FLANGE_LINK, (arm.a[5], 0.0, 0.0), (arm.alpha[5], 0.0, 0.0))
    g = spec.gripper_length_m
    b.link("gripper_link", mass=spec.gripper_mass_kg, com=(0.0, 0.0, g / 2),
           inertia=_cyl_inertia(spec.gripper_mass_kg, spec.gripper_radius_m, g),
           shapes=[("cylinder", (spec.gripper_radius_m, g), (0, 0, g / 2), (0, 0, 0), "gripper"),
                   ("box", (0.02, 2.5 * spec.gripper_radius_m, 0.04), (0, 0, g + 0.02), (0, 0, 0),
                    "gripper")])
    b.joint("gripper_joint", "fixed", FLANGE_LINK, "gripper_link", (0.0, 0.0, 0.0))
    b.link(TOOL_LINK, mass=0.0)
    b.joint("tcp_joint", "fixed", FLANGE_LINK, TOOL_LINK, (0.0, 0.0, spec.tcp_m))


_MATERIALS: tuple[tuple[str, tuple[float, float, float, float]], ...] = (
    ("body", (0.95, 0.75, 0.05, 1.0)),
    ("bumper", (0.15, 0.15, 0.15, 1.0)),
    ("plate", (0.25, 0.25, 0.25, 1.0)),
    ("tyre", (0.05, 0.05, 0.05, 1.0)),
    ("sensor", (0.2, 0.4, 0.9, 1.0)),
    ("camera", (0.6, 0.6, 0.65, 1.0)),
    ("arm", (0.3, 0.55, 0.75, 1.0)),
    ("arm_link", (0.8, 0.8, 0.82, 1.0)),
    ("gripper", (0.2, 0.2, 0.2, 1.0)),
)


def urdf_text(spec: RobotSpec) -> str:
    """The URDF of a robot, generated from its spec (deterministic text).

    Example:
        >>> from kbplanner.robot.robot_table import load_robot_specs
        >>> text = urdf_text(load_robot_specs()["jackal"])
        >>> "lidar_link" in text and "shoulder_pan_joint" not in text
        True
    """
    b = _UrdfBuilder(spec.name)
    for name, rgba in _MATERIALS:
        b.material(name, rgba)
    _add_base(b, spec.base)
    if spec.arm is not None:
        _add_arm(b, spec, spec.arm)
    header = (f"Generated by kbplanner.robot.robot_model.write_urdfs from robots.toml [robot.{spec.name}]; "
              "do not edit. " + spec.description.replace("--", "-"))
    return b.text(header)
