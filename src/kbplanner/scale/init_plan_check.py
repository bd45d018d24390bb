"""``kbplanner init`` (issue 10), step 5: a storage proposal is checked with the planner's own checks.

A scenario init proposes (frame storages, pickup locations, stacks) is loaded as ``kbplanner plan``
loads it and planned with the same code: B1-B3 (:func:`kbplanner.planning.planner.plan_task`) and B4
(:func:`kbplanner.planning.manipulation.refine_plan`: stack, base poses on the occupancy grid, inverse
kinematics, the carry leg of :mod:`kbplanner.planning.carry_reach` with the carry footprints, and the
install-order feedback that moves an element whose base poses later elements block before them).
The scenario is checked without a ``kbp:workSequence``, so that B4 may reorder; the order it ends with
is the one init then writes.

One check B4 does not make is added, with the same configuration-space test the carry leg uses: the
robot alone (its base footprint, :class:`~kbplanner.planning.carry_reach.CarryReach` with one
footprint) must reach every destination of its unloaded navigation (the pickup locations) from where
it stands - its start for the first element, then the base pose it installed the element before from -
on the task storey's map with the elements installed so far marked, as the simulation drives: a pickup
location the robot's footprint cannot get to fails in ``simulate`` with "no path to the base pose".
When an element installed before closes that way, it is named (``pickup way closed by``), and init
moves this element before it (:func:`kbplanner.scale.init_proposals.next_move`).

Takes the staged project folder, the scenario name and the seed; gives a :class:`ScenarioCheck`
(installable count, the order, each failing element with its reason and fix). Given ``beat`` (what the
best proposal so far installs), the check is abandoned as soon as the proposal can no longer install more
(B4's ``stop`` hook, :class:`Bound`: the elements B4 failed so far, and those whose pickup way is closed,
leave at most ``beat`` installable); it is then marked ``abandoned`` and is never kept. A proposal is not
abandoned while one of its failed elements is one B4's install-order feedback would move (its reorder
rounds, which run after the first pass, could still rescue it and the elements under it in its stack).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import shapely

from kbplanner.model.project_data import ProjectData
from kbplanner.planning.base_poses import PoseChecker, element_polygon, mark_polygon
from kbplanner.planning.carry_reach import CarryReach
from kbplanner.planning.feasibility import element_verdicts
from kbplanner.planning.install_order import blocked_move, installable, stack_above
from kbplanner.planning.manipulation import KIND_RELEASE, STOPPED, elements_in_order, refine_plan, robot_name
from kbplanner.planning.plan_model import Plan, Pose2, SkillCall
from kbplanner.planning.planner import plan_task
from kbplanner.planning.pose_frames import as_pose6_list, pose6_matrix
from kbplanner.planning.pose_search import RefineSettings
from kbplanner.robot.robot_table import load_robot_specs
from kbplanner.world.build import world_of
from kbplanner.world.footprint import Footprint
from kbplanner.world.maps import storey_map
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import World

log = logging.getLogger(__name__)

#: The fix for a pickup location the robot alone cannot drive to.
UNREACHED_FIX = ("move the storage and its kbp:pickupLocation (scenarios/storage_*.ttl) to a spot the robot "
                 "reaches from kbp:robotStart: wider than the robot's footprint all the way, or move the "
                 "robot start (site/site_layout.ttl)")

#: The fix for a pickup location that an element installed before walls off.
CLOSED_FIX = ("install the element earlier: move it before the element named in the scenario's "
              "kbp:workSequence (scenarios/storage_*.ttl) and lay it higher in its stack (kbp:stackIndex)")


@dataclass(frozen=True)
class Failure:
    """An element the plan of a proposal cannot install: its label, why and the fix."""

    iri: str
    label: str
    reason: str
    fix: str


@dataclass
class ScenarioCheck:
    """The plan of one storage proposal: how many elements it installs, in which order, which fail."""

    scenario: str
    total: int
    order: list[str] = field(default_factory=list)  # element IRIs in the order B4 ended with
    failures: list[Failure] = field(default_factory=list)
    note: str = ""  # why nothing was planned (no robot fits), else empty
    plan: Plan | None = None  # the plan refined by B4 (None: no robot fits)
    abandoned: str = ""  # why B4 was stopped before the end (it could no longer beat the best), else empty

    @property
    def installable(self) -> int:
        return self.total - len(self.failures)


def _unloaded_destinations(plan: Plan, iri: str) -> list[Pose2]:
    """The destinations of element ``iri``'s navigations before its first manipulation (the robot holds
    nothing there: it drives to the pickup location), and the base pose of that manipulation (the
    pick), where the navigation ends."""
    out: list[Pose2] = []
    for s in plan.steps_for(iri):
        dest = s.by_role("DestinationRole")
        if isinstance(dest, list) and len(dest) == 6:  # a navigation (B4 may give it a base pose too)
            x, y, _z, _r, _p, yaw = (float(v) for v in dest)  # type: ignore[arg-type,unused-ignore]
            out.append(Pose2(x, y, yaw))
        elif s.base_pose is not None:  # the pick: the navigation drives to its base pose
            out.append(s.base_pose)
            break
    return out


def _release(plan: Plan, iri: str) -> SkillCall | None:
    """The release step of an element the plan installs (every step feasible), else None."""
    steps = plan.steps_for(iri)
    if not steps or not all(s.feasible for s in steps):
        return None
    return next((s for s in reversed(steps) if s.skill_kind == KIND_RELEASE and s.base_pose is not None),
                None)


def installed_polygon(plan: Plan, world: World, iri: str) -> shapely.Geometry | None:
    """Element ``iri``'s floor polygon at its installed pose (as B4 and the simulation mark it on the map),
    when the plan installs it, else None."""
    release = _release(plan, iri)
    we = world.element(iri)
    if release is None or we is None or we.local_bounds is None:
        return None
    target = as_pose6_list(release.by_role("TargetPoseRole"))
    inst = we.installed_pose
    if target is None and inst is not None:
        target = [inst.x, inst.y, inst.z, inst.roll, inst.pitch, inst.yaw]
    return None if target is None else element_polygon(we.local_bounds, pose6_matrix(target))


def installed_polygons(plan: Plan, world: World) -> dict[str, shapely.Geometry]:
    """Element IRI -> its floor polygon at its installed pose (as B4 and the simulation mark it on the
    map), for the elements the plan installs."""
    out: dict[str, shapely.Geometry] = {}
    for e in plan.elements:
        poly = installed_polygon(plan, world, e.iri)
        if poly is not None:
            out[e.iri] = poly
    return out


def _way_closed_by(grid: OccupancyGrid, installed: list[tuple[str, str, shapely.Geometry]], fp: Footprint,
                   start: Pose2, dest: Pose2) -> tuple[str, str] | None:
    """The first element of ``installed`` (in install order) whose footprint, added to ``grid`` with those
    before it, closes the robot's way from ``start`` to ``dest``; None when the way is closed without
    them (bisection: reachability only shrinks as elements are added)."""
    def reachable(k: int) -> bool:
        g = grid
        for _iri, _label, poly in installed[:k]:
            g = mark_polygon(g, poly)
        return CarryReach(g, (fp,), start, (dest.x, dest.y)).reaches(dest)

    if not installed or not reachable(0):
        return None
    lo, hi = 0, len(installed)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if reachable(mid):
            lo = mid
        else:
            hi = mid
    return installed[hi - 1][0], installed[hi - 1][1]


class PickupWays:
    """The robot's way to each pickup location, followed element by element in install order as the
    simulation drives it (:func:`unreached_pickups`): :meth:`follow` judges the next element and moves
    the robot to where it installed it, with its installed footprint marked on the map."""

    def __init__(self, plan: Plan, grid: OccupancyGrid, start: Pose2) -> None:
        spec = load_robot_specs().get(robot_name(plan))
        self.fp = spec.footprint() if spec is not None else None
        self.size = ("" if spec is None else
                     f"the robot ({spec.base.length_m:.2f} x {spec.base.width_m:.2f} m)")
        self.grid, self.start, self.here, self.g = grid, start, start, grid
        self.installed: list[tuple[str, str, shapely.Geometry]] = []
        self.stuck = self.fp is not None and not PoseChecker(grid).free(self.fp, start.x, start.y, start.yaw)

    def follow(self, plan: Plan, iri: str, label: str, polygon: shapely.Geometry | None) -> str | None:
        """Why the robot cannot drive to element ``iri``'s pickup location, or None; then, when the plan
        installs the element and the way was open, the robot stands where it installed it and
        ``polygon`` (:func:`installed_polygon`) is marked on the map."""
        if self.fp is None:
            return None
        start, here = self.start, self.here
        if self.stuck:  # navigation does not start there
            return (f"navigate to the pickup location: {self.size} at its start ({start.x:.2f}, "
                    f"{start.y:.2f}) stands in collision (a storage or another object covers the start)"
                    if _unloaded_destinations(plan, iri) else None)
        for dest in _unloaded_destinations(plan, iri):
            if CarryReach(self.g, (self.fp,), here, (dest.x, dest.y)).reaches(dest):
                continue
            text = (f"navigate to the pickup location: {self.size} cannot drive from "
                    + (f"its start ({here.x:.2f}, {here.y:.2f})" if here is start else
                       f"where it installed the element before ({here.x:.2f}, {here.y:.2f})")
                    + f" to the pickup location ({dest.x:.2f}, {dest.y:.2f}): no way wide enough for its "
                    "footprint on the task storey's map"
                    + (f" with the {len(self.installed)} element(s) installed before it" if self.installed
                       else ""))
            closed = (_way_closed_by(self.grid, self.installed, self.fp, here, dest) if self.installed
                      else None)
            if closed is not None:
                text += (f"; the way is open until {closed[1]} is installed "
                         f"({PICKUP_BLOCKER_MARK}{closed[0]}): install this element before {closed[1]}")
            return text  # not installed: the robot stays where it was
        release = _release(plan, iri)
        if release is None or release.base_pose is None:
            return None
        self.here = release.base_pose
        if polygon is not None:
            self.g = mark_polygon(self.g, polygon)
            self.installed.append((iri, label, polygon))
        return None


def unreached_pickups(plan: Plan, grid: OccupancyGrid, start: Pose2,
                      polygons: Mapping[str, shapely.Geometry] | None = None) -> dict[str, str]:
    """Element IRI -> reason, for the elements whose unloaded navigation goes to a pose the robot's base
    footprint cannot reach (the configuration-space test of the carry leg), or all of them when the
    robot stands in collision at ``start`` (the navigation fails there).

    The way is followed as the simulation drives it (:class:`PickupWays`): from ``start`` for the first
    element, then from where the robot stood to install the element before, on ``grid`` with the elements
    installed so far marked (``polygons``: :func:`installed_polygons`; without them the map stays as it
    is). A way closed by an element installed before names it (``pickup way closed by <iri>``): installing
    this element first opens it (:func:`pickup_blocker`)."""
    ways = PickupWays(plan, grid, start)
    out: dict[str, str] = {}
    for e in plan.elements:
        why = ways.follow(plan, e.iri, e.label, (polygons or {}).get(e.iri))
        if why is not None:
            out[e.iri] = why
    return out


PICKUP_BLOCKER_MARK = "pickup way closed by "


def pickup_blocker(reason: str) -> str | None:
    """The IRI of the element named as closing the way to the pickup in a reason of
    :func:`unreached_pickups`."""
    i = reason.find(PICKUP_BLOCKER_MARK)
    if i < 0:
        return None
    return reason[i + len(PICKUP_BLOCKER_MARK):].split(")", 1)[0].strip() or None


def cannot_beat(beat: int, plan: Plan, unreached: int = 0) -> bool:
    """Whether a plan B4 has refined so far can no longer install more than ``beat`` elements: its
    elements with an infeasible step (B4's first pass never makes one feasible again), and the
    ``unreached`` others whose pickup location the robot cannot drive to, leave at most ``beat``."""
    return installable(plan) - unreached <= beat


def reorderable(plan: Plan, refined: Plan, above: Mapping[str, set[str]],
                radius_m: float = RefineSettings().blocking_radius_m) -> list[str]:
    """The elements of ``refined`` (B4's first pass so far on the B1-B3 ``plan``) that B4's install-order
    feedback would move before an element installed earlier
    (:func:`~kbplanner.planning.install_order.blocked_move`, in its order): its reorder rounds could still
    rescue them, and with them the elements under them in their stacks."""
    out: list[str] = []
    tried: set[tuple[str, str]] = set()
    others = [e.iri for e in plan.elements]
    while (move := blocked_move(plan, refined, above, radius_m, tried)) is not None:
        out.append(move[0])
        tried.update((move[0], other) for other in others)
    return out


class Bound:
    """B4's ``stop`` for a proposal that must install more than ``beat`` elements to be kept: asked after
    each element B4 refined, it follows the robot's way to that element's pickup location
    (:class:`PickupWays`, in the order the check after B4 follows it) and answers True as soon as the
    elements B4 failed and those whose pickup way is closed leave at most ``beat`` (:func:`cannot_beat`)
    and none of the failed elements is one B4's reorder rounds could rescue (:func:`reorderable`, given
    ``above``, the stacks of :func:`~kbplanner.planning.install_order.stack_above`; None: B4 runs
    without reordering).
    """

    def __init__(self, beat: int, plan: Plan, grid: OccupancyGrid, start: Pose2 | None,
                 polygon: Callable[[Plan, str], shapely.Geometry | None],
                 above: Mapping[str, set[str]] | None = None) -> None:
        self.beat, self.polygon, self.plan, self.above = beat, polygon, plan, above
        self.held: list[str] = []  # the failed elements B4 could still move, when it last held off the stop
        self.order = elements_in_order(plan)
        self.labels = {e.iri: e.label for e in plan.elements}
        same = self.order == [e.iri for e in plan.elements]  # else only B4's own failures count
        self.ways = PickupWays(plan, grid, start) if start is not None and same else None
        self.unreached: dict[str, str] = {}  # element IRI -> why its pickup way is closed (B4 installs it)
        self.done = 0

    def __call__(self, plan: Plan) -> bool:
        iri = self.order[self.done]
        self.done += 1
        if self.ways is not None:
            why = self.ways.follow(plan, iri, self.labels[iri], self.polygon(plan, iri))
            if why is not None and all(s.feasible for s in plan.steps_for(iri)):
                self.unreached[iri] = why
        if not cannot_beat(self.beat, plan, len(self.unreached)):
            return False
        self.held = [] if self.above is None else reorderable(self.plan, plan, self.above)
        return not self.held


def check_scenario(stage: Path, scenario: str, task: str, seed: int,
                   progress: Callable[[str, int, int], None] | None = None,
                   loaded: tuple[ProjectData, World, OccupancyGrid] | None = None,
                   beat: int | None = None) -> ScenarioCheck:
    """Plan ``task`` of the project staged in ``stage`` under ``scenario`` as ``kbplanner plan`` does
    (B1-B4), plus the robot's way to each pickup location (module docstring). ``loaded``: the project
    as staged now, its world of ``task`` and the task storey's grid, when the caller has them (else
    loaded here). ``beat``: the check is abandoned (``abandoned`` says when) as soon as so many elements
    fail (in B4, or on the way to their pickup location) that at most ``beat`` are left installable
    (:class:`Bound`; None: planned to the end); a check that is not abandoned is the same as without
    ``beat``."""
    if loaded is None:
        data = ProjectData.load(stage, scenario=scenario)
        world = world_of(data, task_id=task)
        grid = storey_map(world).grid
    else:
        data, world, grid = loaded
    plan = plan_task(data, task, world=world)
    check = ScenarioCheck(scenario, len(plan.elements))
    if not plan.robot_id:
        check.note = "no robot of the knowledge base fits the task"
        check.failures = [Failure(e.iri, e.label, check.note, "see `kbplanner robots`")
                          for e in plan.elements]
        return check
    start = plan.robot_start
    if start is None and world.robot_start is not None:
        start = Pose2(world.robot_start.x, world.robot_start.y, world.robot_start.yaw)
    bound = (None if beat is None else
             Bound(beat, plan, grid, start, lambda p, iri: installed_polygon(p, world, iri),
                   stack_above(world)))
    refined = refine_plan(plan, world, seed=seed, grid=grid, progress=progress, stop=bound)
    check.plan = refined
    check.order = [e.iri for e in refined.elements]
    if bound is not None and refined.notes and refined.notes[-1].startswith(STOPPED):
        unreached = bound.unreached
    else:
        unreached = ({} if start is None else
                     unreached_pickups(refined, grid, start, installed_polygons(refined, world)))
    for v in element_verdicts(refined):
        if not v.feasible:
            why = f"step {v.step} ({v.skill_id} {v.action}): {v.reason}"
            check.failures.append(Failure(v.iri, v.label, why, v.fix or ""))
        elif v.iri in unreached:
            why = unreached[v.iri]
            check.failures.append(Failure(v.iri, v.label, why, CLOSED_FIX if pickup_blocker(why) else
                                          UNREACHED_FIX))
    if bound is not None and refined.notes and refined.notes[-1].startswith(STOPPED):
        check.abandoned = (f"abandoned after {refined.notes[-1].removeprefix(STOPPED)}: "
                           f"{len(check.failures)} cannot be installed, so at most {check.installable} "
                           f"of {check.total} can (the best so far installs {beat})")
        log.info("init: scenario %s %s", scenario, check.abandoned)
        return check
    log.info("init: scenario %s plans %d of %d elements installable", scenario, check.installable,
             check.total)
    return check
