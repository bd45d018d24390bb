"""B4, arm and base poses per skill: refine an action-level plan with inverse kinematics.

Takes a :class:`~kbplanner.planning.plan_model.Plan` (B1-B3, from :mod:`kbplanner.planning.planner`) and the
:class:`~kbplanner.world.world_types.World` it runs in; returns a copy of the plan in which every
step of every
element has its base pose and its arm poses (joint angles of the robot's arm, radians), found with
PyBullet IK on the robot's URDF (:mod:`kbplanner.robot.arm_ik`), or is infeasible with the reason.

Per element, for the wall-frame task of the paper (NV-1, MM-G-1, NV-2, MM-R-1); other
specifications are refined step by step by skill kind:

- **NV-1** (navigation): the arm in the navigation pose, which is the skill's ``armPose`` parameter
  when that pose keeps the lidar and the camera clear and the arm off the base (checked with rays,
  :func:`kbplanner.robot.lidar.sensor_view_hits`), else the robot table's ``stow`` pose (said in the
  notes). It drives to the base pose chosen for the pick.
- **MM-G-1** (pick): the element where it lies in the world (its storage), the grasp point from
  the model; grasps as in :mod:`kbplanner.planning.carry` (straight down onto the upper face, else tilted
  towards the robot). Arm poses: ``initial`` (navigation pose), ``approach`` and ``pre_grasp``
  (back along the approach, 0.35/0.25 m and 0.10/0.05 m, the longest that is reachable), ``grasp``,
  ``lift`` (straight up 0.30 m, or less when out of reach), ``final`` (= ``lift``). The element's
  mass must not exceed the arm's payload.
- **NV-2** (navigation with object): ``carry_normal`` and ``carry_narrow`` (both carry modes,
  :func:`kbplanner.planning.carry.carry_modes`, with the skill's ``armPose`` parameter as the first IK seed),
  ``initial``/``final`` = ``carry_normal``. It drives to the base pose chosen for the install.
- **MM-R-1** (install): ``initial`` (carry), ``orient`` (the element in its installed orientation
  0.15 m back along the approach and 0.25 m up, or less when out of reach: the paper's
  intermediate pose), ``pre_place``
  (0.15 m back, 0.02 m up), ``place`` (the installed pose, IK to 5 mm and 1 degree), ``retract``
  (the tool 0.15 m back along its axis, the element left in place), ``final`` (navigation pose).

Base poses. For a pick, the NV-1 destination (the storage's pickup location) is used when the arm
reaches the grasp from there. Otherwise, and always for an install (NV-2's destination is the
element's installed pose, which is where the element goes, not where the robot stands), base poses
are sampled around the target (seeded: ``seed``, element IRI, step): the arm mount within the arm's
horizontal reach at the target's height, on the side the gripper comes from, the base turned
towards the target within 60 degrees. A candidate must be free on the storey's occupancy grid for
the base footprint (the same conservative test as the navigation's configuration space, with the
installed elements of earlier steps and the element's own installed footprint marked occupied) and
for at least one carry footprint (base + held element), and every arm pose of the step must be
reachable without the held element touching the robot. Candidates are tried in order of distance to
where the incoming path starts (the robot's previous base pose), so the choice is deterministic; it
is written into ``SkillCall.notes``. When the seeded samples give no clear pose, a second pass that
does not depend on the seed tries, per bearing and base turn, the free pose whose arm mount is
closest to the target (:meth:`~kbplanner.planning.pose_search.PoseSearch.closest_free`). An element
whose install fails is picked again with another grasp (at most ``max_regrasps``), and one whose
install is blocked by elements installed before it is moved before them
(:mod:`~kbplanner.planning.install_order`, in :func:`refine_plan`). After an install the robot must
not be shut in by what it installed (:func:`escapes`). An install base pose must be reachable from the
pick base pose by the robot holding the element, in the configuration spaces of its carry footprints
that the navigation with object plans in (:mod:`~kbplanner.planning.carry_reach`); when none is, the
reason gives the carry sizes and the element installed before that closes the way, and that element
is what the order feedback moves it before. A stud frame whose box is symmetric about its
vertical axis may be placed turned by 180 degrees about it when only that way the gripper (which
holds the face that was up at the storage) can reach. The held element should stay clear of the arm
and base; when no candidate achieves that, the best one overlapping by at most
``max_arm_penetration_m`` is used and the overlap is written in the notes. A pick also needs the
element to be on top of its stack (no element still at the storage lies on it) and its mass within
the arm's payload. When nothing works the step is infeasible with the reason, and the element's
later steps are infeasible as "skipped".

This module drives B4 element by element (:func:`refine_plan`); the search is split by what it finds:
:mod:`~kbplanner.planning.base_poses` (where the robot can stand), :mod:`~kbplanner.planning.pose_search`
(settings, IK, navigation arm pose, base-pose candidates), :mod:`~kbplanner.planning.grasp_poses`
(MM-G-1), :mod:`~kbplanner.planning.install_poses` (MM-R-1) and :mod:`~kbplanner.planning.pose_frames`
(pose values and frames).

Example:
    >>> from kbplanner.planning.planner import plan_task  # doctest: +SKIP
    >>> plan = refine_plan(plan_task(project), world, seed=7)  # doctest: +SKIP
    >>> plan.steps[1].arm_poses["grasp"]  # doctest: +SKIP
"""

