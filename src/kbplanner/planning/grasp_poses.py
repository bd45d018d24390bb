"""B4, pick (MM-G-1): a base pose, a grasp and the arm poses to take an element from its storage.

Takes the element where it lies in the world (:class:`~kbplanner.world.world_types.WorldElement`), its grasp
point, the navigation arm pose and the robot; gives a :class:`Pick` (base pose, grasp, arm poses
``initial``/``approach``/``pre_grasp``/``grasp``/``lift``/``final``, the carry geometry of both carry
modes, cached per grasp) or the reason why none was found. Grasps as in :mod:`kbplanner.planning.carry`;
base poses from :class:`~kbplanner.planning.pose_search.PoseSearch`. Details in
:mod:`kbplanner.planning.manipulation`.
"""

from __future__ import annotations

import logging
import math
import zlib
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kbplanner.planning.carry import (
    CarryGeometry,
    ElementProbe,
    Grasp,
    Matrix,
    base_transform,
    carry_modes,
    carry_problem,
    grasp_candidates,
)
from kbplanner.planning.plan_model import Pose2, SkillCall
from kbplanner.planning.pose_frames import as_pose6_list, joints, pose6_matrix, shifted, tool_frame
from kbplanner.planning.pose_search import PoseSearch
from kbplanner.robot.arm_ik import IkResult
from kbplanner.world.world_types import WorldElement

log = logging.getLogger(__name__)


@dataclass
class Pick:
    """A pick found: where the base stands, the grasp, its arm poses and the carry geometry it gives."""

    base: Pose2
    grasp: Grasp
    tie: Matrix  # tool in element, from the grasp joints' forward kinematics
    poses: dict[str, list[float]]
    geometry: CarryGeometry
    note: str
    clearance_m: float = 0.0  # arm - element at grasp and lift (negative: they overlap)


