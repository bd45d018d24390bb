"""B5 skill MM-R-1 (move manipulator and release): place the held element at its installed pose.

Takes the step's arm poses from B4 (``orient``, ``pre_place``, ``place``, ``retract``, ``final``) and
the installed pose (the step's ``target pose`` input, else the element's installed pose). The arm
turns the element into its installed orientation in front of the robot (``orient``: the paper's
intermediate pose), brings it to ``pre_place`` and ``place``; there the element is released (the
constraint removed, event "release") and fixed in place (a static body where it is, event "fix",
with its position and orientation error against the installed pose: a stud frame whose box is
symmetric about its vertical axis may be placed turned by 180 degrees about it, and the error is
taken against the nearer of the two). An error above the tolerance (2 cm, 2 degrees by default) is a
failed step. The arm then retracts and returns to its final (navigation) pose.
"""

from __future__ import annotations

import math

import numpy as np

from kbplanner.planning.pose_frames import as_pose6_list, pose6_matrix, target_variants
from kbplanner.planning.step_kinds import KIND_RELEASE
from kbplanner.simulation.sim_env import angle_between
from kbplanner.simulation.skills.base import JointPath, Skill, Status

ORDER = ("orient", "pre_place", "place")
AFTER = ("retract", "final")


class ReleaseSkill(Skill):
    """MM-R-1 (see module docstring)."""

    kind = KIND_RELEASE

    def start(self) -> None:
        call = self.step
        env = self.c.env
        missing = [k for k in (*ORDER, *AFTER) if k not in call.arm_poses]
        if missing:
            self.fail(f"no arm poses {', '.join(missing)} in the plan (B4 did not refine this step)")
            return
        if env.held is None or env.held.element.iri != call.element:
            self.fail("the gripper does not hold this element")
            return
        if call.base_pose is not None:
            x, y, _ = env.base_pose()
            off = math.hypot(x - call.base_pose.x, y - call.base_pose.y)
            if off > self.c.settings.pose_tol_m:
                self.fail(f"the robot stands {off:.3f} m from the install base pose")
                return
        target = as_pose6_list(call.by_role("TargetPoseRole"))
        e = env.element(call.element)
        if target is None and e.installed_pose is not None:
            p = e.installed_pose
            target = [p.x, p.y, p.z, p.roll, p.pitch, p.yaw]
        if target is None:
            self.fail("no target pose: neither a 'target pose' input nor an installed pose")
            return
        self.target = pose6_matrix(target)
        self.path = self._path(ORDER)
        self.after: JointPath | None = None

    def _path(self, keys: tuple[str, ...]) -> JointPath:
        env = self.c.env
        arm = env.robot.spec.arm
        limits = arm.velocity_rps if arm is not None else None
        return JointPath(env.robot.arm_positions(), [(k, self.step.arm_poses[k]) for k in keys],
                         self.c.settings.joint_speed_rps, env.control_hz, limits)

    def tick(self) -> Status:
        env = self.c.env
        if self.after is None:
            sample = self.path.next()
            if sample is not None:
                env.set_arm(sample[0])
                env.follow()
                if sample[1] == "orient":
                    self.c.carry_mode = "placing"
                if sample[1] != "place":
                    return Status.RUNNING
            return self._release()
        sample = self.after.next()
        if sample is None:
            return self.fail(self.reason) if self.reason else Status.SUCCESS
        env.set_arm(sample[0])
        return Status.RUNNING

    def _release(self) -> Status:
        env = self.c.env
        call = self.step
        s = self.c.settings
        e = env.element(call.element)
        assert e.local_bounds is not None
        frame = env.element_frame(call.element)
        env.detach()
        self.c.carry_mode = ""
        self.c.emit("release")
        env.fix(call.element)
        best = None
        for turned, goal in target_variants(e.local_bounds, self.target):
            pos = float(np.linalg.norm(frame[:3, 3] - goal[:3, 3]))
            ang = math.degrees(angle_between(frame, goal))
            if best is None or (ang, pos) < (best[1], best[0]):
                best = (pos, ang, turned)
        assert best is not None
        pos_err, ang_err, turned = best
        self.details.update(placement_error_m=round(pos_err, 5), placement_error_deg=round(ang_err, 4),
                            placed_turned=turned)
        self.c.emit("fix", placement_error_m=round(pos_err, 5), placement_error_deg=round(ang_err, 4),
                    turned=turned)
        if pos_err > s.place_tol_m or ang_err > s.place_tol_deg:
            self.reason = (f"placed {pos_err:.3f} m / {ang_err:.2f} deg from the installed pose (tolerance "
                           f"{s.place_tol_m} m / {s.place_tol_deg} deg)")
        self.after = self._path(AFTER)
        return Status.RUNNING