from __future__ import annotations

import copy
import logging
from collections.abc import Callable

from kbplanner.planning.base_poses import PoseChecker, element_polygon, mark_polygon
from kbplanner.planning.grasp_poses import Pick, PickSearch
from kbplanner.planning.install_order import blocked_move, installable, move_before, stack_above
from kbplanner.planning.install_poses import InstallSearch
from kbplanner.planning.plan_model import Plan, Pose2, SkillCall
from kbplanner.planning.pose_frames import as_joints, as_pose6_list, joints, pose2, pose6_matrix
from kbplanner.planning.pose_search import RefineSettings
from kbplanner.planning.step_kinds import (  # B4's callers import these from here too
    KIND_GRASP,
    KIND_NAVIGATION,  # noqa: F401 - re-exported (B4 names the kinds it refines)
    KIND_NAVIGATION_WITH_OBJECT,
    KIND_RELEASE,
    NAVIGATION_KINDS,
    elements_in_order,
    robot_name,
)
from kbplanner.robot.robot_model import RobotModel
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.site_checks import check_pickup_locations
from kbplanner.world.world_types import World, WorldElement

log = logging.getLogger(__name__)

# Reasons of B4 failures that do not depend on the IK (no retry with the fallback IK).
_CARRY_WAY = ("carry way walled off", "carry way needs the load turned")
_NOT_IK_FAILURES = ("no free base pose", "the element lies under", "the element is not at a storage",
                    "out of reach from any base pose", "skipped", "the element weighs",
                    *_CARRY_WAY)


_StepState = tuple[bool, str | None, Pose2 | None, dict[str, list[float]], list[str]]
_State = tuple[list[_StepState], set[str], Pose2, PoseChecker, int]