class PickSearch(PoseSearch):
    """The pick (MM-G-1) part of the B4 search."""

    def pick(self, step: SkillCall, we: WorldElement, nominal: Pose2 | None, nav_q: tuple[float, ...],
             carry_seed: tuple[float, ...] | None) -> Pick | str:
        assert we.pose is not None and we.local_bounds is not None
        frame = pose6_matrix([we.pose.x, we.pose.y, we.pose.z, we.pose.roll, we.pose.pitch, we.pose.yaw])
        gp_in = as_pose6_list(step.by_role("GraspFrameRole"))
        gp: tuple[float, float, float] = (
            (gp_in[0], gp_in[1], gp_in[2]) if gp_in is not None else we.local_bounds.center)
        target = (frame @ np.array([*gp, 1.0]))[:3]
        rng = np.random.default_rng([self.seed, zlib.crc32(we.iri.encode()), step.step])
        ref = nominal or self.robot_at
        if self.horizontal_reach(float(target[2])) <= self.s.min_reach_m:
            return self.beyond_reach(target)
        bases: list[tuple[Pose2, str]] = []
        if nominal is not None:
            bases.append((nominal, "the NV-1 destination (pickup location)"))
        bases += [(b, "sampled") for b in self.candidates(target, rng, None, ref)]
        tried = free_count = 0
        best: Pick | None = None
        last_reason = "no base pose around the grasp point is free"
        # Pass 1: the pickup location and the seeded samples (nearest to the robot first); pass 2, when
        # pass 1 found no clear grasp: the deterministic closest free poses (PoseSearch.closest_free),
        # so that a pick at the edge of the arm's reach does not depend on the seed.
        for pass_no in (1, 2):
            if pass_no == 2:
                bases = [(b, "closest free") for b in self.closest_free(target, self.checker, None, ref)]
            budget = tried + self.s.max_ik_bases
            for base, how in bases:
                if not self.checker.free(self.base_fp, base.x, base.y, base.yaw):
                    continue
                free_count += 1
                if tried >= budget:
                    break
                tried += 1
                res = self._pick_from(base, how, free_count, target, frame, gp, we, nav_q, carry_seed)
                if isinstance(res, str):
                    last_reason = res
                    continue
                if res.clearance_m >= 0.0:
                    return res
                if best is None or res.clearance_m > best.clearance_m:
                    best = res
        if best is not None:
            log.info("%s: no collision-free grasp; the best reachable one overlaps by %.3f m", we.label,
                        -best.clearance_m)
            return best
        if nominal is not None and tried == 0 and free_count == 0:
            return "no free base pose near the grasp point (pickup location and samples blocked)"
        return f"grasp point out of reach from {tried} free base pose(s) tried: {last_reason}"

    def _pick_from(self, base: Pose2, how: str, free_count: int, target: npt.NDArray[np.float64],
                   frame: Matrix, gp: tuple[float, float, float], we: WorldElement, nav_q: tuple[float, ...],
                   carry_seed: tuple[float, ...] | None) -> Pick | str:
        """The best grasp from one base pose: the first clear one by tilt, else the least overlapping."""
        assert we.local_bounds is not None
        self.robot.set_base_pose(base.x, base.y, base.yaw)
        mount_h = np.array([*self.robot.spec.arm_mount_xyz, 1.0])
        mount = (base_transform(base.x, base.y, base.yaw) @ mount_h)[:2]
        toward = (float(mount[0] - target[0]), float(mount[1] - target[1]))
        norm = math.hypot(*toward) or 1.0
        seeds = [nav_q, *(self.robot.spec.poses[k] for k in ("pre_grasp",) if k in self.robot.spec.poses)]
        best: Pick | None = None
        last_reason = "grasp out of reach"
        for tilt in self.s.grasp_tilts_deg:
            direction = (toward[0] / norm, toward[1] / norm)
            done = False
            for grasp in grasp_candidates(we.local_bounds, frame, gp, direction, (tilt,)):
                if (grasp.tilt_deg, grasp.flip_x) in self.excluded_grasps:
                    continue  # its install failed (manipulation._Refiner._element_regrasp)
                g = self.ik(grasp.tool_at(frame), seeds, fallback=False)
                if not g.reachable:
                    continue
                res = self._pick_at(base, grasp, frame, we, nav_q, carry_seed, g)
                if isinstance(res, str):
                    last_reason = res
                    continue
                done = True  # larger tilts only bring the forearm closer to the element
                nearest = {"sampled": f", nearest of {free_count} free samples",
                           "closest free": " (arm mount closest to the grasp point; seed-independent pass)"
                           }.get(how, "")
                res.note = (f"base pose: {how} ({base.x:.3f}, {base.y:.3f}, "
                            f"{math.degrees(base.yaw):.1f} deg){nearest}; grasp {grasp.label}; {res.note}")
                if res.clearance_m >= 0.0:
                    return res
                if best is None or res.clearance_m > best.clearance_m:
                    best = res
            if done:
                break
        return best if best is not None else last_reason

    def _pick_at(self, base: Pose2, grasp: Grasp, frame: Matrix, we: WorldElement, nav_q: tuple[float, ...],
                 carry_seed: tuple[float, ...] | None, g: IkResult) -> Pick | str:
        """The pick with ``grasp`` from ``base``; ``g``: the grasp pose's IK (reachable), from the seeds
        ``nav_q`` and the robot's ``pre_grasp`` pose."""
        assert we.local_bounds is not None
        tool = grasp.tool_at(frame)
        # The carry footprints depend on the grasp only (cached): check them first, it is cheap and it
        # rejects most base poses next to a stack.
        tie0 = np.linalg.inv(frame) @ tool_frame(self.robot, g.joints)
        geo = self._carry_geometry(frame, tool, tie0, we, carry_seed)
        problem = carry_problem(geo)
        if problem:
            return problem
        modes = self.carry_free(self.checker, geo, base)
        if not modes:
            return "neither carry footprint is free at the pick base pose"
        z_tool = tool[:3, 2]
        poses: dict[str, list[float]] = {"initial": joints(nav_q)}
        found: dict[str, IkResult] = {}
        chain = (("pre_grasp", self.s.pre_grasp_offsets_m), ("approach", self.s.approach_offsets_m))
        for key, offsets in chain:
            for off in offsets:
                seed = found["pre_grasp"].joints if key == "approach" else g.joints
                r = self.ik(shifted(tool, -off * z_tool), [seed], fallback=False)
                if r.reachable:
                    found[key] = r
                    break
            if key not in found:
                return f"{key.replace('_', '-')} pose unreachable"
        tie = np.linalg.inv(frame) @ tool_frame(self.robot, g.joints)
        probe = ElementProbe(self.robot, we.local_bounds)
        try:
            self.robot.set_arm(g.joints)
            probe.place(frame)
            grasp_clear = probe.clearance()
            lift: tuple[IkResult, float, float] | None = None
            for h in self.s.lift_heights_m:
                r = self.ik(shifted(tool, np.array([0.0, 0.0, h])), [g.joints], fallback=False)
                if not r.reachable:
                    continue
                self.robot.set_arm(r.joints)
                probe.place(tool_frame(self.robot, r.joints) @ np.linalg.inv(tie))
                clear = probe.clearance()
                if lift is None or clear > lift[2] + 1e-4:
                    lift = (r, h, clear)
                if clear >= 0.0:
                    break
            self.robot.set_arm(nav_q)
            if lift is None:
                return "no lift pose is reachable"
            clearance = min(grasp_clear, lift[2])
            if clearance < -self.s.max_arm_penetration_m:
                return (f"the arm would reach {-clearance:.3f} m into the element at the grasp "
                        f"(more than {self.s.max_arm_penetration_m} m)")
        finally:
            probe.close()
        poses.update({"approach": joints(found["approach"].joints),
                      "pre_grasp": joints(found["pre_grasp"].joints),
                      "grasp": joints(g.joints), "lift": joints(lift[0].joints)})
        poses["final"] = poses["lift"]
        note = (f"lift {lift[1]:.2f} m; arm-element clearance {clearance:.3f} m"
                f"{' (the arm reaches into the element: not resolved)' if clearance < 0 else ''}; "
                f"carry footprints (robot frame): normal "
                f"{geo.normal.rect.length:.2f} x {geo.normal.rect.width:.2f} m, narrow "
                f"{geo.narrow.rect.length:.2f} x {geo.narrow.rect.width:.2f} m")
        return Pick(base, grasp, np.asarray(tie, dtype=np.float64), poses, geo, note, clearance)

    def _carry_geometry(self, frame: Matrix, tool: Matrix, tie: Matrix, we: WorldElement,
                        carry_seed: tuple[float, ...] | None) -> CarryGeometry:
        """Both carry modes of the element held with ``tie``, computed once per grasp and element shape.

        Keyed by the nominal grasp (the candidate's tool pose in the element frame), not by the IK's
        ``tie``, which differs within the IK tolerance from one base pose to the next.
        """
        assert we.local_bounds is not None
        nominal_tie = np.linalg.inv(frame) @ tool
        cache_key = (np.round(nominal_tie, 3).tobytes()
                     + np.round(np.asarray(we.local_bounds.as_list()), 4).tobytes() + self.method.encode())
        geo = self.carry_cache.get(cache_key)
        if geo is None:
            cseeds = [carry_seed] if carry_seed is not None else []
            geo = carry_modes(self.robot, we.local_bounds, tie, seeds=cseeds,
                              refinements=self.s.ik_refinements, method=self.method)
            self.carry_cache[cache_key] = geo
        return geo
