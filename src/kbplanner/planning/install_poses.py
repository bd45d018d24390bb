"""B4, install (MM-R-1): a base pose and the arm poses to place a held element at its installed pose.

Takes the element, the :class:`~kbplanner.planning.grasp_poses.Pick` that holds it, the navigation arm
pose and the installed pose (a 4x4 site frame); gives an :class:`Install` (base pose, arm poses
``initial``/``orient``/``pre_place``/``place``/``retract``/``final``) or the reason why none was found.
The element's own installed footprint is marked occupied, the robot must not be shut in by it
(:func:`~kbplanner.planning.base_poses.escapes`), the robot holding the element must be able to drive
there from the pick base pose (:mod:`~kbplanner.planning.carry_reach`, the navigation's test with the
carry footprints; when no free base pose is reachable the reason names the element installed before
that closes the way), and a box symmetric about its vertical axis may be
placed turned by 180 degrees (:func:`~kbplanner.planning.pose_frames.target_variants`). Details in
:mod:`kbplanner.planning.manipulation`.
"""

from __future__ import annotations

import logging
import math
import zlib
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kbplanner.planning.base_poses import element_polygon, escapes, mark_polygon
from kbplanner.planning.carry import ElementProbe, Matrix
from kbplanner.planning.carry_reach import (
    CarryReach,
    carry_footprints,
    carry_leg_reason,
    first_blocker,
    reaches_alone,
)
from kbplanner.planning.grasp_poses import Pick
from kbplanner.planning.plan_model import Pose2, SkillCall
from kbplanner.planning.pose_frames import joints, shifted, target_variants, tool_frame
from kbplanner.planning.pose_search import PoseSearch
from kbplanner.world.world_types import WorldElement

log = logging.getLogger(__name__)


@dataclass
class Install:
    """An install found: where the base stands, its arm poses, and how clear the held element stays."""

    base: Pose2
    poses: dict[str, list[float]]
    note: str
    clearance_m: float = 0.0


