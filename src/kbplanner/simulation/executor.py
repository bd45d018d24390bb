# Over 500 lines: B5 run loop plus its safety bookkeeping (collisions, monitoring totals); next to split.
"""B5, plan execution: the robot does the refined plan in PyBullet; everything is recorded.

Takes a loaded :class:`~kbplanner.model.project_data.ProjectData`, a plan refined by B4
(:func:`kbplanner.planning.manipulation.refine_plan`) and a seed; returns a :class:`SimulationResult` (outcome
per element and per action, durations, events, paths of the files written) and writes a run
directory (atomically: :func:`kbplanner.core.outputs.run_directory`).

The run: the world at the plan's date (:func:`kbplanner.world.build.build_world`, unless given) is loaded
with the robot at its start and the workers walking their routes
(:func:`kbplanner.simulation.workers.plan_workers`,
seeded) in a :class:`~kbplanner.simulation.sim_env.SimEnv`. Elements are done in the plan's order. An element
with an infeasible step (B1-B4) fails at once with that step's reason, and the robot does not move
for it. Otherwise each step's skill is taken from the one table :data:`kbplanner.simulation.skills.SKILLS` by
its skill kind (a kind without an implementation fails the step: "no executor for skill kind X"),
set up with the run context, initialised with the step, updated once per control period (the clock
then advances: workers move, the held element follows the tool) until it succeeds or fails, then
terminated. A failed step ends its element (a held element is put back at its storage, not
simulated; event "put_back") and the run goes on with the next element.

Files (see docs/simulation.md, "Executor"): ``trajectories.csv`` and ``events.jsonl``
(:mod:`kbplanner.simulation.recorder`), ``metrics.json`` (durations per action, element and in total, path
lengths, stops, replans, placement errors, simulated time), ``timing.json`` (wall-clock figures:
OMPL planning times, wall time, real-time factor; the only file that differs between two runs with
the same inputs and seed), ``footprints.json`` (robot and carried elements per carry mode, robot
frame), ``manifest.json`` (project, scenario, seed, input hashes, versions, plan digest),
``plan.json`` (the refined plan) and ``keyframes/*.png`` (first grasp, first rotation of each kind,
first install, end).

Example:
    >>> result = simulate(project, plan, seed=7, out_dir=Path("runs/outside"))  # doctest: +SKIP
    >>> result.all_installed, round(result.sim_time_s)  # doctest: +SKIP
    (True, 2231)
"""

from __future__ import annotations

import hashlib
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kbplanner.core.errors import KbplannerError
from kbplanner.core.outputs import (
    atomic_write_bytes,
    atomic_write_text,
    input_hashes,
    run_directory,
    versions,
    write_json,
)
from kbplanner.planning.carry import NARROW, NORMAL, geometry_from_joints, pose_of, rect_dict
from kbplanner.planning.plan_model import Plan, SkillCall
from kbplanner.planning.step_kinds import KIND_NAVIGATION_WITH_OBJECT, elements_in_order, robot_name
from kbplanner.simulation.keyframes import render_png
from kbplanner.simulation.path_quality import ArmClock, path_quality
from kbplanner.simulation.recorder import Recorder, clean
from kbplanner.simulation.safety import ContactMonitor, safety_summary
from kbplanner.simulation.separation import SsmParameters, hazard_rects
from kbplanner.simulation.sim_env import SimEnv
from kbplanner.simulation.skills import ExecSettings, RunContext, Status, skill_for
from kbplanner.simulation.skills.navigation import NavigationSkill
from kbplanner.simulation.social_force import Obstacle
from kbplanner.world.footprint import Rect
from kbplanner.world.world_types import World

if TYPE_CHECKING:
    from kbplanner.model.project_data import ProjectData
    from kbplanner.simulation.workers import WorkerMotion
    from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

ProgressFn = Callable[[str, int, int], None]

