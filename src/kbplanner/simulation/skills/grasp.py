"""B5 skill MM-G-1 (move manipulator and grasp): arm to the element, link it to the gripper, lift it.

Takes the step's arm poses from B4 (``initial``, ``approach``, ``pre_grasp``, ``grasp``, ``lift``) and
its base pose; the robot must stand at that base pose (within ``pose_tol_m``). The arm moves through
``approach`` and ``pre_grasp`` to ``grasp`` (joint interpolation at the joint speed); there the tool
centre point must be within 2 cm of the model's grasp point (else the step fails: the gripper
missed). The element is attached as in the paper's link attacher (a ``p.JOINT_FIXED`` constraint,
collisions with the robot filtered off; event "grasp"), then lifted to ``lift`` (event "lift").
"""

from __future__ import annotations

import math

import numpy as np

from kbplanner.planning.pose_frames import as_pose6_list
from kbplanner.planning.step_kinds import KIND_GRASP
from kbplanner.simulation.skills.base import JointPath, Skill, Status

ORDER = ("approach", "pre_grasp", "grasp")
GRASP_TOL_M = 0.02


class GraspSkill(Skill):
    """MM-G-1 (see module docstring)."""

    kind = KIND_GRASP

    def start(self) -> None:
        call = self.step
        env = self.c.env
        missing = [k for k in (*ORDER, "lift") if k not in call.arm_poses]
        if missing:
            self.fail(f"no arm poses {', '.join(missing)} in the plan (B4 did not refine this step)")
            return
        if call.base_pose is not None:
            x, y, _ = env.base_pose()
            off = math.hypot(x - call.base_pose.x, y - call.base_pose.y)
            if off > self.c.settings.pose_tol_m:
                self.fail(f"the robot stands {off:.3f} m from the pick base pose")
                return
        if env.held is not None:
            self.fail(f"the gripper already holds {env.held.element.label}")
            return
        arm = env.robot.spec.arm
        limits = arm.velocity_rps if arm is not None else None
        self.path = JointPath(env.robot.arm_positions(), [(k, call.arm_poses[k]) for k in ORDER],
                              self.c.settings.joint_speed_rps, env.control_hz, limits)
        self.lift: JointPath | None = None

    def tick(self) -> Status:
        env = self.c.env
        call = self.step
        if self.lift is None:
            sample = self.path.next()
            if sample is not None:
                env.set_arm(sample[0])
                if sample[1] != "grasp":
                    return Status.RUNNING
            # at the grasp pose: check the tool is at the grasp point, then link the element
            frame = env.element_frame(call.element)
            gp = as_pose6_list(call.by_role("GraspFrameRole"))
            e = env.element(call.element)
            assert e.local_bounds is not None
            local = np.array([*(gp[:3] if gp is not None else e.local_bounds.center), 1.0])
            target = (frame @ local)[:3]
            miss = float(np.linalg.norm(env.tool_frame()[:3, 3] - target))
            if miss > GRASP_TOL_M:
                return self.fail(f"the gripper missed the grasp point by {miss:.3f} m")
            env.attach(call.element)
            self.c.emit("grasp", tool_error_m=round(miss, 4))
            self.details["grasp_error_m"] = round(miss, 4)
            arm = env.robot.spec.arm
            limits = arm.velocity_rps if arm is not None else None
            self.lift = JointPath(env.robot.arm_positions(), [("lift", call.arm_poses["lift"])],
                                  self.c.settings.joint_speed_rps, env.control_hz, limits)
            self.c.carry_mode = "lifted"
            return Status.RUNNING
        sample = self.lift.next()
        if sample is None:
            z = env.element_frame(call.element)[2, 3]
            self.c.emit("lift", element_z_m=round(float(z), 4))
            return Status.SUCCESS
        env.set_arm(sample[0])
        env.follow()
        return Status.RUNNING
