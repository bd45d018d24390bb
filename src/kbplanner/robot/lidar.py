"""Simulated robot sensors (B5, skill input "laser scan"): a 2D lidar scan and sensor view checks.

Takes a robot loaded in PyBullet (:class:`~kbplanner.robot.robot_model.RobotModel`, its ``lidar_link`` and
``camera_link``) and returns a :class:`Scan`: one ray per angular step over the scanner's field of
view (270 degrees for the SICK LMS-111-like scanner of the robot table), in the scan plane, cast
with ``p.rayTestBatch`` from the minimum range to the maximum range, so the scanner's blind zone
(closer than ``range_min_m``) is not seen, as on the real device. Each ray reports the distance to
the first body it hits and which body; :meth:`Scan.nearest` gives the nearest hit among given bodies
(the workers), which is what the executor's safety stop uses.

:func:`sensor_view_hits` checks an arm pose: how many lidar rays (scan plane) and camera rays (its
field of view) hit the robot's own arm or a held element, i.e. whether a navigation or carry pose
keeps both sensors clear.

Example:
    >>> from kbplanner.robot.robot_model import RobotModel
    >>> robot = RobotModel.load("husky_ur5")
    >>> spec = lidar_spec(robot)
    >>> round(math.degrees(spec.fov_rad)), spec.n_rays
    (270, 541)
    >>> scan(robot, spec).nearest({}) is None
    True
    >>> robot.close()
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kbplanner.robot.robot_model import RobotModel

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class LidarSpec:
    """A 2D scanner: field of view, angular step, ranges (rad, m)."""

    fov_rad: float
    step_rad: float
    range_min_m: float
    range_max_m: float

    @property
    def n_rays(self) -> int:
        """Rays per scan (both ends of the field of view included)."""
        return round(self.fov_rad / self.step_rad) + 1

    def angles(self) -> FloatArray:
        """Ray angles in the scanner frame (0 = straight ahead, counter-clockwise positive)."""
        return np.linspace(-self.fov_rad / 2, self.fov_rad / 2, self.n_rays)


def lidar_spec(robot: RobotModel, step_deg: float | None = None) -> LidarSpec:
    """The scanner of the robot table (``[base.*.lidar]``); ``step_deg`` overrides its resolution."""
    params = robot.spec.base.lidar.params
    step = step_deg if step_deg is not None else params.get("angular_resolution_deg", 0.5)
    return LidarSpec(
        fov_rad=math.radians(params.get("fov_deg", 270.0)),
        step_rad=math.radians(step),
        range_min_m=params.get("range_min_m", 0.1),
        range_max_m=params.get("range_max_m", 20.0),
    )


@dataclass(frozen=True, eq=False)
class Scan:
    """One lidar scan: per ray its angle (scanner frame), range (``inf``: nothing hit) and hit body."""

    angles: FloatArray
    ranges: FloatArray
    bodies: IntArray
    origin: tuple[float, float, float]
    points: FloatArray | None = None  # (n, 2) site x, y of each ray's hit (nan: no hit)

    def nearest(self, bodies: Mapping[int, str]) -> tuple[str, float, float] | None:
        """(name, distance m, angle rad) of the nearest hit on one of ``bodies`` (id -> name), or None."""
        if not bodies:
            return None
        mask = np.isin(self.bodies, np.fromiter(bodies, dtype=np.int64))
        if not mask.any():
            return None
        idx = np.flatnonzero(mask)
        k = int(idx[np.argmin(self.ranges[idx])])
        return (bodies[int(self.bodies[k])], float(self.ranges[k]), float(self.angles[k]))


def rays_near(origin: FloatArray, dirs: FloatArray, near: FloatArray, radius_m: float) -> IntArray | None:
    """Indices of the rays (``dirs``, unit, from ``origin``) that pass within ``radius_m`` of a vertical
    line through one of the ``near`` points (n, 2: site x, y), in order; ``None`` when the rays do not
    lie in a horizontal plane (then every ray may matter)."""
    if len(dirs) and float(np.max(np.abs(dirs[:, 2]))) > 1e-9:
        return None
    hx, hy = dirs[:, 0], dirs[:, 1]
    keep = np.zeros(len(dirs), dtype=bool)
    for wx, wy in np.asarray(near, dtype=np.float64).reshape(-1, 2).tolist():
        rx, ry = wx - float(origin[0]), wy - float(origin[1])
        along = rx * hx + ry * hy  # how far along each ray the point's foot is
        across = np.abs(rx * hy - ry * hx)  # the point's distance from each ray's line
        keep |= (across <= radius_m) & (along >= -radius_m)
    return np.flatnonzero(keep)


def scan(robot: RobotModel, spec: LidarSpec, *, ignore: Iterable[int] = (),
         near: FloatArray | None = None, near_radius_m: float = 0.5) -> Scan:
    """Cast one scan from the robot's lidar link in its current pose.

    Hits on the robot itself and on bodies in ``ignore`` (e.g. the held element) count as no hit; as
    each ray reports only its first hit, they also hide what is behind them (occlusion).

    ``near`` (n, 2 site x, y; e.g. the workers): only the rays that pass within ``near_radius_m`` of
    one of these points are cast (each ray's first hit does not depend on the others, so they report
    exactly what a whole scan would); the other rays report no hit. A person of radius r is hit only
    by rays within r of their axis: with ``near_radius_m`` > r their hits are those of a whole scan,
    at a fraction of its cost.
    """
    import pybullet as p

    pos, orn = robot.link_pose(robot.lidar_link)
    rot = np.asarray(p.getMatrixFromQuaternion(orn), dtype=np.float64).reshape(3, 3)
    ang = spec.angles()
    local = np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], axis=1)
    dirs = local @ rot.T
    origin = np.asarray(pos, dtype=np.float64)
    idx = rays_near(origin, dirs, near, near_radius_m) if near is not None else None
    if idx is not None:
        dirs = dirs[idx]
    starts = origin + spec.range_min_m * dirs
    ends = origin + spec.range_max_m * dirs
    robot.place_pending()  # (placed already by link_pose; the rays see the robot where it was set)
    hits = p.rayTestBatch(starts.tolist(), ends.tolist(), physicsClientId=robot.client) if len(dirs) else ()
    skip = {robot.body, *ignore}
    span = spec.range_max_m - spec.range_min_m
    ranges = np.full(len(ang), np.inf)
    bodies = np.full(len(ang), -1, dtype=np.int64)
    points = np.full((len(ang), 2), np.nan)
    rows = idx.tolist() if idx is not None else range(len(ang))
    for i, h in zip(rows, hits, strict=True):
        body = int(h[0])
        if body < 0 or body in skip:  # nothing, the robot itself, or an ignored body (it occludes)
            continue
        ranges[i] = spec.range_min_m + float(h[2]) * span
        bodies[i] = body
        points[i] = (float(h[3][0]), float(h[3][1]))
    return Scan(ang, ranges, bodies, (float(pos[0]), float(pos[1]), float(pos[2])), points)


def sensor_view_hits(
    robot: RobotModel,
    *,
    extra_bodies: Iterable[int] = (),
    lidar_range_m: float = 2.0,
    camera_range_m: float = 3.0,
    camera_fov_deg: tuple[float, float] = (87.0, 58.0),
) -> dict[str, int]:
    """How many lidar rays (every 5 deg of the scan plane) and camera rays (a 9 x 7 grid over its field
    of view) hit the robot's arm (from the upper arm on, with gripper) or one of ``extra_bodies``."""
    import pybullet as p

    arm_links = set(robot.arm_links[1:])
    arm_links |= {robot.links[n] for n in ("tool0", "tool_link") if n in robot.links}
    extra = set(extra_bodies)

    def count(origin: FloatArray, dirs: FloatArray, length: float) -> int:
        starts = origin + 0.02 * dirs
        ends = origin + length * dirs
        n = 0
        robot.place_pending()
        for h in p.rayTestBatch(starts.tolist(), ends.tolist(), physicsClientId=robot.client):
            if (int(h[0]) == robot.body and int(h[1]) in arm_links) or int(h[0]) in extra:
                n += 1
        return n

    out: dict[str, int] = {}
    spec = lidar_spec(robot, step_deg=5.0)
    pos, orn = robot.link_pose(robot.lidar_link)
    rot = np.asarray(p.getMatrixFromQuaternion(orn), dtype=np.float64).reshape(3, 3)
    ang = spec.angles()
    dirs = np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], axis=1) @ rot.T
    out["lidar"] = count(np.asarray(pos), dirs, lidar_range_m)
    pos, orn = robot.link_pose(robot.camera_link)
    rot = np.asarray(p.getMatrixFromQuaternion(orn), dtype=np.float64).reshape(3, 3)
    hfov, vfov = (math.radians(a) / 2 for a in camera_fov_deg)
    cam: list[list[float]] = []
    for az in np.linspace(-hfov, hfov, 9):
        for el in np.linspace(-vfov, vfov, 7):
            cam.append([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    out["camera"] = count(np.asarray(pos), np.asarray(cam) @ rot.T, camera_range_m)
    return out
