"""The report (analysis output): what a planner looks at after simulating one or more scenarios.

``build_report(runs, ...)`` turns simulation run records (one per scenario) into a
:class:`~kbplanner.analysis.report_doc.ReportDoc`: the key figures side by side (with the paper's figures
beside ours), the requirements the model had to meet, the selected robot and why, the plan, for each
scenario the site layout with the robot's and every worker's trajectory, distance over time with the
1 m and ISO/TS 15066 thresholds, the proximity intervals and where they happened, a Gantt chart of the
robot's actions and rendered key frames, then per-frame durations across scenarios and the fit of the
simulated work into the task's window. ``write_report(run_dirs, out_dir)`` writes ``report.html``
(self-contained) and ``report.md``. Reference figures to compare with (e.g. a paper's) come from the
project's ``[reference]`` table, never from code.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import Any

import numpy as np

from kbplanner.analysis.plots import (
    GanttBar,
    LayoutObject,
    distance_over_time,
    gantt,
    grouped_bars,
    site_layout,
)
from kbplanner.analysis.report_doc import ReportDoc
from kbplanner.analysis.run_record import ProximityResult, RunRecord
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

@dataclass
class ScenarioFigures:
    """The comparison figures of one scenario."""

    scenario: str
    installed: int
    elements: int
    first_element_min: float | None
    per_element_min: float | None
    total_min: float
    min_separation_m: float
    below_threshold_s: float
    below_separation_s: float
    worker_stops: int
    stop_time_s: float
    collisions: int = 0
    slowdowns: int = 0
    time_lost_s: float = 0.0

    def row(self) -> list[Any]:
        """One row of the comparison table."""
        return [self.scenario, f"{self.installed}/{self.elements}", _r(self.first_element_min),
                _r(self.per_element_min), _r(self.total_min), _r(self.min_separation_m),
                _r(self.below_threshold_s), _r(self.below_separation_s), self.worker_stops,
                _r(self.stop_time_s), self.slowdowns, _r(self.time_lost_s), self.collisions]


COMPARISON_COLUMNS = ["scenario", "installed", "first frame (min)", "per frame (min)", "total (min)",
                      "min separation (m)", "time < 1 m (s)", "time < ISO/TS 15066 S_p (s)",
                      "stops for workers", "stopped (s)", "slow-downs", "time lost to monitoring (s)",
                      "collisions"]


def _r(v: float | None, nd: int = 2) -> float | None:
    return None if v is None else round(float(v), nd)


def scenario_figures(rec: RunRecord, prox: ProximityResult) -> ScenarioFigures:
    """Figures of one run for the comparison table."""
    d = rec.durations()
    totals = rec.metrics.get("totals", {})
    stops = sum(1 for e in rec.events if e.get("kind") == "stop")
    safety = rec.metrics.get("safety", {})
    return ScenarioFigures(
        scenario=rec.scenario or rec.directory.name,
        installed=d.installed, elements=len(d.elements),
        first_element_min=None if d.first_element_s is None else d.first_element_s / 60.0,
        per_element_min=None if d.mean_per_element_s is None else d.mean_per_element_s / 60.0,
        total_min=d.total_s / 60.0,
        min_separation_m=prox.min_distance_m,
        below_threshold_s=prox.time_below_threshold_s,
        below_separation_s=prox.time_below_separation_s,
        worker_stops=stops, stop_time_s=float(totals.get("stop_time_s", 0.0)),
        collisions=int(safety.get("collisions", 0)), slowdowns=int(safety.get("slowdowns", 0)),
        time_lost_s=float(safety.get("time_lost_s", 0.0)),
    )


def collision_lines(runs: Mapping[str, RunRecord]) -> list[str]:
    """One line per collision event of the runs (empty: none)."""
    out = []
    for name, rec in runs.items():
        for e in rec.events:
            if e.get("kind") == "collision":
                d = e.get("details", {})
                out.append(f"{name}: t = {e.get('t_s')} s, {d.get('worker')}: {d.get('cause')} (robot "
                           f"{d.get('robot_speed_mps')} m/s, worker {d.get('worker_speed_mps')} "
                           f"m/s, carrying "
                           f"{d.get('carried') or 'nothing'}, step {e.get('step')} {e.get('action')})")
    return out


def _layout_objects(world: Any) -> list[LayoutObject]:
    out = []
    for o in world.site_objects:
        out.append(LayoutObject(o.label, o.kind, o.pose.x, o.pose.y, o.size[0], o.size[1], o.pose.yaw))
    return out


def _keyframes(rec: RunRecord) -> list[tuple[str, bytes]]:
    kdir = rec.directory / "keyframes"
    if not kdir.is_dir():
        return []
    return [(p.name, p.read_bytes()) for p in sorted(kdir.glob("*.png"))]


def build_report(runs: Mapping[str, RunRecord], *, title: str,
                 grids: Mapping[str, OccupancyGrid] | None = None,
                 layouts: Mapping[str, Sequence[LayoutObject]] | None = None,
                 requirements: Sequence[Sequence[Any]] = (), requirement_columns: Sequence[str] = (),
                 selection: Sequence[Sequence[Any]] = (), window: tuple[datetime, datetime] | None = None,
                 fits: Mapping[str, Any] | None = None, threshold_m: float = 1.0,
                 space_of: Any = None, reference: Mapping[str, Any] | None = None,
                 task_tables: Mapping[str, tuple[Sequence[str], Sequence[Sequence[Any]]]] | None = None,
                 ) -> ReportDoc:
    """Assemble the report (see module docstring) from run records and optional context.

    ``task_tables`` (per scenario: columns and rows of ``tasks.csv``, the last row the total) adds a
    section on every robotized task of a whole-building run (``kbplanner run --tasks all``).
    """
    doc = ReportDoc(title)
    hits = collision_lines(runs)
    if hits:
        doc.heading(f"COLLISIONS: {len(hits)} contact event(s) between the robot and a worker")
        doc.paragraph("A worker's body overlapped the robot or its load. Each event: " + "; ".join(hits))
    prox = {name: rec.proximity(threshold_m=threshold_m) for name, rec in runs.items()}
    figures = [scenario_figures(rec, prox[name]) for name, rec in runs.items()]

    doc.heading("Summary")
    first = next(iter(runs.values()))
    man = first.manifest
    doc.paragraph(f"Task {man.get('task', '?')} simulated with robot {man.get('robot', '?')}, seed "
                  f"{man.get('seed', '?')}, in {len(runs)} scenario(s). Distances are measured from the "
                  "robot's footprint including the element it carries to each worker's body (0.25 m radius).")
    doc.table(COMPARISON_COLUMNS, [f.row() for f in figures], caption="Scenarios side by side")
    if reference:
        source = str(reference.get("source", "reference"))
        ref_rows = []
        for f in figures:
            ref = reference.get(f.scenario, {})
            if not isinstance(ref, Mapping):
                continue
            ref_rows.append([f.scenario, _r(f.first_element_min), ref.get("first_frame_min"), _r(f.total_min),
                             ref.get("total_min"), _r(f.min_separation_m), ref.get("min_separation")])
        if ref_rows:
            doc.table(["scenario", "frame 1 (min), ours", f"frame 1 (min), {source}",
                       "all frames (min), ours", f"all frames (min), {source}",
                       "min separation (m), ours", f"min separation, {source}"],
                      ref_rows, caption=f"Our figures beside the reference figures ({source})")

    if requirements:
        doc.heading("Additional modeling requirements (A3)")
        doc.paragraph("Derived by the knowledge base from the task specification's input bindings on the "
                      "bare 4D model; every scenario's augmented model met them (see its validation).")
        doc.table(requirement_columns, requirements)
    if selection:
        doc.heading("Robot selection (B3)")
        doc.paragraph(f"Selected: {man.get('robot', '?')}. Every robot of the knowledge base, every check "
                      "(failed checks first).")
        doc.table(["robot", "verdict", "check", "result"], selection)

    plan_path = first.directory / "plan.json"
    if plan_path.is_file():
        plan = json.loads(plan_path.read_text(encoding="utf-8"))
        doc.heading("Plan (B1-B4)")
        n_steps, n_elements = len(plan.get("steps", [])), len(plan.get("elements", []))
        doc.paragraph(f"{n_steps} skill calls for {n_elements} elements; "
                      f"element order: {plan.get('order_rule', '')}.")
        rows = []
        for s in plan.get("steps", [])[:8]:
            base = s.get("base_pose")
            where = f"({base['x']:.2f}, {base['y']:.2f})" if base else ""
            rows.append([s["step"], s["action_label"], s["skill_id"], where, "yes" if s["feasible"] else
                         f"no: {s.get('reason')}"])
        doc.table(["step", "action", "skill", "base pose (m)", "feasible"], rows,
                  caption="The first 8 steps (plan.json has them all)")

    for name, rec in runs.items():
        p = prox[name]
        tr = rec.trajectories
        doc.heading(f"Scenario {name}")
        robot_xy = np.column_stack([tr.x, tr.y])
        workers = {w: np.column_stack(xy) for w, xy in tr.workers.items()}
        marks = [("narrow", x, y) for _, x, y in rec.event_positions("rotate_to_narrow")[:6]]
        marks += [(f"min {w.min_distance_m:.2f} m", w.x_min_m, w.y_min_m) for w in p.workers
                  if w.min_distance_m < threshold_m]
        doc.image(f"layout_{name}.png",
                  site_layout((grids or {}).get(name), (layouts or {}).get(name, []), robot_xy, workers,
                              title=f"{name}: robot and worker trajectories", marks=marks),
                  f"{name}: site layout (task storey) with the robot's path (black) and each worker's path")
        doc.image(f"distance_{name}.png",
                  distance_over_time(tr.t, {w.worker: w.distance_m for w in p.workers},
                                     {f"{threshold_m:g} m": threshold_m, "ISO/TS 15066 S_p": p.separation_m},
                                     title=f"{name}: distance from the robot to each worker"),
                  f"{name}: distance over time with the {threshold_m:g} m and ISO/TS 15066 thresholds")
        rows = []
        for iv in p.intervals:
            floor = float(rec.manifest.get("robot_floor_z", 0.0))  # the robot's storey, not another
            where = space_of(iv.x_m, iv.y_m, floor) if space_of else ""
            rows.append([iv.worker, iv.threshold, _r(iv.start_s, 1), _r(iv.duration_s, 1),
                         _r(iv.min_distance_m), f"({iv.x_m:.1f}, {iv.y_m:.1f})", where])
        if rows:
            doc.table(["worker", "below", "from (s)", "for (s)", "min (m)", "where (m)", "nearest space"],
                      rows, caption=f"{name}: proximity intervals")
        else:
            doc.note(f"{name}: no worker came closer than {threshold_m:g} m or the ISO/TS 15066 distance.")
        bars = [GanttBar(a.element, a.action, a.start_s, a.end_s, a.outcome == "succeeded")
                for a in rec.durations().actions]
        if bars:
            doc.image(f"gantt_{name}.png", gantt(bars, title=f"{name}: robot actions"),
                      f"{name}: the robot's actions over time (hatched: failed)")
        failed = [e for e in rec.durations().elements if e.outcome != "installed"]
        if failed:
            doc.table(["element", "outcome", "reason"], [[e.element, e.outcome, e.reason] for e in failed],
                      caption=f"{name}: elements not installed")
        for kname, png in _keyframes(rec)[:4]:
            doc.image(f"{name}_{kname}", png, f"{name}: key frame {kname}")

    if task_tables:
        doc.heading("Every robotized task (whole building)")
        doc.paragraph("Each robotized task simulated in the world at its own date (its storey, the robot "
                      "set down at the storey's arrival pose); the sections above show the simulation task "
                      "of project.toml. Minimum separations include the storeys between the robot and the "
                      "workers, who walk on the ground.")
        per_task: dict[str, dict[str, float]] = {}
        for name, (columns, task_rows) in task_tables.items():
            doc.table(list(columns), [list(r) for r in task_rows],
                      caption=f"{name}: every task (tasks/tasks.csv)")
            cols = list(columns)
            if "task" in cols and "simulated (min)" in cols:
                i, j = cols.index("task"), cols.index("simulated (min)")
                per_task[name] = {str(r[i]): float(r[j] or 0.0) for r in task_rows[:-1]}
        if per_task:
            doc.image("tasks.png", grouped_bars(per_task, title="simulated time per task", ylabel="minutes"),
                      "Simulated time of each robotized task (minutes)")

    doc.heading("Durations")
    per_frame = {name: {e.element: e.duration_s / 60.0 for e in rec.durations().elements}
                 for name, rec in runs.items()}
    doc.image("per_frame.png", grouped_bars(per_frame, title="time per frame", ylabel="minutes"),
              "Time per frame in each scenario (minutes)")
    kinds = sorted({k for rec in runs.values() for k in rec.durations().per_action_kind()})
    doc.table(["action", *runs.keys()],
              [[k, *(_r(rec.durations().per_action_kind().get(k, 0.0) / 60.0) for rec in runs.values())]
               for k in kinds], caption="Mean duration of each action (minutes)")
    if window is not None and fits:
        doc.table(["scenario", "window", "robot working time (h)", "ends", "fits"],
                  [[n, f"{window[0]:%Y-%m-%d} .. {window[1]:%Y-%m-%d}", _r(f.simulated_s / 3600.0),
                    f"{f.simulated_finish:%Y-%m-%d %H:%M}", f.fits] for n, f in fits.items()],
                  caption="The simulated work placed at the start of the task's window, in working hours")
    return doc