class _Refiner(PickSearch, InstallSearch):
    """B4 for the elements of one plan, element by element (pick, install, and the navigation steps)."""

    def stacked_on(self, we: WorldElement) -> list[WorldElement]:
        """Elements of the same storage lying higher on the stack that are not picked yet."""
        if we.pose is None or we.bounds is None:
            return []
        out = []
        for e in self.world.task_elements:
            if e.iri == we.iri or e.iri in self.picked or e.storage != we.storage or e.pose is None:
                continue
            b = e.bounds
            if b is None or e.pose.z <= we.pose.z + 1e-6:
                continue
            if b.xmax > we.bounds.xmin and b.xmin < we.bounds.xmax and b.ymax > we.bounds.ymin and \
                    b.ymin < we.bounds.ymax:
                out.append(e)
        return out

    # ---- one element ---------------------------------------------------------------------------
    def element(self, iri: str) -> None:
        """B4 for one element with the IK of the settings; again with the fallback IK if that fails."""
        steps = self.plan.steps_for(iri)
        if not steps:
            return
        saved = self._state(steps)
        self.method = self.s.ik_method
        self._element_regrasp(iri, steps, saved)
        fallback = self.s.fallback_ik_method
        if fallback is None or fallback == self.method or all(s.feasible for s in steps):
            return
        first = next(s.reason for s in steps if not s.feasible) or ""
        if first.startswith(_NOT_IK_FAILURES):
            return  # another IK cannot help
        self._restore(steps, saved)
        self.method = fallback
        self._element_regrasp(iri, steps, saved)
        self.method = self.s.ik_method
        self.fallbacks += 1
        if all(s.feasible for s in steps):
            steps[0].notes.append(f"B4 arm poses by the {fallback} IK (the {self.s.ik_method} IK gave: "
                                  f"{first})")

    def grasp_used(self) -> tuple[float, bool] | None:
        """(tilt, flip) of the grasp of the last pick found, or None."""
        return self.last_grasp

    def _state(self, steps: list[SkillCall]) -> _State:
        return ([(s.feasible, s.reason, s.base_pose, dict(s.arm_poses), list(s.notes)) for s in steps],
                set(self.picked), self.robot_at, self.checker, len(self.installed))

    def _restore(self, steps: list[SkillCall], saved: _State) -> None:
        for s, (feasible, reason, base, arm, notes) in zip(steps, saved[0], strict=True):
            s.feasible, s.reason, s.base_pose, s.arm_poses, s.notes = feasible, reason, base, arm, list(notes)
        self.picked, self.robot_at, self.checker = set(saved[1]), saved[2], saved[3]
        del self.installed[saved[4]:]

    def _element_regrasp(self, iri: str, steps: list[SkillCall], saved: _State) -> None:
        """The element; when its install fails, again with another grasp (the carried element's footprint
        and the install arm poses depend on the grasp), at most ``max_regrasps`` times. When none helps,
        the first result stays (its install failure is the reason to report)."""
        self.excluded_grasps = set()
        self.last_grasp = None
        self._element(iri, steps)
        first: _State | None = None
        for _ in range(self.s.max_regrasps):
            bad = next((s for s in steps if not s.feasible), None)
            used = self.grasp_used()
            if bad is None or bad.skill_kind != KIND_RELEASE or used is None or \
                    (bad.reason or "").startswith(_CARRY_WAY):
                break  # (another grasp changes the carried footprint by centimetres: not a way through)
            if first is None:
                first = self._state(steps)
            self.excluded_grasps.add(used)
            self._restore(steps, saved)
            self._element(iri, steps)
            now = self.grasp_used()
            if all(s.feasible for s in steps) and now is not None:
                tilt, flip = now
                steps[1 if len(steps) > 1 else 0].notes.append(
                    f"grasp chosen again after the install failed with {len(self.excluded_grasps)} other "
                    f"grasp(s) (now tilt {tilt:g} deg{', tool x reversed' if flip else ''})")
                return
        if first is not None and not all(s.feasible for s in steps):
            self._restore(steps, first)

    def _element(self, iri: str, steps: list[SkillCall]) -> None:
        bad = next((i for i, s in enumerate(steps) if not s.feasible), None)
        if bad is not None:
            _skip_after(steps, bad)
            return
        if not any(s.skill_kind in (KIND_GRASP, KIND_RELEASE) for s in steps):
            _refine_in_place(steps)  # no material handled: the element is a target (marking, inspection)
            return
        we = self.world.element(iri)
        if we is None or not we.is_movable or we.pose is None or we.local_bounds is None:
            why = next((o.reason for o in self.world.omitted if o.iri == iri), "not in the world")
            first = next((i for i, s in enumerate(steps) if s.skill_kind == KIND_GRASP), 0)
            _fail(steps, first, f"the element is not at a storage in the world: {why}")
            return
        info = next((e for e in self.plan.elements if e.iri == iri), None)
        pending: SkillCall | None = None
        pick: Pick | None = None
        installed = False
        for i, s in enumerate(steps):
            want = as_joints(s.parameters.get("armPose"), len(self.robot.arm_joints))
            if s.skill_kind in NAVIGATION_KINDS:
                pending = s
                continue
            if s.skill_kind == KIND_GRASP:
                nav_q, nav_note = self.nav_pose(as_joints(pending.parameters.get("armPose"), 6)
                                                if pending is not None else None)
                above = self.stacked_on(we)
                if above:
                    names = ", ".join(sorted(e.label for e in above)[:3])
                    names += ", ..." if len(above) > 3 else ""
                    _fail(steps, i, f"the element lies under {len(above)} element(s) still at its storage "
                                    f"({names}): the plan's element order ({self.plan.order_rule}) does not "
                                    "follow the stack; give the elements kbp:workSequence (top of the stack "
                                    "first) or restack them (kbp:stackIndex)")
                    return
                mass = info.mass_kg if info is not None and info.mass_kg is not None else we.mass_kg
                payload = self.arm.payload_kg
                if mass is not None and mass > payload:
                    _fail(steps, i, f"the element weighs {mass:g} kg, more than the arm's payload of "
                                    f"{payload:g} kg ({self.robot.spec.name})")
                    return
                nominal = None
                if pending is not None:
                    dest = as_pose6_list(pending.by_role("DestinationRole"))
                    if dest is not None:
                        nominal = pose2(dest[0], dest[1], dest[5])
                carry_seed = None
                nxt = next((t for t in steps[i + 1:] if t.skill_kind == KIND_NAVIGATION_WITH_OBJECT), None)
                if nxt is not None:
                    carry_seed = as_joints(nxt.parameters.get("armPose"), 6)
                res = self.pick(s, we, nominal, nav_q, carry_seed)
                if isinstance(res, str):
                    _fail(steps, i, res)
                    return
                pick = res
                self.last_grasp = (res.grasp.tilt_deg, res.grasp.flip_x)
                self.picked.add(we.iri)
                s.base_pose = res.base
                s.arm_poses = res.poses
                s.notes.append(res.note)
                if pending is not None:
                    pending.base_pose = res.base
                    pending.arm_poses = {"initial": joints(nav_q), "final": joints(nav_q)}
                    pending.notes.append(nav_note)
                    pending.notes.append("drives to the pick base pose of the next step")
                    pending = None
                self.robot_at = res.base
                continue
            if s.skill_kind == KIND_RELEASE:
                if pick is None:
                    _fail(steps, i, "nothing is held: no pick step before this release")
                    return
                target_in = as_pose6_list(s.by_role("TargetPoseRole"))
                inst = we.installed_pose
                if target_in is None and inst is not None:
                    target_in = [inst.x, inst.y, inst.z, inst.roll, inst.pitch, inst.yaw]
                target = pose6_matrix(target_in if target_in is not None else [0.0] * 6)
                nav_q, nav_note = self.nav_pose(want)
                res_i = self.install(s, we, pick, nav_q, target)
                if isinstance(res_i, str):
                    _fail(steps, i, res_i)
                    return
                s.base_pose = res_i.base
                s.arm_poses = res_i.poses
                s.notes.append(res_i.note)
                s.notes.append(nav_note.replace("navigation arm pose", "final arm pose"))
                if pending is not None:
                    geo = pick.geometry
                    pending.base_pose = res_i.base
                    pending.arm_poses = {"initial": joints(geo.normal.joints),
                                         "carry_normal": joints(geo.normal.joints),
                                         "carry_narrow": joints(geo.narrow.joints),
                                         "final": joints(geo.normal.joints)}
                    seed_note = ("the skill's armPose was the first IK seed" if want is not None
                                 else "IK from the robot's carry pose")
                    pending.notes.append(f"carry poses by IK ({seed_note}); drives to the install base pose "
                                         "of the next step")
                    pending = None
                self.robot_at = res_i.base
                pick = None
                installed = True
                polygon = element_polygon(we.local_bounds, target)
                self.checker = self.checker.with_grid(mark_polygon(self.checker.grid, polygon))
                self.installed.append((we.iri, we.label, polygon))
                continue
            s.notes.append(f"no B4 refinement for skill kind {s.skill_kind}")
        if pending is not None:
            dest = as_pose6_list(pending.by_role("DestinationRole"))
            if dest is not None:
                pending.base_pose = pose2(dest[0], dest[1], dest[5])
                self.robot_at = pending.base_pose
        log.info("B4 %s: %s", we.label, "refined" if installed else "refined (no install step)")


