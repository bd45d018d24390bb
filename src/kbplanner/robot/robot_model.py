"""Robot models (simulation, B3-B5): robot descriptions, URDF generation and PyBullet loading.

Takes the parameter table ``sim/robots/robots.toml`` (public figures of a Husky-class base, UR5- and
UR16e-class arms, a Jackal-class base) and returns typed :class:`RobotSpec` objects, the URDF text
generated from them (checked in as ``sim/robots/*.urdf``), and a :class:`RobotModel`: a robot loaded
into a PyBullet client with its arm joints, tool, lidar and camera links found by name, named arm
poses, and base pose setting. Inverse kinematics lives in :mod:`kbplanner.robot.arm_ik`.

Frames: the base frame is on the ground below the chassis centre, x forward, y left, z up. The arm
is built from standard Denavit-Hartenberg parameters: joint ``i`` sits at
``Tx(a[i-1]) Rx(alpha[i-1]) Tz(d[i])`` from joint ``i-1`` and turns about its local z axis, so the
URDF's zero pose is the DH zero pose (arm stretched out horizontally).

Example:
    >>> specs = load_robot_specs()
    >>> specs["husky_ur5"].base.length_m, specs["husky_ur5"].arm.name
    (0.99, 'ur5')
"""

from __future__ import annotations

import logging
import math
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from kbplanner.core.errors import InputFileError
from kbplanner.core.resources import data_dir
from kbplanner.world.footprint import Footprint, Rect

log = logging.getLogger(__name__)

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


def robots_toml() -> Path:
    """Path of the robot parameter table shipped with kbplanner."""
    return data_dir("sim") / "robots" / "robots.toml"


# --------------------------------------------------------------------------------------------
# Specs
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SensorSpec:
    """A sensor mounted on the base: its frame origin in the base frame and its public figures."""

    model: str
    xyz: tuple[float, float, float]
    size: tuple[float, float, float]
    mass_kg: float
    params: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class BaseSpec:
    """A skid-steer mobile base (footprint, wheels, chassis, top plate, sensors, motion limits)."""

    name: str
    description: str
    sources: str
    length_m: float
    width_m: float
    mass_kg: float
    wheel_radius_m: float
    wheel_width_m: float
    wheel_mass_kg: float
    wheelbase_m: float
    track_m: float
    ground_clearance_m: float
    chassis_length_m: float
    chassis_width_m: float
    chassis_top_m: float
    bumper_height_m: float
    plate_length_m: float
    plate_width_m: float
    plate_thickness_m: float
    plate_mass_kg: float
    max_speed_mps: float
    max_yaw_rate_rps: float
    max_accel_mps2: float
    max_yaw_accel_rps2: float
    lidar: SensorSpec
    camera: SensorSpec

    @property
    def height_m(self) -> float:
        """Height of the top plate above the ground."""
        return self.chassis_top_m + self.plate_thickness_m


@dataclass(frozen=True)
class ArmSpec:
    """A 6-axis arm given by standard DH parameters and published link dynamics."""

    name: str
    description: str
    sources: str
    d: tuple[float, ...]
    a: tuple[float, ...]
    alpha: tuple[float, ...]
    base_mass_kg: float
    base_radius_m: float
    base_height_m: float
    masses_kg: tuple[float, ...]
    com_m: tuple[tuple[float, float, float], ...]
    link_radius_m: tuple[float, ...]
    lower_rad: tuple[float, ...]
    upper_rad: tuple[float, ...]
    velocity_rps: tuple[float, ...]
    effort_nm: tuple[float, ...]
    payload_kg: float
    reach_m: float
    shoulder_offset_m: float = 0.0  # geometry only: upper arm beside the shoulder, along joint 2's axis
    elbow_offset_m: float = 0.0  # geometry only: forearm beside the elbow, along joint 3's axis


@dataclass(frozen=True)
class RobotSpec:
    """A robot: a base, optionally an arm with a gripper, and named arm poses (joint angles)."""

    name: str
    description: str
    base: BaseSpec
    arm: ArmSpec | None = None
    arm_mount_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    arm_mount_yaw_rad: float = 0.0
    gripper_length_m: float = 0.0
    gripper_radius_m: float = 0.0
    gripper_mass_kg: float = 0.0
    tcp_m: float = 0.0
    poses: dict[str, tuple[float, ...]] = field(default_factory=dict)

    @property
    def urdf_name(self) -> str:
        """File name of the generated URDF."""
        return f"{self.name}.urdf"

    def urdf_path(self) -> Path:
        """Path of the checked-in URDF shipped with kbplanner."""
        return data_dir("sim") / "robots" / self.urdf_name

    @property
    def mass_kg(self) -> float:
        """Total mass: base, arm, gripper and sensors."""
        m = self.base.mass_kg + self.base.lidar.mass_kg + self.base.camera.mass_kg
        if self.arm is not None:
            m += self.arm.base_mass_kg + sum(self.arm.masses_kg) + self.gripper_mass_kg
        return m

    def footprint(self) -> Footprint:
        """The base footprint (the arm in its stow pose stays inside it) in the robot frame."""
        return Footprint((Rect(0.0, 0.0, self.base.length_m, self.base.width_m),), name=self.name)


