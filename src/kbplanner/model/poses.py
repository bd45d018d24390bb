"""4D model poses: x, y, z, roll, pitch, yaw of model elements, and the rounding written to the graph.

Takes a 4x4 rigid transform (metres) and gives a :class:`Pose` rounded for writing
(:func:`matrix_to_pose`); :func:`round_length` and :func:`round_angle` are the rounding of lengths and
angles in the model graph. Used by the IFC import (:mod:`kbplanner.model.ifc_geometry`, which re-exports
them) and, without importing ifcopenshell, by the world (A6) and the planner (B1-B4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# Lengths written to the graph are rounded to 1 micrometre, angles to 1 nanoradian: enough for
# robots, and it keeps floating-point noise (3.100000000000378) out of the model.
LENGTH_DIGITS = 6
ANGLE_DIGITS = 9


def round_length(value: float) -> float:
    """A length in metres rounded to 1 µm, without negative zero."""
    return round(float(value), LENGTH_DIGITS) + 0.0


def round_angle(value: float) -> float:
    """An angle in radians rounded to 1 nrad, without negative zero."""
    return round(float(value), ANGLE_DIGITS) + 0.0


@dataclass(frozen=True)
class Pose:
    """x, y, z (m) and roll, pitch, yaw (rad, extrinsic X-Y-Z: R = Rz(yaw) Ry(pitch) Rx(roll))."""

    x: float
    y: float
    z: float
    roll: float
    pitch: float
    yaw: float


def matrix_to_pose(matrix: np.ndarray) -> Pose:
    """The pose of a 4x4 rigid transform (translation in metres), rounded for writing.

    Example:
        >>> m = np.eye(4); m[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]; m[:3, 3] = [1, 2, 3]
        >>> matrix_to_pose(m)
        Pose(x=1.0, y=2.0, z=3.0, roll=0.0, pitch=0.0, yaw=1.570796327)
    """
    r = np.asarray(matrix, dtype=float)[:3, :3]
    # Normalise the axes: IFC placements may carry unnormalised direction ratios.
    norms = np.linalg.norm(r, axis=0)
    r = r / np.where(norms > 0, norms, 1.0)
    sin_pitch = -r[2, 0]
    pitch = math.asin(max(-1.0, min(1.0, sin_pitch)))
    if abs(sin_pitch) < 1.0 - 1e-9:
        roll = math.atan2(r[2, 1], r[2, 2])
        yaw = math.atan2(r[1, 0], r[0, 0])
    else:  # gimbal lock: put the whole rotation about z into yaw
        roll = 0.0
        yaw = math.atan2(-r[0, 1], r[1, 1])
    t = np.asarray(matrix, dtype=float)[:3, 3]
    return Pose(
        round_length(t[0]), round_length(t[1]), round_length(t[2]),
        round_angle(roll), round_angle(pitch), round_angle(yaw),
    )