def _refine_in_place(steps: list[SkillCall]) -> None:
    """B4 for steps that handle no material: a navigation drives to its destination input; the
    other kinds (tool path, fastening, inspection) work from where the robot stands."""
    for s in steps:
        if s.skill_kind in NAVIGATION_KINDS:
            dest = as_pose6_list(s.by_role("DestinationRole"))
            if dest is not None:
                s.base_pose = pose2(dest[0], dest[1], dest[5])


def _fail(steps: list[SkillCall], i: int, reason: str) -> None:
    steps[i].feasible = False
    steps[i].reason = reason
    _skip_after(steps, i)


def _skip_after(steps: list[SkillCall], i: int) -> None:
    for s in steps[i + 1:]:
        if s.feasible:
            s.feasible = False
            s.reason = (f"skipped: step {steps[i].step} ({steps[i].action_label}) of this element is "
                        "infeasible")


#: The start of the note of a plan whose B4 the caller's ``stop`` ended (:func:`refine_plan`).
STOPPED = "B4 stopped by the caller after "


def refine_plan(
    plan: Plan,
    world: World,
    *,
    seed: int,
    grid: OccupancyGrid | None = None,
    settings: RefineSettings | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    reorder: bool = True,
    stop: Callable[[Plan], bool] | None = None,
) -> Plan:
    """B4: a copy of ``plan`` with base and arm poses for every step (see module docstring).

    ``grid`` is the task storey's occupancy grid (default: :func:`kbplanner.world.maps.storey_map`
    of the world). ``progress(label, done, total)`` is called after each element. With ``reorder``,
    an element whose install B4 finds blocked by elements installed before it is moved before them
    and B4 runs again (:mod:`kbplanner.planning.install_order`; kept when more elements become
    installable, and said in ``order_rule`` and the notes).

    ``stop(plan)`` (default: never) is asked after each element of the first pass with the copy refined
    so far (the elements not reached yet keep their B1-B3 steps); when it answers True, B4 ends there and
    returns that copy, without the order feedback, its last note starting with :data:`STOPPED` (a caller
    abandons a plan that can no longer beat another: ``kbplanner init``'s storage proposals).

    Raises:
        InputFileError: the plan names a robot whose URDF cannot be loaded.
    """
    if grid is None and plan.robot_id:
        from kbplanner.world.maps import storey_map

        grid = storey_map(world).grid
    out = _refine_once(plan, world, seed=seed, grid=grid, settings=settings, progress=progress, stop=stop)
    if not reorder or not out.robot_id or grid is None or (out.notes and out.notes[-1].startswith(STOPPED)):
        return out
    used = settings or RefineSettings()
    current = plan
    tried: set[tuple[str, str]] = set()
    moves: list[str] = []
    above = stack_above(world)
    for _ in range(min(len(plan.elements), used.max_reorder_rounds)):
        move = blocked_move(current, out, above, used.blocking_radius_m, tried)
        if move is None:
            break
        tried.add(move)
        candidate_in = move_before(current, *move, above.get(move[0], set()))
        candidate = _refine_once(candidate_in, world, seed=seed, grid=grid, settings=settings,
                                 progress=progress)
        if installable(candidate) <= installable(out):
            continue
        labels = {e.iri: e.label for e in plan.elements}
        order = [e.iri for e in current.elements]
        with_it = sum(1 for i in order[order.index(move[1]):order.index(move[0])]
                      if i in above.get(move[0], set()))
        lying = f" (with the {with_it} element(s) lying on it)" if with_it else ""
        moves.append(f"{labels[move[0]]}{lying} before {labels[move[1]]}")
        current, out = candidate_in, candidate
    if moves:
        text = (f"B4 moved {'; '.join(moves)} (the install base poses were blocked by the elements "
                "installed before)")
        out.order_rule = f"{plan.order_rule}; then {text}"
        out.notes.append(text)
    return out