SUCCEEDED = "succeeded"
FAILED = "failed"
SKIPPED = "skipped"
INSTALLED = "installed"
KEYFRAME_EVENTS = ("grasp", "rotate_to_narrow", "rotate_back", "fix")
WORKER_HORIZON_S_PER_STEP = 120.0  # worker motions are planned this far ahead per plan step (+ 30 min)
MAX_STEP_S = 4 * 3600.0  # a step still running after this much simulated time fails


@dataclass
class StepOutcome:
    """What happened to one step."""

    step: int
    element: str  # GlobalId
    action: str
    skill_id: str
    outcome: str  # succeeded | failed | skipped
    reason: str | None
    start_s: float
    end_s: float
    details: dict[str, Any] = field(default_factory=dict)

    @property
    def duration_s(self) -> float:
        """Simulated time the step took."""
        return self.end_s - self.start_s


@dataclass
class ElementOutcome:
    """What happened to one element of the task."""

    iri: str
    global_id: str
    label: str
    outcome: str  # installed | failed
    reason: str | None
    start_s: float
    end_s: float
    steps: list[StepOutcome] = field(default_factory=list)
    placement_error_m: float | None = None
    placement_error_deg: float | None = None
    final_pose: tuple[float, float, float, float, float, float] | None = None  # element frame at the end

    @property
    def duration_s(self) -> float:
        """Simulated time spent on the element."""
        return self.end_s - self.start_s


@dataclass
class SimulationResult:
    """The outcome of a run and where its files are."""

    elements: list[ElementOutcome]
    events: list[dict[str, Any]]
    metrics: dict[str, Any]
    timing: dict[str, Any]
    out_dir: Path
    files: list[str]
    sim_time_s: float
    wall_time_s: float

    @property
    def installed(self) -> list[ElementOutcome]:
        """Elements installed."""
        return [e for e in self.elements if e.outcome == INSTALLED]

    @property
    def failed(self) -> list[ElementOutcome]:
        """Elements not installed, with reasons."""
        return [e for e in self.elements if e.outcome != INSTALLED]

    @property
    def all_installed(self) -> bool:
        """True when every element was installed."""
        return bool(self.elements) and not self.failed


def _world(project: ProjectData, plan: Plan) -> World:
    from kbplanner.world.build import build_world

    return build_world(project, project.world_date(plan.task_id), plan.task_id)


def _project_files(project: ProjectData) -> list[Path]:
    m = project.manifest
    files = [m.path, m.ifc, *m.site, *m.jobsite, *m.knowledge_base, *m.augmentation]
    if m.schedule is not None:
        files.append(m.schedule)
    if project.scenario is not None and project.scenario in m.scenarios:
        files += list(m.scenarios[project.scenario].overlays)
    return [f for f in files if f.is_file()]


