"""B5 skills NV-1 and NV-2, the part of the navigation grid a step plans on: a window around start and
goal (:func:`window`), and the nearest free pose for a robot that stands where the conservative
configuration space calls it blocked (:func:`nearest_free_pose`, within ``UNSTICK_RADIUS_M``).

Both live in :mod:`kbplanner.planning.base_poses`, because B4's carry-leg check
(:mod:`kbplanner.planning.carry_reach`) must use the very same windows and unstick rule as the
navigation; this module names them for the navigation skills.
"""

from __future__ import annotations

from kbplanner.planning.base_poses import UNSTICK_RADIUS_M, nearest_free_pose, window

Pose2D = tuple[float, float, float]

__all__ = ["UNSTICK_RADIUS_M", "Pose2D", "nearest_free_pose", "window"]