class InstallSearch(PoseSearch):
    """The install (MM-R-1) part of the B4 search."""

    def install(self, step: SkillCall, we: WorldElement, pick: Pick, nav_q: tuple[float, ...],
                target: Matrix) -> Install | str:
        """Base and arm poses to place the element at ``target`` (or its symmetric twin).

        A solution whose held element stays clear of the robot wins; otherwise the one with the
        largest clearance (down to ``-max_arm_penetration_m``), with a note.
        """
        assert we.local_bounds is not None
        reasons = []
        best: Install | None = None
        for turned, goal in target_variants(we.local_bounds, target):
            res = self._install_target(step, we, pick, nav_q, goal)
            if isinstance(res, str):
                if res not in reasons:
                    reasons.append(res if not turned else f"turned 180 deg: {res}")
                continue
            if turned:
                res.note += ("; placed turned 180 deg about its vertical axis (its box is symmetric about "
                             "it), so the gripper can reach the face it holds")
            if res.clearance_m >= 0.0:
                return res
            if best is None or res.clearance_m > best.clearance_m:
                best = res
        if best is not None:
            log.info("%s: no install pose keeps the element clear of the robot; best overlap %.3f m",
                        we.label, -best.clearance_m)
            return best
        return "; ".join(reasons)

    def _install_target(self, step: SkillCall, we: WorldElement, pick: Pick, nav_q: tuple[float, ...],
                        target: Matrix) -> Install | str:
        assert we.local_bounds is not None
        tool = target @ pick.tie
        z_tool = tool[:3, 2]
        flat = np.array([z_tool[0], z_tool[1], 0.0])
        if np.linalg.norm(flat) < 1e-6:  # tool vertical at the target: any side
            side = None
            back = np.zeros(3)
        else:
            flat /= np.linalg.norm(flat)
            side = (-float(flat[0]), -float(flat[1]))
            back = -flat
        own = element_polygon(we.local_bounds, target)
        checker = self.checker.with_grid(mark_polygon(self.checker.grid, own))
        rng = np.random.default_rng([self.seed, zlib.crc32(we.iri.encode()), step.step])
        bases = self.candidates(tool[:3, 3], rng, side, pick.base)
        if not bases:
            return self.beyond_reach(tool[:3, 3])
        up = np.array([0.0, 0.0, 1.0])
        probe = ElementProbe(self.robot, we.local_bounds)
        tried = free_count = 0
        last = "no base pose near the installed pose is free"
        around = (float(target[0, 3]), float(target[1, 3]))  # the installed pose: the same for both turns
        reach = self._carry_reach(pick, around)
        walled: list[Pose2] = []
        turning: list[tuple[Pose2, int]] = []  # reachable only by turning the load on the way (pass found)
        no_turn = ""  # why the navigation's way of turning the load does not get to them
        best: Install | None = None
        try:
            # Pass 1: seeded samples nearest to the pick base pose; pass 2 (no clear install yet): the
            # deterministic closest free poses (PoseSearch.closest_free), independent of the seed; pass 3:
            # the base poses the robot reaches only by turning the load on the way (the navigation's last
            # resort), when no other one works.
            for pass_no in (1, 2, 3):
                if pass_no == 2:
                    bases = self.closest_free(tool[:3, 3], checker, side, pick.base)
                elif pass_no == 3:
                    if best is not None:
                        break
                    bases = [b for b, _n in turning]
                budget = tried + self.s.max_ik_bases
                for base in bases:
                    if not checker.free(self.base_fp, base.x, base.y, base.yaw):
                        continue
                    modes = self.carry_free(checker, pick.geometry, base)
                    if not modes:
                        continue
                    if pass_no < 3:
                        way = reach.way(base)
                        if way == 0:
                            walled.append(base)
                            continue
                        if way == 1:
                            turning.append((base, pass_no))
                            continue
                    else:
                        why = reach.turn_route(base)
                        if why is not None:
                            no_turn = why
                            continue
                    free_count += 1
                    if tried >= budget:
                        break
                    tried += 1
                    self.robot.set_base_pose(base.x, base.y, base.yaw)
                    res = self._install_at(tool, back, up, pick, nav_q, probe)
                    if isinstance(res, str):
                        last = res
                        continue
                    poses, clear = res
                    if not escapes(checker.grid, self.base_fp, base, radius_m=self.s.escape_radius_m):
                        last = "the robot would be shut in by the installed element"
                        continue
                    found_in = next((n for b, n in turning if b is base), 0) if pass_no == 3 else pass_no
                    how = "sampled" if found_in == 1 else "closest free"
                    which = (f"nearest to the pick base pose of {free_count} free samples" if found_in == 1
                             else "arm mount closest to the installed pose; seed-independent pass")
                    turn = ("; reached only by turning the load on the way (no carry mode drives it there "
                            "directly)" if pass_no == 3 else "")
                    note = (f"base pose: {how} ({base.x:.3f}, {base.y:.3f}, {math.degrees(base.yaw):.1f} "
                            f"deg), {which}; arrives carrying {'/'.join(modes)}{turn}; element-robot "
                            f"clearance {clear:.3f} m"
                            f"{' (the element reaches into the robot: not resolved)' if clear < 0 else ''}")
                    found = Install(base, poses, note, clear)
                    if clear >= 0.0:
                        return found
                    if best is None or clear > best.clearance_m:
                        best = found
        finally:
            probe.close()
        if best is not None:
            return best
        if turning and not tried:
            ln, wn = (pick.geometry.footprint(m).bounds_m() for m in ("normal", "narrow"))
            return (f"carry way needs the load turned: no carry mode drives the robot holding the element "
                    f"(normal {ln[2] - ln[0]:.2f} x {ln[3] - ln[1]:.2f} m, narrow {wn[2] - wn[0]:.2f} x "
                    f"{wn[3] - wn[1]:.2f} m) from the pick base pose ({pick.base.x:.2f}, {pick.base.y:.2f}) "
                    f"to any of {len(turning)} free install base pose(s) it can reach only by turning the "
                    f"load on the way, and the navigation's way of turning it fails: {no_turn}")
        if walled and not tried:
            return self._walled_reason(pick, walled, around)
        more = (f" ({len(walled)} other free base pose(s) the robot holding it cannot drive to)"
                if walled else "")
        return f"installed pose out of reach from {tried} free base pose(s) tried{more}: {last}"

    def _carry_reach(self, pick: Pick, around: tuple[float, float]) -> CarryReach:
        """The carry-leg check from the pick base pose on the current grid (one per grid, pick and place)."""
        key = (id(self.checker.grid), pick.base, id(pick.geometry), round(around[0], 1), round(around[1], 1))
        reach = self.reach_cache.get(key)
        if reach is None:
            self.reach_cache.clear()  # one grid state at a time
            reach = CarryReach(self.checker.grid, carry_footprints(pick.geometry), pick.base, around)
            self.reach_cache[key] = reach
        return reach

    def _walled_reason(self, pick: Pick, walled: list[Pose2], around: tuple[float, float]) -> str:
        """Why none of the free install base poses ``walled`` is reachable holding the element (worked out
        once per grid, pick and element: both turns of a symmetric element ask again)."""
        reach = self._carry_reach(pick, around)
        if reach.reason is None:
            goals = walled[:12]
            blocker = first_blocker(self.base_grid, self.installed, pick.geometry, pick.base, goals, around,
                                    known_closed=True)
            alone = blocker is None and reaches_alone(self.checker.grid, self.base_fp, pick.base, goals,
                                                      around)
            within = reach.margins[-1] if reach.capped else None
            reach.reason = carry_leg_reason(pick.geometry, pick.base, len(walled), alone, blocker, within)
        return reach.reason

    def _install_at(
        self,
        tool: Matrix,
        back: npt.NDArray[np.float64],
        up: npt.NDArray[np.float64],
        pick: Pick,
        nav_q: tuple[float, ...],
        probe: ElementProbe,
    ) -> tuple[dict[str, list[float]], float] | str:
        place = self.ik(tool, [pick.geometry.normal.joints], tight=True)
        if not place.reachable:
            return f"place {place.reason}"
        chain = [("pre_place", self.s.pre_place_back_m, (self.s.pre_place_up_m,)),
                 ("orient", self.s.orient_back_m, self.s.orient_up_m)]
        found = {"place": place}
        prev = place.joints
        for key, b, ups in chain:
            r = place
            for u in ups:
                r = self.ik(shifted(tool, b * back + u * up), [prev], fallback=False)
                if r.reachable:
                    break
            if not r.reachable:
                return f"{key.replace('_', '-')} pose {r.reason}"
            found[key] = r
            prev = r.joints
        retract = self.ik(shifted(tool, -self.s.retract_m * tool[:3, 2]), [place.joints], fallback=False)
        if not retract.reachable:
            return f"retract pose {retract.reason}"
        clear = math.inf
        for key in ("orient", "pre_place", "place"):
            self.robot.set_arm(found[key].joints)
            probe.place(tool_frame(self.robot, found[key].joints) @ np.linalg.inv(pick.tie))
            clear = min(clear, probe.clearance())
        self.robot.set_arm(nav_q)
        if clear < -self.s.max_arm_penetration_m:
            return f"the element would reach {-clear:.3f} m into the robot while placed"
        poses = {"initial": joints(pick.geometry.normal.joints), "orient": joints(found["orient"].joints),
                 "pre_place": joints(found["pre_place"].joints), "place": joints(place.joints),
                 "retract": joints(retract.joints), "final": joints(nav_q)}
        return poses, clear
