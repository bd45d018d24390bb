"""B5 skill kind kbp:Inspect: view a target from where the robot stands (quality check, progress photo).

The target is the position of the step's ``kbp:ViewTargetRole`` input (a pose, site frame). The base
turns in place to face it (at :data:`TURN_RPS`), then holds the view for the dwell time (the
``kbp:DwellTimeRole`` input, else the skill's ``dwellTime`` parameter, default 2 s). The view is a
ray in PyBullet from the camera (simplified: above the base's centre, :data:`CAMERA_ABOVE_PLATE_M`
over the top plate) to the target; a hit on a body other than the robot and the step's element more
than :data:`TARGET_TOL_M` before the target means the view is blocked, and a target beyond the
skill's ``viewDistance`` parameter (default 5 m) is too far: both fail the step. Recorded:
``distance_m``, ``dwell_s``, event ``inspect``.
"""

from __future__ import annotations

import math

from kbplanner.core.vocab import KBP
from kbplanner.knowledge.skill_kinds import local
from kbplanner.planning.pose_frames import as_pose6_list
from kbplanner.simulation.sim_world import SimWorld
from kbplanner.simulation.skills.base import Skill, Status
from kbplanner.simulation.skills.fasten import DEFAULT_DWELL_S, number

DEFAULT_VIEW_M = 5.0
CAMERA_ABOVE_PLATE_M = 0.1
TARGET_TOL_M = 0.05
TURN_RPS = 0.5


def _name(sim: SimWorld, body: int) -> str:
    """What a body is: an element or site object IRI, a static group, or the ground."""
    named = {b: k for k, b in sim.element_bodies.items()}
    named.update({b: k for k, b in sim.site_object_bodies.items()})
    if body in named:
        return named[body]
    group = next((g for g, bodies in sim.static_bodies.items() if body in bodies), None)
    return f"static {group}" if group else ("the ground" if body == sim.ground else f"body {body}")


class InspectSkill(Skill):
    """kbp:Inspect (see module docstring)."""

    kind = str(KBP.Inspect)

    def start(self) -> None:
        call = self.step
        env = self.c.env
        target = as_pose6_list(call.by_role(local(KBP.ViewTargetRole)))
        if target is None:
            self.fail("no view target: the step has no pose for its kbp:ViewTargetRole input")
            return
        self.target = (target[0], target[1], target[2])
        p = call.parameters
        self.dwell_s = number(call.by_role(local(KBP.DwellTimeRole)),
                              number(p.get("dwellTime"), DEFAULT_DWELL_S))
        max_view = number(p.get("viewDistance"), DEFAULT_VIEW_M)
        if not (math.isfinite(self.dwell_s) and self.dwell_s >= 0
                and math.isfinite(max_view) and max_view > 0):
            self.fail(f"dwell time {self.dwell_s} s must be a finite number >= 0 and view distance "
                      f"{max_view} m > 0 (kbp:dwellTime, kbp:viewDistance)")
            return
        x, y, _ = env.base_pose()
        self.eye = (x, y, env.robot_floor_z + env.robot.spec.base.height_m + CAMERA_ABOVE_PLATE_M)
        dist = math.dist(self.eye, self.target)
        self.details.update({"dwell_s": round(self.dwell_s, 3), "distance_m": round(dist, 3)})
        if dist > max_view:
            self.fail(f"the view target is {dist:.2f} m from the camera, beyond the view distance of "
                      f"{max_view:g} m")
            return
        blocked = self._blocked()
        if blocked:
            self.fail(f"the view of the target is blocked by {blocked}")
            return
        self.yaw = math.atan2(self.target[1] - y, self.target[0] - x)
        self.until: float | None = None

    def _blocked(self) -> str | None:
        import pybullet as pb

        env = self.c.env
        d = math.dist(self.eye, self.target)
        env.sync()  # the workers' and the held element's bodies where they are now
        hits = pb.rayTest(self.eye, self.target, physicsClientId=env.client)
        own = env.world_bodies.element_bodies.get(self.step.element)
        for body, _link, frac, _pos, _n in hits:
            if body < 0 or body == env.robot.body or body == own:
                continue  # nothing, the robot itself, or the element being inspected
            if frac * d < d - TARGET_TOL_M:
                return _name(env.world_bodies, body)
        return None

    def tick(self) -> Status:
        env = self.c.env
        if self.until is None:
            x, y, yaw = env.base_pose()
            dyaw = math.atan2(math.sin(self.yaw - yaw), math.cos(self.yaw - yaw))
            if abs(dyaw) > 1e-6:
                env.set_base_pose(x, y, yaw + math.copysign(min(abs(dyaw), TURN_RPS * env.dt), dyaw))
                return Status.RUNNING
            self.until = env.t + self.dwell_s
            self.c.emit("inspect", distance_m=self.details["distance_m"], dwell_s=self.details["dwell_s"])
        if env.t + 1e-9 < self.until:
            return Status.RUNNING
        return Status.SUCCESS