class _Run:
    """One execution: the loop over elements and steps, events and key frames."""

    def __init__(self, env: SimEnv, plan: Plan, settings: ExecSettings, seed: int,
                 progress: ProgressFn | None, ready: Callable[[str], None] | None = None) -> None:
        self.env = env
        self.plan = plan
        self.ready = ready
        self.settings = settings
        self.progress = progress
        self.rec = Recorder(env, settings.record_hz)
        self.ctx = RunContext(env=env, plan=plan, settings=settings, emit=self.emit, seed=seed)
        self.keyframes: list[tuple[str, bytes]] = []
        self._frames_done: set[str] = set()
        self.footprints: dict[str, dict[str, Any]] = {}
        self.done_steps = 0
        self.total_steps = len(plan.steps)
        self._element_rects: dict[str, dict[str, Rect]] = {}
        self._robot_rects = list(env.robot.spec.footprint().rects)
        self._hazard: tuple[tuple[float, float, float], Any, str, Obstacle] | None = None
        env.hazard = self.hazard
        self.contact = ContactMonitor(env, self.hazard, self.emit,
                                      lambda: env.held.element.global_id if env.held is not None else "")

    def hazard(self) -> Obstacle:
        """The robot's hazard footprint now: base + the held element's carry-mode rectangle (the same
        object while the base pose - the very tuple the robot gives -, the held element and the carry
        mode stay; nobody changes it)."""
        env = self.env
        held = env.held
        pose = env.base_pose()
        mode = self.ctx.carry_mode if held is not None else ""
        last = self._hazard
        if last is not None and last[0] is pose and last[1] is held and last[2] == mode:
            return last[3]
        if held is None:
            obs = Obstacle(pose, self._robot_rects)
        else:
            gid = held.element.global_id
            if gid not in self._element_rects:
                self._element_rects[gid] = self._carry_rects(held.element.iri, gid)
            obs = Obstacle(pose, hazard_rects(self._robot_rects, self._element_rects[gid] or None,
                                              self.ctx.carry_mode))
        self._hazard = (pose, held, mode, obs)
        return obs

    def _carry_rects(self, iri: str, gid: str) -> dict[str, Rect]:
        """The held element's normal/narrow carry rectangles, from the plan's NV-2 carry poses."""
        env = self.env
        held = env.held
        assert held is not None
        step = next((s for s in self.plan.steps_for(iri) if s.skill_kind == KIND_NAVIGATION_WITH_OBJECT
                     and s.arm_poses.get("carry_normal") and s.arm_poses.get("carry_narrow")), None)
        if step is None or held.element.local_bounds is None:
            return {}
        q = env.robot.arm_positions()
        geo = geometry_from_joints(env.robot, held.element.local_bounds, held.tool_in_element,
                                   step.arm_poses["carry_normal"], step.arm_poses["carry_narrow"])
        env.set_arm(q)
        self.footprints[gid] = {"normal": rect_dict(geo.normal.rect), "narrow": rect_dict(geo.narrow.rect)}
        return {NORMAL: geo.normal.rect, NARROW: geo.narrow.rect}

    def emit(self, kind: str, **details: Any) -> None:
        step = self.ctx.step
        self.rec.event(kind, step=step.step if step else None,
                       element=self.ctx.gid(step.element) if step else "",
                       action=step.action_label if step else "", details=details)
        if self.settings.keyframes and kind in KEYFRAME_EVENTS and kind not in self._frames_done:
            self._frames_done.add(kind)
            self.env.sync()
            self.keyframes.append((kind, render_png(self.env, self.settings.keyframe_size)))

    def sample(self, force: bool = False, arm: tuple[float, ...] | None = None) -> None:
        held = self.env.held
        step = self.ctx.step
        self.rec.sample(step=step.step if step else None, carried=held.element.global_id if held else "",
                        carry_mode=self.ctx.carry_mode if held else "", force=force, arm=arm)

    def _tell(self, label: str) -> None:
        self.done_steps += 1
        if self.progress is not None:
            self.progress(label, self.done_steps, self.total_steps)

    def run(self) -> list[ElementOutcome]:
        self.sample(force=True)
        self.emit("start", robot=self.plan.robot_id, elements=len(self.plan.elements))
        out = [self.element(iri) for iri in elements_in_order(self.plan)]
        for e in out:  # where every element ended (site frame: x, y, z, roll, pitch, yaw)
            if any(t.iri == e.iri for t in self.env.world.task_elements):
                e.final_pose = tuple(round(v, 6) + 0.0 for v in pose_of(self.env.element_frame(e.iri)))  # type: ignore[assignment]
        self.ctx.step = None
        self.emit("end", installed=sum(1 for e in out if e.outcome == INSTALLED), elements=len(out))
        if self.settings.keyframes:
            self.env.sync()
            self.keyframes.append(("end", render_png(self.env, self.settings.keyframe_size)))
        self.sample(force=True)
        return out

    def element(self, iri: str) -> ElementOutcome:
        if self.ready is not None:
            self.ready(iri)  # (B4 ahead of B5: the plan holds the element's refined steps once it returns)
        steps = self.plan.steps_for(iri)
        info = next((e for e in self.plan.elements if e.iri == iri), None)
        gid = info.global_id if info else iri
        label = info.label if info else iri
        t0 = self.env.t
        result = ElementOutcome(iri, gid, label, FAILED, None, t0, t0)
        bad = next((s for s in steps if not s.feasible), None)
        if bad is not None:
            self.ctx.step = bad
            reason = bad.reason or "infeasible"
            self.emit("step_failed", reason=reason, planned=True)
            for s in steps:
                outcome = FAILED if s is bad else SKIPPED
                why = reason if s is bad else f"skipped: step {bad.step} infeasible"
                result.steps.append(StepOutcome(s.step, gid, s.action_label, s.skill_id, outcome, why, t0,
                                                t0))
                self._tell(label)
            result.reason = f"step {bad.step} ({bad.action_label}): {reason}"
            self.ctx.step = None
            self.emit("element_failed", element_label=label, reason=result.reason)
            return result
        failed_at: StepOutcome | None = None
        for s in steps:
            if failed_at is not None:
                why = f"skipped: step {failed_at.step} failed"
                result.steps.append(StepOutcome(s.step, gid, s.action_label, s.skill_id, SKIPPED, why,
                                                self.env.t, self.env.t))
                self._tell(label)
                continue
            done = self.run_step(s, gid)
            result.steps.append(done)
            self._tell(label)
            if done.outcome == FAILED:
                failed_at = done
                if self.env.held is not None:
                    self.env.put_back(self.env.held.element.iri)
                    self.ctx.carry_mode = ""
                    self.emit("put_back", reason="the step failed: the element is returned to its storage "
                                                 "(not simulated)")
            if "placement_error_m" in done.details:
                result.placement_error_m = done.details["placement_error_m"]
                result.placement_error_deg = done.details["placement_error_deg"]
        result.end_s = self.env.t
        self.ctx.step = None
        if failed_at is None:
            result.outcome = INSTALLED
            self.emit("element_installed", element=gid, element_label=label,
                      duration_s=round(result.duration_s, 3))
        else:
            result.reason = f"step {failed_at.step} ({failed_at.action}): {failed_at.reason}"
            self.emit("element_failed", element=gid, element_label=label, reason=result.reason)
        return result

    def run_step(self, call: SkillCall, gid: str) -> StepOutcome:
        env = self.env
        self.ctx.step = call
        t0 = env.t
        skill = skill_for(call.skill_kind)
        if skill is None:
            reason = f"no executor for skill kind {call.skill_kind}"
            self.emit("step_failed", reason=reason)
            return StepOutcome(call.step, gid, call.action_label, call.skill_id, FAILED, reason, t0, t0)
        self.emit("step_start", skill=call.skill_id)
        arm = env.robot.spec.arm
        clock = ArmClock(env.robot.arm_positions(), [min(self.settings.joint_speed_rps, v) for v in
                                                     (arm.velocity_rps if arm is not None else ())])
        skill.setup(self.ctx)
        skill.initialise(call)
        status = skill.status
        last_q: tuple[float, ...] | None = None
        while status is Status.RUNNING:
            status = skill.update()
            q = env.robot.arm_positions()  # the arm of this period (nothing below moves it)
            if q != last_q:  # (the same joints: a step of 0.0, nothing to add)
                clock.update(q)
                last_q = q
            self.contact.after_robot()
            if status is not Status.RUNNING:
                break
            env.step()
            self.contact.after_workers()
            self.sample(arm=q)
            if env.t - t0 > MAX_STEP_S:
                status = skill.fail(f"still running after {MAX_STEP_S:.0f} s of simulated time")
        skill.terminate(status)
        if isinstance(skill, NavigationSkill) and skill.geo is not None:
            self.footprints[gid] = {"normal": rect_dict(skill.geo.normal.rect),
                                    "narrow": rect_dict(skill.geo.narrow.rect)}
        ok = status is Status.SUCCESS
        details = dict(skill.details)
        if clock.total_s > 0:
            details["arm_min_s"] = round(clock.total_s, 4)
        if ok:
            self.emit("step_end", duration_s=round(env.t - t0, 3))
        else:
            self.emit("step_failed", reason=skill.reason)
        return StepOutcome(call.step, gid, call.action_label, call.skill_id, SUCCEEDED if ok else FAILED,
                           None if ok else skill.reason, t0, env.t, details)


