"""B5 skill kind kbp:Fasten: hold a tool pose for a dwell time, pressing with a contact force (anchor, screw).

The tool pose is the step's ``kbp:TargetPoseRole`` input (site frame; roll, pitch, yaw orient the
tool). From where the base stands (a navigation step brings it there), the arm's inverse kinematics
(:func:`kbplanner.robot.arm_ik.solve_ik`, collision-checked) gives the joint angles; the arm moves
there in joint space, holds for the dwell time (the ``kbp:DwellTimeRole`` input, else the skill's
``dwellTime`` parameter, default 2 s), emitting ``fasten`` with the contact force (the
``kbp:ContactForceRole`` input, else the ``contactForce`` parameter, default 0 N), and returns to the
arm pose it started from. Simplification: the force is not simulated as a contact; it is checked
against the arm's payload (force / 9.81 m/s2 must not exceed the payload in kg) and recorded.
A pose out of reach, a robot without an arm or a force above the payload is a failed step.
"""

from __future__ import annotations

import math

from kbplanner.core.vocab import KBP
from kbplanner.knowledge.skill_kinds import local
from kbplanner.planning.pose_frames import as_pose6_list
from kbplanner.simulation.skills.base import JointPath, Skill, Status

DEFAULT_DWELL_S = 2.0
G = 9.81


def number(value: object, default: float) -> float:
    """A float from a step value; ``default`` when the value is absent (None).

    A value that is not a number becomes NaN, so that the caller's range check fails the step with
    the value named, rather than using the default silently.
    """
    if value is None:
        return default
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return math.nan


class FastenSkill(Skill):
    """kbp:Fasten (see module docstring)."""

    kind = str(KBP.Fasten)

    def start(self) -> None:
        call = self.step
        env = self.c.env
        arm = env.robot.spec.arm
        if arm is None:
            self.fail(f"the robot {env.robot.spec.name} has no arm to hold a tool pose")
            return
        target = as_pose6_list(call.by_role(local(KBP.TargetPoseRole)))
        if target is None:
            self.fail("no tool pose: the step has no pose for its kbp:TargetPoseRole input")
            return
        p = call.parameters
        self.dwell_s = number(call.by_role(local(KBP.DwellTimeRole)),
                              number(p.get("dwellTime"), DEFAULT_DWELL_S))
        force = number(call.by_role(local(KBP.ContactForceRole)), number(p.get("contactForce"), 0.0))
        if not (math.isfinite(self.dwell_s) and self.dwell_s >= 0 and math.isfinite(force) and force >= 0):
            self.fail(f"dwell time {self.dwell_s} s and contact force {force} N must be finite numbers >= 0 "
                      "(kbp:dwellTime, kbp:contactForce)")
            return
        payload = arm.payload_kg
        if force / G > payload:
            self.fail(f"contact force {force:g} N is more than the arm's payload of {payload:g} kg "
                      f"({payload * G:.0f} N)")
            return
        from kbplanner.robot.arm_ik import solve_ik  # only a fastening step needs the IK

        ik = solve_ik(env.robot, tuple(target[:3]), tuple(target[3:]))  # type: ignore[arg-type]
        if not ik.reachable:
            self.fail(f"the tool pose is out of reach from where the robot stands: {ik.reason}")
            return
        self.start_q = env.robot.arm_positions()
        self.path = JointPath(self.start_q, [("tool pose", ik.joints)], self.c.settings.joint_speed_rps,
                              env.control_hz, arm.velocity_rps)
        self.back: JointPath | None = None
        self.held_until: float | None = None
        self.details.update({"dwell_s": round(self.dwell_s, 3), "force_n": round(force, 3),
                             "tool_error_m": round(ik.position_error_m, 4)})

    def tick(self) -> Status:
        env = self.c.env
        if self.held_until is None:
            sample = self.path.next()
            if sample is not None:
                env.set_arm(sample[0])
                if not self.path.done:
                    return Status.RUNNING
            self.held_until = env.t + self.dwell_s
            self.c.emit("fasten", dwell_s=self.details["dwell_s"], force_n=self.details["force_n"])
            return Status.RUNNING
        if env.t + 1e-9 < self.held_until:
            return Status.RUNNING
        if self.back is None:
            arm = env.robot.spec.arm
            assert arm is not None
            self.back = JointPath(env.robot.arm_positions(), [("back", self.start_q)],
                                  self.c.settings.joint_speed_rps, env.control_hz, arm.velocity_rps)
        sample = self.back.next()
        if sample is not None:
            env.set_arm(sample[0])
            return Status.RUNNING
        return Status.SUCCESS