def _floats(value: Any, n: int | None, where: str, file: Path) -> tuple[float, ...]:
    if not isinstance(value, list) or (n is not None and len(value) != n):
        raise InputFileError(
            f"expected a list of {n if n is not None else 'some'} numbers, got {value!r}",
            file=file, element=where, fix="write the value as a TOML array of numbers",
        )
    try:
        return tuple(float(v) for v in value)
    except (TypeError, ValueError) as exc:
        raise InputFileError(f"non-numeric value in {value!r}", file=file, element=where,
                             fix="use numbers only") from exc


def _xyz(value: Any, where: str, file: Path) -> tuple[float, float, float]:
    x, y, z = _floats(value, 3, where, file)
    return (x, y, z)


def _get(table: dict[str, Any], key: str, where: str, file: Path) -> Any:
    if key not in table:
        raise InputFileError(f"missing key '{key}'", file=file, element=where,
                             fix=f"add '{key} = ...' to [{where}]")
    return table[key]


def _sensor(table: dict[str, Any], where: str, file: Path) -> SensorSpec:
    known = {"model", "xyz", "size", "mass_kg"}
    params = {k: float(v) for k, v in sorted(table.items()) if k not in known}
    return SensorSpec(
        model=str(_get(table, "model", where, file)),
        xyz=_xyz(_get(table, "xyz", where, file), where + ".xyz", file),
        size=_xyz(_get(table, "size", where, file), where + ".size", file),
        mass_kg=float(_get(table, "mass_kg", where, file)),
        params=params,
    )


def _base(name: str, t: dict[str, Any], file: Path) -> BaseSpec:
    where = f"base.{name}"
    scalars = [
        "length_m", "width_m", "mass_kg", "wheel_radius_m", "wheel_width_m", "wheel_mass_kg",
        "wheelbase_m", "track_m", "ground_clearance_m", "chassis_length_m", "chassis_width_m",
        "chassis_top_m", "bumper_height_m", "plate_length_m", "plate_width_m", "plate_thickness_m",
        "plate_mass_kg", "max_speed_mps", "max_yaw_rate_rps", "max_accel_mps2", "max_yaw_accel_rps2",
    ]
    values = {k: float(_get(t, k, where, file)) for k in scalars}
    return BaseSpec(
        name=name,
        description=str(t.get("description", "")),
        sources=str(t.get("sources", "")),
        lidar=_sensor(_get(t, "lidar", where, file), where + ".lidar", file),
        camera=_sensor(_get(t, "camera", where, file), where + ".camera", file),
        **values,
    )


def _arm(name: str, t: dict[str, Any], file: Path) -> ArmSpec:
    where = f"arm.{name}"
    com = _get(t, "com_m", where, file)
    if not isinstance(com, list) or len(com) != 6:
        raise InputFileError("com_m must list 6 centres of mass", file=file, element=where,
                             fix="give one [x, y, z] per link")
    return ArmSpec(
        name=name,
        description=str(t.get("description", "")),
        sources=str(t.get("sources", "")),
        d=_floats(_get(t, "d", where, file), 6, where + ".d", file),
        a=_floats(_get(t, "a", where, file), 6, where + ".a", file),
        alpha=_floats(_get(t, "alpha", where, file), 6, where + ".alpha", file),
        base_mass_kg=float(_get(t, "base_mass_kg", where, file)),
        base_radius_m=float(_get(t, "base_radius_m", where, file)),
        base_height_m=float(_get(t, "base_height_m", where, file)),
        masses_kg=_floats(_get(t, "masses_kg", where, file), 6, where + ".masses_kg", file),
        com_m=tuple(_xyz(c, where + ".com_m", file) for c in com),
        link_radius_m=_floats(_get(t, "link_radius_m", where, file), 6, where + ".link_radius_m", file),
        lower_rad=_floats(_get(t, "lower_rad", where, file), 6, where + ".lower_rad", file),
        upper_rad=_floats(_get(t, "upper_rad", where, file), 6, where + ".upper_rad", file),
        velocity_rps=_floats(_get(t, "velocity_rps", where, file), 6, where + ".velocity_rps", file),
        effort_nm=_floats(_get(t, "effort_nm", where, file), 6, where + ".effort_nm", file),
        payload_kg=float(_get(t, "payload_kg", where, file)),
        reach_m=float(_get(t, "reach_m", where, file)),
        shoulder_offset_m=float(t.get("shoulder_offset_m", 0.0)),
        elbow_offset_m=float(t.get("elbow_offset_m", 0.0)),
    )


