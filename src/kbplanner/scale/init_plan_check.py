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
footprint) must reach every destination of its unloaded navigation (the pickup locations) from its
start on the task storey's map: a pickup location on free cells the robot's footprint cannot get to
fails in ``simulate`` with "no path to the base pose".

Takes the staged project folder, the scenario name and the seed; gives a :class:`ScenarioCheck`
(installable count, the order, each failing element with its reason and fix).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from kbplanner.model.project_data import ProjectData
from kbplanner.planning.base_poses import PoseChecker
from kbplanner.planning.carry_reach import CarryReach
from kbplanner.planning.feasibility import element_verdicts
from kbplanner.planning.manipulation import refine_plan, robot_name
from kbplanner.planning.plan_model import Plan, Pose2
from kbplanner.planning.planner import plan_task
from kbplanner.robot.robot_table import load_robot_specs
from kbplanner.world.build import world_of
from kbplanner.world.maps import storey_map
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

#: The fix for a pickup location the robot alone cannot drive to.
UNREACHED_FIX = ("move the storage and its kbp:pickupLocation (scenarios/storage_*.ttl) to a spot the robot "
                 "reaches from kbp:robotStart: wider than the robot's footprint all the way, or move the "
                 "robot start (site/site_layout.ttl)")


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

    @property
    def installable(self) -> int:
        return self.total - len(self.failures)


def _unloaded_destinations(plan: Plan) -> list[tuple[str, Pose2]]:
    """(element IRI, destination) of each navigation before the element's first manipulation (the robot
    holds nothing there: it drives to the pickup location), and the base pose of that manipulation (the
    pick), where the navigation ends."""
    out: list[tuple[str, Pose2]] = []
    for e in plan.elements:
        for s in plan.steps_for(e.iri):
            dest = s.by_role("DestinationRole")
            if isinstance(dest, list) and len(dest) == 6:  # a navigation (B4 may give it a base pose too)
                x, y, _z, _r, _p, yaw = (float(v) for v in dest)  # type: ignore[arg-type,unused-ignore]
                out.append((e.iri, Pose2(x, y, yaw)))
            elif s.base_pose is not None:  # the pick: the navigation drives to its base pose
                out.append((e.iri, s.base_pose))
                break
    return out


def unreached_pickups(plan: Plan, grid: OccupancyGrid, start: Pose2) -> dict[str, str]:
    """Element IRI -> reason, for the elements whose unloaded navigation goes to a pose the robot's base
    footprint cannot reach from ``start`` on ``grid`` (the configuration-space test of the carry leg), or
    all of them when the robot stands in collision at ``start`` (the navigation fails there)."""
    spec = load_robot_specs().get(robot_name(plan))
    if spec is None:
        return {}
    fp = spec.footprint()
    reaches: dict[tuple[float, float, float], bool] = {}
    out: dict[str, str] = {}
    if not PoseChecker(grid).free(fp, start.x, start.y, start.yaw):  # navigation does not start there
        return {iri: (f"navigate to the pickup location: the robot ({spec.base.length_m:.2f} x "
                      f"{spec.base.width_m:.2f} m) at its start ({start.x:.2f}, {start.y:.2f}) stands in "
                      "collision (a storage or another object covers the start)")
                for iri, _d in _unloaded_destinations(plan)}
    for iri, dest in _unloaded_destinations(plan):
        key = (round(dest.x, 3), round(dest.y, 3), round(dest.yaw, 3))
        if key not in reaches:
            reaches[key] = CarryReach(grid, (fp,), start, (dest.x, dest.y)).reaches(dest)
        if not reaches[key]:
            out[iri] = (f"navigate to the pickup location: the robot ({spec.base.length_m:.2f} x "
                        f"{spec.base.width_m:.2f} m) cannot drive from its start ({start.x:.2f}, "
                        f"{start.y:.2f}) to the pickup location ({dest.x:.2f}, {dest.y:.2f}): no way wide "
                        "enough for its footprint on the task storey's map")
    return out


def check_scenario(stage: Path, scenario: str, task: str, seed: int,
                   progress: Callable[[str, int, int], None] | None = None) -> ScenarioCheck:
    """Plan ``task`` of the project staged in ``stage`` under ``scenario`` as ``kbplanner plan`` does
    (B1-B4), plus the robot's way to each pickup location (module docstring)."""
    data = ProjectData.load(stage, scenario=scenario)
    world = world_of(data, task_id=task)
    grid = storey_map(world).grid
    plan = plan_task(data, task, world=world)
    check = ScenarioCheck(scenario, len(plan.elements))
    if not plan.robot_id:
        check.note = "no robot of the knowledge base fits the task"
        check.failures = [Failure(e.iri, e.label, check.note, "see `kbplanner robots`")
                          for e in plan.elements]
        return check
    refined = refine_plan(plan, world, seed=seed, grid=grid, progress=progress)
    check.plan = refined
    check.order = [e.iri for e in refined.elements]
    start = refined.robot_start
    if start is None and world.robot_start is not None:
        start = Pose2(world.robot_start.x, world.robot_start.y, world.robot_start.yaw)
    unreached = unreached_pickups(refined, grid, start) if start is not None else {}
    for v in element_verdicts(refined):
        if not v.feasible:
            why = f"step {v.step} ({v.skill_id} {v.action}): {v.reason}"
            check.failures.append(Failure(v.iri, v.label, why, v.fix or ""))
        elif v.iri in unreached:
            check.failures.append(Failure(v.iri, v.label, unreached[v.iri], UNREACHED_FIX))
    log.info("init: scenario %s plans %d of %d elements installable", scenario, check.installable,
             check.total)
    return check
