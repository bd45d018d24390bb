"""Scenario sweeps (analysis, after B5), step 3: one variant planned (B1-B4) and simulated (B5).

``run_variant`` runs in a worker process (local, Dask or Ray): it loads the project itself from the
picklable :class:`VariantTask`, applies the variant's storage overlay, plans, simulates with the
workers shifted to the variant's start time (``shifted_workers``) and gives one table row
(:class:`VariantResult`): ``ok``, or ``failed`` with the message.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.core.errors import KbplannerError
from kbplanner.scale.sweep_axes import Variant
from kbplanner.scale.sweep_storage import apply_overlay, find_storage, storage_overlay

if TYPE_CHECKING:
    from kbplanner.model.project_data import ProjectData
    from kbplanner.simulation.workers import WorkerMotion
    from kbplanner.world.occupancy import OccupancyGrid

OK, REJECTED, FAILED = "ok", "rejected", "failed"


@dataclass(frozen=True)
class VariantTask:
    """What one process needs to simulate a variant (picklable)."""

    project_dir: str
    variant: Variant
    max_elements: int | None
    threshold_m: float
    run_dir: str | None  # keep the run here; None: a temporary directory


@dataclass
class VariantResult:
    """One row of the sweep table."""

    variant: str
    scenario: str
    storage: str
    storage_x: float | None
    storage_y: float | None
    storage_yaw: float | None
    seed: int
    start: str
    status: str  # ok | rejected | failed
    reason: str = ""
    installed: int = 0
    elements: int = 0
    total_min: float | None = None
    per_frame_min: float | None = None
    min_separation_m: float | None = None
    below_threshold_s: float | None = None
    below_separation_s: float | None = None
    stops: int = 0
    stop_time_s: float | None = None

    @property
    def complete(self) -> bool:
        """Simulated with every element installed."""
        return self.status == OK and self.elements > 0 and self.installed == self.elements


COLUMNS = [f.name for f in fields(VariantResult)]


def rounded(v: float | None, nd: int = 3) -> float | None:
    """``v`` rounded to ``nd`` decimals (None stays None)."""
    return None if v is None else round(float(v), nd)


def shifted_workers(project: ProjectData, grid: OccupancyGrid, *, seed: int, horizon_s: float,
                    offset_s: float) -> list[WorkerMotion]:
    """The workers' motions from ``offset_s`` seconds into their day on: planned from 0, shifted."""
    from kbplanner.simulation.workers import plan_workers

    motions = plan_workers(project.model, grid, seed=seed, horizon_s=horizon_s + offset_s)
    if offset_s <= 0:
        return motions
    for m in motions:
        m.segments = [(t0 - offset_s, t1 - offset_s, pts, cum) for t0, t1, pts, cum in m.segments
                      if t1 - offset_s >= 0.0]
    return motions


def run_variant(task: VariantTask) -> VariantResult:
    """Load the project, apply the variant's overlay, plan (B1-B4) and simulate (B5); one table row."""
    from kbplanner.analysis.report import scenario_figures
    from kbplanner.analysis.run_record import RunRecord
    from kbplanner.model.project_data import ProjectData
    from kbplanner.planning.manipulation import refine_plan
    from kbplanner.planning.planner import plan_task
    from kbplanner.simulation.executor import WORKER_HORIZON_S_PER_STEP, simulate
    from kbplanner.simulation.floors import walk_grid
    from kbplanner.simulation.skills import ExecSettings
    from kbplanner.world.build import world_of
    from kbplanner.world.maps import storey_map

    v = task.variant
    project = ProjectData.load(task.project_dir, scenario=v.scenario)
    st = find_storage(project.model, file=project.manifest.path)
    x, y, yaw = st.x, st.y, st.yaw
    if v.storage is not None and v.storage.moved:
        x, y = float(v.storage.x or 0.0), float(v.storage.y or 0.0)
        yaw = st.yaw if v.storage.yaw is None else float(v.storage.yaw)
        apply_overlay(project.model, storage_overlay(st, x, y, yaw))
    label = v.storage.label if v.storage else v.scenario
    row = VariantResult(variant=v.id, scenario=v.scenario, storage=label,
                        storage_x=rounded(x), storage_y=rounded(y), storage_yaw=rounded(yaw, 4), seed=v.seed,
                        start=v.start, status=OK)
    try:
        world = world_of(project)
        grid = storey_map(world).grid
        plan = plan_task(project, world=world)
        if not plan.robot_id:
            row.status, row.reason = FAILED, "no robot of the knowledge base fits the task"
            return row
        if task.max_elements is not None:
            plan.keep_first(task.max_elements)
        refined = refine_plan(plan, world, seed=v.seed, grid=grid)
        horizon = 1800.0 + WORKER_HORIZON_S_PER_STEP * len(refined.steps)
        workers = shifted_workers(project, walk_grid(world, grid), seed=v.seed, horizon_s=horizon,
                                  offset_s=v.start_offset_s)
        with tempfile.TemporaryDirectory(prefix="kbplanner-sweep-") as tmp:
            out = Path(task.run_dir) if task.run_dir else Path(tmp) / "run"
            simulate(project, refined, seed=v.seed, out_dir=out, world=world, grid=grid,
                     settings=ExecSettings(keyframes=False), workers=workers)
            rec = RunRecord.load(out)
            fig = scenario_figures(rec, rec.proximity(threshold_m=task.threshold_m))
    except KbplannerError as err:
        row.status, row.reason = FAILED, str(err).splitlines()[0]
        return row
    row.installed, row.elements = fig.installed, fig.elements
    row.total_min, row.per_frame_min = rounded(fig.total_min), rounded(fig.per_element_min)
    row.min_separation_m = rounded(fig.min_separation_m)
    row.below_threshold_s = rounded(fig.below_threshold_s)
    row.below_separation_s = rounded(fig.below_separation_s)
    row.stops, row.stop_time_s = fig.worker_stops, rounded(fig.stop_time_s)
    if row.installed < row.elements:
        row.reason = f"{row.elements - row.installed} element(s) not installed"
    return row