def _metrics(plan: Plan, elements: list[ElementOutcome], sim_time: float, settings: ExecSettings,
             seed: int) -> dict[str, Any]:
    per_action: dict[str, dict[str, Any]] = {}
    nav: list[dict[str, Any]] = []
    totals = {"stops": 0, "stop_time_s": 0.0, "slowdowns": 0, "time_lost_s": 0.0, "replans": 0,
              "path_length_m": 0.0, "driven_m": 0.0}
    for e in elements:
        for s in e.steps:
            a = per_action.setdefault(s.action, {"count": 0, "succeeded": 0, "failed": 0, "skipped": 0,
                                                 "total_s": 0.0})
            a["count"] += 1
            a[s.outcome] += 1
            a["total_s"] += s.duration_s
            d = s.details
            if "path_length_m" in d:
                nav.append({"step": s.step, "element": e.global_id, "action": s.action,
                            "outcome": s.outcome, "path_length_m": d["path_length_m"],
                            "driven_m": d.get("driven_m", 0.0), "narrow_length_m": d["narrow_length_m"],
                            "carry_modes": d["carry_modes"], "stops": d["stops"],
                            "stop_time_s": d["stop_time_s"], "replans": d["replans"],
                            "slowdowns": d.get("slowdowns", 0), "slow_time_s": d.get("slow_time_s", 0.0),
                            "time_lost_s": d.get("time_lost_s", 0.0), "duration_s": s.duration_s,
                            "shortest_m": d.get("shortest_m")})
                totals["stops"] += d["stops"]
                totals["stop_time_s"] += d["stop_time_s"]
                totals["slowdowns"] += d.get("slowdowns", 0)
                totals["time_lost_s"] += d.get("time_lost_s", 0.0)
                totals["replans"] += d["replans"]
                totals["path_length_m"] += d["path_length_m"]
                totals["driven_m"] += d.get("driven_m", 0.0)
    for a in per_action.values():
        done = a["succeeded"]
        a["mean_s"] = a["total_s"] / done if done else None
    errors = [(e.placement_error_m, e.placement_error_deg or 0.0) for e in elements
              if e.placement_error_m is not None]
    per_element = []
    for e in elements:
        steps = []
        for s in e.steps:
            d = {k: v for k, v in s.details.items() if k not in ("planning_time_s", "planner")}
            steps.append({"step": s.step, "action": s.action, "skill": s.skill_id, "outcome": s.outcome,
                          "reason": s.reason, "start_s": s.start_s, "end_s": s.end_s,
                          "duration_s": s.duration_s, "details": d})
        per_element.append({"global_id": e.global_id, "label": e.label, "iri": e.iri, "outcome": e.outcome,
                            "reason": e.reason, "start_s": e.start_s, "end_s": e.end_s,
                            "duration_s": e.duration_s, "placement_error_m": e.placement_error_m,
                            "placement_error_deg": e.placement_error_deg,
                            "final_pose": list(e.final_pose) if e.final_pose else None, "steps": steps})
    installed = sum(1 for e in elements if e.outcome == INSTALLED)
    return clean({
        "project": plan.project, "scenario": plan.scenario, "task": plan.task_id, "robot": plan.robot_id,
        "seed": seed,
        "totals": {"sim_time_s": sim_time, "elements": len(elements), "installed": installed,
                   "failed": len(elements) - installed, **totals},
        "per_action": dict(sorted(per_action.items())),
        "per_element": per_element,
        "navigation": nav,
        "path_quality": path_quality(per_element, nav),
        "placement": {"max_error_m": max((a for a, _ in errors), default=None),
                      "max_error_deg": max((b for _, b in errors), default=None),
                      "tolerance_m": settings.place_tol_m, "tolerance_deg": settings.place_tol_deg},
        "settings": {"control_hz": settings.control_hz, "record_hz": settings.record_hz,
                     "joint_speed_rps": settings.joint_speed_rps, "replan_after_s": settings.replan_after_s,
                     "give_up_after_s": settings.give_up_after_s, "monitoring": settings.monitoring,
                     "reactive_workers": settings.reactive_workers},
    })