def _refine_once(
    plan: Plan,
    world: World,
    *,
    seed: int,
    grid: OccupancyGrid | None,
    settings: RefineSettings | None,
    progress: Callable[[str, int, int], None] | None,
    stop: Callable[[Plan], bool] | None = None,
) -> Plan:
    """B4 once, in the plan's order (until ``stop`` answers True: :func:`refine_plan`)."""
    out = copy.deepcopy(plan)
    if not out.robot_id:
        out.notes.append("B4 not run: no robot selected")
        return out
    if grid is None:
        from kbplanner.world.maps import storey_map

        grid = storey_map(world).grid
    check_pickup_locations(world, grid)  # a declared location is used, or the run stops (exit 2)
    robot = RobotModel.load(robot_name(out))
    robot.floor_z = float(out.storey_elevation_m)  # the robot works on the task's storey
    fallbacks = 0
    stopped = ""
    try:
        if robot.spec.arm is None:
            for s in out.steps:
                if s.skill_kind in (KIND_GRASP, KIND_RELEASE) and s.feasible:
                    s.feasible = False
                    s.reason = f"robot {out.robot_id} has no arm"
            return out
        refiner = _Refiner(out, world, robot, grid, seed, settings or RefineSettings())
        order = elements_in_order(out)
        for n, iri in enumerate(order, start=1):
            refiner.element(iri)
            if progress is not None:
                progress(iri, n, len(order))
            if stop is not None and stop(out):
                stopped = f"{STOPPED}{n} of {len(order)} elements"
                break
        fallbacks = refiner.fallbacks
    finally:
        robot.close()
    used = settings or RefineSettings()
    again = (f"; {fallbacks} element(s) tried again with the {used.fallback_ik_method} IK"
             if fallbacks else "")
    out.notes.append(f"B4: arm and base poses by the {used.ik_method} IK (seed {seed}){again}")
    if stopped:
        out.notes.append(stopped)
    return out
