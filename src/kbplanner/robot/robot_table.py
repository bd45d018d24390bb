"""Robot models (simulation, B3-B5), the robot table: ``sim/robots/robots.toml`` read into typed specs.

Takes the parameter table (public figures of a Husky-class base, UR5- and UR16e-class arms, a
Jackal-class base) and returns typed :class:`RobotSpec` objects (base, sensors, arm by standard DH
parameters, gripper, named arm poses); a missing key, a wrong value or an unknown base or arm is an
:class:`~kbplanner.core.errors.InputFileError` naming the table entry. The URDFs are generated from
these specs (:mod:`kbplanner.robot.urdf_generation`) and loaded by
:class:`~kbplanner.robot.robot_model.RobotModel`.

Example:
    >>> specs = load_robot_specs()
    >>> specs["husky_ur5"].base.length_m, specs["husky_ur5"].arm.name
    (0.99, 'ur5')
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from kbplanner.core.errors import InputFileError
from kbplanner.core.resources import data_dir
from kbplanner.world.footprint import Footprint, Rect


def robots_toml() -> Path:
    """Path of the robot parameter table shipped with kbplanner."""
    return data_dir("sim") / "robots" / "robots.toml"


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


def _finite_everywhere(value: Any, where: str, file: Path) -> None:
    """The numeric rule (docs/numeric_rule.md): TOML allows ``nan`` and ``inf``; no robot has them."""
    if isinstance(value, dict):
        for k, v in value.items():
            _finite_everywhere(v, f"{where}.{k}" if where else str(k), file)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _finite_everywhere(v, f"{where}[{i}]", file)
    elif isinstance(value, float) and not math.isfinite(value):
        raise InputFileError(f"{where} = {value!r} is not a finite number", file=file, element=where,
                             fix="give a finite number in its physical range")


# base values that may be 0 (the rest are sizes, masses, speeds, rates: > 0)
_MAY_BE_ZERO = {"ground_clearance_m", "bumper_height_m"}


def _in_range(values: dict[str, float], where: str, file: Path) -> None:
    for k, v in values.items():
        if v < 0 or (v == 0 and k not in _MAY_BE_ZERO):
            op = ">= 0" if k in _MAY_BE_ZERO else "> 0"
            raise InputFileError(f"{where}.{k} = {v!r} is out of range (must be {op})", file=file,
                                 element=f"{where}.{k}", fix=f"give {k} a finite number {op}")


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
    _in_range(values, where, file)
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
    _finite_everywhere(data, "", file)
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