def simulate(
    project: ProjectData,
    plan: Plan,
    *,
    seed: int,
    out_dir: Path,
    progress: ProgressFn | None = None,
    world: World | None = None,
    grid: OccupancyGrid | None = None,
    settings: ExecSettings | None = None,
    gui: bool = False,
    workers: Sequence[WorkerMotion] | None = None,
    ready: Callable[[str], None] | None = None,
) -> SimulationResult:
    """Execute a refined plan in PyBullet and write the run directory (see module docstring).

    ``progress(element_label, steps_done, steps_total)`` is called after each step. ``world`` and
    ``grid`` (the task storey's occupancy grid) are built when not given; ``workers`` replaces the
    model's workers (their motions, e.g. a scripted one for a test or a what-if). ``ready(element_iri)``
    is called before each element is simulated (:meth:`kbplanner.planning.refine_ahead.RefineAhead.ready`:
    B4 refines the plan's elements in a second process meanwhile; the outputs are written from ``plan``
    as it is after the last element).

    Raises:
        KbplannerError: no robot in the plan, no [simulation] date for the world, a robot whose URDF
            cannot be loaded.
    """
    from kbplanner.simulation import cell_store, walk_store
    from kbplanner.simulation.floors import walk_grid
    from kbplanner.simulation.workers import WorkerSpec, load_workers, plan_workers
    from kbplanner.world import cspace_store
    from kbplanner.world.maps import storey_map

    settings = settings or ExecSettings()
    if not plan.robot_id:
        raise KbplannerError("the plan has no robot: no robot of the knowledge base fits the task",
                             element=plan.task_id,
                             fix="see the plan's robot selection, or choose one with --robot")
    started = time.perf_counter()
    cpu_started = time.process_time()
    world = world or _world(project, plan)
    grid = grid if grid is not None else storey_map(world).grid
    ground_grid = walk_grid(world, grid)  # the workers' map: the ground floor's when the robot is upstairs
    reactive: list[WorkerSpec] = []
    if workers is None and settings.reactive_workers:
        reactive, workers = load_workers(project.model), []
    elif workers is None:
        horizon = 1800.0 + WORKER_HORIZON_S_PER_STEP * len(plan.steps)  # past it workers hold their last pose
        workers = plan_workers(project.model, ground_grid, seed=seed, horizon_s=horizon)
    env = SimEnv(world, robot_name(plan), grid=grid, walk_grid=ground_grid, workers=workers,
                 reactive=reactive, control_hz=settings.control_hz, gui=gui, visuals=settings.keyframes)
    loaded = time.perf_counter()
    kept = cspace_store.folder_for(project.cache_entry)  # what earlier commands kept (none with --no-cache)
    try:
        with cspace_store.kept_in(kept):  # the workers' walking map, kept (walk_store)
            env.reset(seed=seed)
        load_s = time.perf_counter() - loaded
        run = _Run(env, plan, settings, seed, progress, ready)
        # configuration spaces of earlier commands, beside the project cache (none with --no-cache)
        with cspace_store.kept_in(kept):
            if env.crowd is not None:  # the workers' route legs of an earlier run on this walking map
                walk_store.read_into(env.crowd.router)
            elements = run.run()
            if env.crowd is not None:
                walk_store.write_from(env.crowd.router)
            cell_store.flush()  # the cell paths searched in this run, for the next
        sim_time = env.t
        robot_fp = env.robot.spec.footprint()
        floor_z, ground_z = env.robot_floor_z, float(env.world.ground_z)
    finally:
        env.close()
    wall = time.perf_counter() - started
    cpu = time.process_time() - cpu_started
    metrics = _metrics(plan, elements, sim_time, settings, seed)
    footprints = {"frame": "robot (x forward, y left), metres, radians",
                  "robot": [rect_dict(r) for r in robot_fp.rects],
                  "elements": dict(sorted(run.footprints.items()))}
    nav_params = next((s.parameters for s in plan.steps if s.skill_kind == KIND_NAVIGATION_WITH_OBJECT),
                      next((s.parameters for s in plan.steps if "maxSpeed" in s.parameters), {}))
    trajectories = run.rec.trajectories_csv()  # once: the safety summary reads the text written below
    metrics["safety"] = clean(safety_summary(trajectories, footprints, abs(floor_z - ground_z),
                                             SsmParameters.from_parameters(nav_params), run.rec.events,
                                             metrics["navigation"], settings.monitoring))
    planning = {str(s.step): round(s.details.get("planning_time_s", 0.0), 4)
                for e in elements for s in e.steps if "planning_time_s" in s.details}
    timing = {"note": "wall-clock figures: they differ from run to run (all other files do not)",
              "wall_time_s": round(wall, 3), "load_s": round(load_s, 3), "sim_time_s": round(sim_time, 3),
              "real_time_factor": round(sim_time / wall, 2) if wall > 0 else None,
              "cpu_time_s": round(cpu, 3),  # this process's CPU time: steadier than wall on a busy machine
              "real_time_factor_cpu": round(sim_time / cpu, 2) if cpu > 0 else None,
              "planning_time_s": planning, "planning_total_s": round(sum(planning.values()), 4),
              "planning_limit_s": settings.nav_time_limit_s}
    slow = [k for k, v in planning.items() if v > 0.5 * settings.nav_time_limit_s]
    if slow:
        timing["warning"] = (f"navigation planning of step(s) {', '.join(slow)} took more than half the OMPL "
                             "time limit: on a slower or busier machine the run may differ")
        log.warning(timing["warning"])
    plan_text = plan.to_json()
    manifest = {
        "project": project.name, "project_dir": str(project.path), "scenario": project.scenario,
        "task": plan.task_id, "robot": plan.robot_id, "seed": seed,
        "robot_floor_z": round(floor_z, 4), "ground_z": round(ground_z, 4),
        "inputs": input_hashes(_project_files(project), project.path),
        "versions": versions(),
        "plan_sha256": hashlib.sha256(plan_text.encode("utf-8")).hexdigest(),
        "files": {"trajectories.csv": "robot, arm, held element and workers every 1/record_hz s",
                  "events.jsonl": "events in time order", "metrics.json": "durations, paths, stops, errors",
                  "timing.json": "wall-clock figures (not deterministic)",
                  "footprints.json": "footprints in the robot frame", "plan.json": "the refined plan",
                  "keyframes/": "PNG images at key events"},
        "deterministic": ["trajectories.csv", "events.jsonl", "metrics.json", "footprints.json", "plan.json"],
    }
    out_dir = Path(out_dir)
    files: list[str] = []
    with run_directory(out_dir) as stage:
        atomic_write_text(stage / "trajectories.csv", trajectories)
        atomic_write_text(stage / "events.jsonl", run.rec.events_jsonl())
        write_json(stage / "metrics.json", metrics)
        write_json(stage / "timing.json", timing)
        write_json(stage / "footprints.json", footprints)
        write_json(stage / "manifest.json", manifest)
        atomic_write_text(stage / "plan.json", plan_text)
        for n, (kind, png) in enumerate(run.keyframes, start=1):
            atomic_write_bytes(stage / "keyframes" / f"{n:02d}_{kind}.png", png)
        files = sorted(str(p.relative_to(stage)) for p in stage.rglob("*") if p.is_file())
    log.info("simulated %.0f s in %.1f s wall: %d of %d elements installed", sim_time, wall,
             metrics["totals"]["installed"], len(elements))
    return SimulationResult(elements=elements, events=run.rec.events, metrics=metrics, timing=timing,
                            out_dir=out_dir, files=files, sim_time_s=sim_time, wall_time_s=wall)