def load_robot_specs(path: Path | None = None) -> dict[str, RobotSpec]:
    """Every robot of a parameter table (default: the shipped ``sim/robots/robots.toml``), by name.

    Raises:
        InputFileError: the file is missing, not TOML, or a robot refers to an unknown base or arm.
    """
    file = Path(path) if path is not None else robots_toml()
    try:
        data = tomllib.loads(file.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputFileError(f"cannot read robot table: {exc.strerror}", file=file,
                             fix="pass the path of a robots.toml") from exc
    except tomllib.TOMLDecodeError as exc:
        raise InputFileError(f"not valid TOML: {exc}", file=file, fix="fix the TOML syntax") from exc
    bases = {n: _base(n, t, file) for n, t in sorted(data.get("base", {}).items())}
    arms = {n: _arm(n, t, file) for n, t in sorted(data.get("arm", {}).items())}
    robots: dict[str, RobotSpec] = {}
    for name, t in sorted(data.get("robot", {}).items()):
        where = f"robot.{name}"
        base_name = str(_get(t, "base", where, file))
        if base_name not in bases:
            raise InputFileError(f"unknown base '{base_name}'", file=file, element=where,
                                 fix=f"use one of {sorted(bases)} or add [base.{base_name}]")
        arm = None
        if "arm" in t:
            if t["arm"] not in arms:
                raise InputFileError(f"unknown arm '{t['arm']}'", file=file, element=where,
                                     fix=f"use one of {sorted(arms)} or add [arm.{t['arm']}]")
            arm = arms[t["arm"]]
        poses = {
            p: _floats(q, 6, f"{where}.poses.{p}", file) for p, q in sorted(t.get("poses", {}).items())
        }
        if poses and arm is None:
            raise InputFileError("named arm poses given for a robot without an arm", file=file,
                                 element=where, fix="remove [robot.NAME.poses] or add an arm")
        robots[name] = RobotSpec(
            name=name,
            description=str(t.get("description", "")),
            base=bases[base_name],
            arm=arm,
            arm_mount_xyz=_xyz(t.get("arm_mount_xyz", [0.0, 0.0, 0.0]), where + ".arm_mount_xyz", file),
            arm_mount_yaw_rad=float(t.get("arm_mount_yaw_rad", 0.0)),
            gripper_length_m=float(t.get("gripper_length_m", 0.0)),
            gripper_radius_m=float(t.get("gripper_radius_m", 0.0)),
            gripper_mass_kg=float(t.get("gripper_mass_kg", 0.0)),
            tcp_m=float(t.get("tcp_m", 0.0)),
            poses=poses,
        )
    return robots


def robot_spec(name: str, path: Path | None = None) -> RobotSpec:
    """One robot of the table by name; raises :class:`InputFileError` naming the known ones."""
    specs = load_robot_specs(path)
    if name not in specs:
        raise InputFileError(f"unknown robot '{name}'", file=path or robots_toml(), element=name,
                             fix=f"use one of {sorted(specs)}")
    return specs[name]


# --------------------------------------------------------------------------------------------
# URDF generation
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# Loading into PyBullet
# --------------------------------------------------------------------------------------------

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
        import pybullet as p

        if z is None:
            z = self.floor_z

        pos, orn = p.multiplyTransforms((x, y, z), p.getQuaternionFromEuler((0.0, 0.0, yaw)),
                                        self._com_pos, self._com_orn)
        p.resetBasePositionAndOrientation(self.body, pos, orn, physicsClientId=self.client)

    def base_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the base frame in the site frame."""
        import pybullet as p

        pos, orn = self.link_pose(-1)
        yaw = p.getEulerFromQuaternion(orn)[2]
        return (float(pos[0]), float(pos[1]), float(yaw))

    # --- arm ----------------------------------------------------------------------------------

    def _need_arm(self) -> None:
        if not self.arm_joints:
            raise InputFileError("this robot has no arm", file=robots_toml(), element=self.spec.name,
                                 fix="choose a robot with an arm (e.g. husky_ur5)")

    def set_arm(self, q: Sequence[float]) -> None:
        """Set the six arm joint angles (radians) without simulating."""
        import pybullet as p

        self._need_arm()
        if len(q) != len(self.arm_joints):
            raise InputFileError(f"expected {len(self.arm_joints)} joint angles, got {len(q)}",
                                 element=self.spec.name, fix="give one angle per arm joint")
        for j, v in zip(self.arm_joints, q, strict=True):
            p.resetJointState(self.body, j, float(v), physicsClientId=self.client)

    def arm_positions(self) -> tuple[float, ...]:
        """The six arm joint angles (radians)."""
        import pybullet as p

        return tuple(float(p.getJointState(self.body, j, physicsClientId=self.client)[0])
                     for j in self.arm_joints)

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

        best = max_m
        for a in links_a:
            for b in links_b:
                for c in p.getClosestPoints(self.body, self.body, max_m, a, b, physicsClientId=self.client):
                    best = min(best, float(c[8]))
        return best

    def arm_clearance(self) -> float:
        """Smallest distance (m) from the arm (from the upper arm on) to base, plate, lidar and camera."""
        if not self.arm_joints:
            return math.inf
        body_links = [-1, self.links["top_plate_link"], self.lidar_link, self.camera_link]
        body_links += [self.links[n] for n in self.links if n.endswith("_wheel_link")]
        return self.min_distance(self.arm_links[1:], body_links)


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
