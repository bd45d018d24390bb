"""Scenario comparison (analysis): simulate several scenarios with one seed and set them side by side.

``simulate_scenario`` runs B1-B5 for one scenario (world at the simulation date, plan, B4 poses,
execution) into a run directory; ``compare`` does it for each scenario, reads the runs back
(:class:`~kbplanner.analysis.run_record.RunRecord`) and gives the comparison table: time for the first frame,
time per frame, total time, minimum separation, time below the 1 m threshold and below the ISO/TS 15066
protective separation distance, and stops caused by workers. ``write_outputs`` writes
``comparison.csv``, ``comparison.json``, the simulated durations written back to the 4D model
(``results.ttl``, ``schedule_with_results.csv``) and the report, with its 4D playback
(:mod:`kbplanner.analysis.playback`) and a BCF topic per element not installed
(:mod:`kbplanner.analysis.bcf_export`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rdflib import URIRef

from kbplanner.analysis.bcf_export import run_issue_date, write_run_bcf
from kbplanner.analysis.playback import add_playbacks
from kbplanner.analysis.plots import LayoutObject
from kbplanner.analysis.report import COMPARISON_COLUMNS, ScenarioFigures, build_report, scenario_figures
from kbplanner.analysis.run_record import RunRecord
from kbplanner.analysis.schedule_fit import (
    ScheduleFit,
    WorkCalendar,
    fit_schedule,
    ifc_with_results,
    results_graph,
    schedule_csv_with_results,
)
from kbplanner.core.errors import KbplannerError
from kbplanner.core.named_queries import run_named
from kbplanner.core.outputs import atomic_write_text, write_json
from kbplanner.core.tables import render
from kbplanner.model.project_data import ProjectData
from kbplanner.world.occupancy import OccupancyGrid

if TYPE_CHECKING:
    from kbplanner.simulation.skills import ExecSettings
    from kbplanner.world.tables import WorldTables

log = logging.getLogger(__name__)

Progress = Callable[[str], None]


@dataclass
class ScenarioRun:
    """One simulated scenario: its run directory and what the report needs of its world."""

    scenario: str
    run_dir: Path
    installed: int
    elements: int
    grid: OccupancyGrid | None = None
    layout: list[LayoutObject] = field(default_factory=list)


def simulate_scenario(
    project_dir: Path,
    scenario: str | None,
    *,
    seed: int | None,
    out_dir: Path,
    progress: Progress | None = None,
    keyframes: bool = True,
    task_id: str | None = None,
    at: datetime | None = None,
    project: ProjectData | None = None,
    max_elements: int | None = None,
    settings: ExecSettings | None = None,
    tables: WorldTables | None = None,
) -> ScenarioRun:
    """B1-B5 for one scenario into ``out_dir``; returns the run and its map for the report.

    ``task_id`` (default ``[simulation] task``) and ``at`` (the world's date, default ``[simulation]
    date``) choose another robotized task; ``project`` is the loaded scenario, to save loading it again;
    ``max_elements`` keeps the first elements of the plan's order only (a quick look, tests);
    ``settings`` the executor's (monitoring, scripted workers; default: key frames, monitoring on);
    ``tables`` the project's world tables (:func:`kbplanner.world.tables.world_tables`), to save reading
    the building again when several tasks of one project are simulated (same world, same run).
    """
    from kbplanner.planning.manipulation import refine_plan
    from kbplanner.planning.planner import plan_task
    from kbplanner.simulation.executor import INSTALLED, simulate
    from kbplanner.simulation.skills import ExecSettings
    from kbplanner.world.build import world_of
    from kbplanner.world.maps import storey_map

    say = progress or (lambda _m: None)
    if project is None:
        project = ProjectData.load(project_dir, scenario=scenario)
    seed = project.manifest.seed if seed is None else seed
    world = world_of(project, at, task_id, tables=tables)
    plan = plan_task(project, task_id, world=world)
    if max_elements is not None:
        plan.keep_first(max_elements)
    if not plan.robot_id:
        reasons = sorted({s.reason or "" for s in plan.steps if not s.feasible})
        raise KbplannerError(
            "no robot of the knowledge base fits the task: " + "; ".join(reasons[:3]),
            file=project.manifest.path,
            element=plan.task_id,
            fix="add a robot to the knowledge base or change the jobsite limits",
        )
    grid = storey_map(world).grid
    say(f"{scenario}: B4 arm and base poses")
    refined = refine_plan(plan, world, seed=seed, grid=grid)

    def tell(label: str, done: int, total: int) -> None:
        say(f"{scenario}: B5 simulation {done}/{total} ({label})")

    result = simulate(
        project,
        refined,
        seed=seed,
        out_dir=out_dir,
        progress=tell,
        world=world,
        grid=grid,
        settings=settings or ExecSettings(keyframes=keyframes),
    )
    layout = [
        LayoutObject(o.label, o.kind, o.pose.x, o.pose.y, o.size[0], o.size[1], o.pose.yaw)
        for o in world.site_objects
    ]
    return ScenarioRun(
        scenario=scenario or "bare",
        run_dir=out_dir,
        installed=sum(1 for e in result.elements if e.outcome == INSTALLED),
        elements=len(result.elements),
        grid=grid,
        layout=layout,
    )


@dataclass
class Comparison:
    """Scenarios side by side (one row each)."""

    figures: list[ScenarioFigures]
    runs: dict[str, RunRecord]
    fits: dict[str, ScheduleFit] = field(default_factory=dict)

    def rows(self) -> list[list[Any]]:
        """The comparison table's rows."""
        return [f.row() for f in self.figures]

    def text(self) -> str:
        """The comparison as an aligned text table."""
        return render(COMPARISON_COLUMNS, self.rows(), "table")

    def csv(self) -> str:
        """The comparison as CSV."""
        return render(COMPARISON_COLUMNS, self.rows(), "csv")


def compare_runs(runs: Mapping[str, RunRecord], *, threshold_m: float = 1.0) -> Comparison:
    """The comparison of already simulated runs."""
    figs = [scenario_figures(rec, rec.proximity(threshold_m=threshold_m)) for rec in runs.values()]
    return Comparison(figures=figs, runs=dict(runs))


def _space_finder(project: ProjectData) -> Callable[[float, float, float], str]:
    """``nearest(x, y, floor_z)``: the room at a point of the storey whose elevation is nearest to
    ``floor_z`` (the robot's storey), or how far outside the nearest room of that storey it is."""
    spaces = []
    for r in run_named(project.graph, "space_bounds").as_dicts():
        spaces.append(
            (
                str(r["label"] or r["globalId"]),
                float(r["minX"]),
                float(r["minY"]),
                float(r["maxX"]),
                float(r["maxY"]),
                float(r["elevation"] or 0.0),
            )
        )

    def nearest(x: float, y: float, floor_z: float = 0.0) -> str:
        best, best_d = "", float("inf")
        if not spaces:
            return ""
        level = min((abs(s[5] - floor_z), s[5]) for s in spaces)[1]
        for label, x0, y0, x1, y1, elevation in spaces:
            if elevation != level:
                continue
            dx = max(x0 - x, 0.0, x - x1)
            dy = max(y0 - y, 0.0, y - y1)
            d = (dx * dx + dy * dy) ** 0.5
            if d < best_d:
                best, best_d = label, d
        if not best:
            return ""
        return best if best_d == 0.0 else f"outside, {best_d:.1f} m from {best}"

    return nearest


def write_outputs(
    project_dir: Path,
    scenario_runs: Sequence[ScenarioRun],
    out_dir: Path,
    *,
    threshold_m: float = 1.0,
    requirements: Any = None,
    selection: Sequence[Sequence[Any]] = (),
    project: ProjectData | None = None,
    task_tables: Mapping[str, tuple[Sequence[str], Sequence[Sequence[Any]]]] | None = None,
    loaded: Mapping[str | None, tuple[ProjectData, WorldTables | None]] | None = None,
) -> Comparison:
    """Comparison table, durations written back to the 4D model, and the report, into ``out_dir``.

    ``project`` is the loaded project (any scenario), to save loading it again; ``task_tables`` the
    per-scenario task tables of a whole-building run (a report section); ``loaded`` the loaded scenarios
    and their world tables (the playbacks' worlds), to save loading them again.
    """
    runs = {s.scenario: RunRecord.load(s.run_dir) for s in scenario_runs}
    comp = compare_runs(runs, threshold_m=threshold_m)
    atomic_write_text(out_dir / "comparison.csv", comp.csv())
    write_json(out_dir / "comparison.json", [asdict(f) for f in comp.figures])
    if project is None:
        project = ProjectData.load(project_dir)
    cal = WorkCalendar.from_calendar(project.manifest.calendar)
    task_rows = {r[1]: r for r in project.query("tasks_and_elements").rows}
    window = None
    for name, rec in runs.items():
        task_id = str(rec.manifest.get("task", ""))
        row = task_rows.get(task_id)
        if row is None or row[3] is None or row[4] is None:
            continue
        window = (row[3], row[4])
        fit = fit_schedule(task_id, row[3], row[4], rec.durations().total_s, cal)
        comp.fits[name] = fit
        g = results_graph(URIRef(row[0]), URIRef(f"{project.base}run/{name}"), fit, scenario=name)
        atomic_write_text(out_dir / "scenarios" / name / "results.ttl", g.serialize(format="turtle"))
        if project.manifest.schedule_from_ifc:
            ifc_with_results(project.manifest.ifc, {task_id: fit},
                             out_dir / "scenarios" / name / "model_with_results.ifc", scenario=name)
        if project.manifest.schedule is not None:
            atomic_write_text(
                out_dir / "scenarios" / name / "schedule_with_results.csv",
                schedule_csv_with_results(project.manifest.schedule, {task_id: fit}),
            )
    req_rows: list[list[Any]] = []
    req_cols: list[str] = []
    if requirements is not None:
        req_cols = ["#", "action", "skill", "input", "elements", "missing"]
        req_rows = [
            [r.number, r.action_label, r.skill_id, r.input_name, len(r.elements), r.missing]
            for r in requirements.requirements
        ]
    doc = build_report(
        runs,
        title=f"kbplanner: {project.name}",
        grids={s.scenario: s.grid for s in scenario_runs if s.grid is not None},
        layouts={s.scenario: s.layout for s in scenario_runs},
        requirements=req_rows,
        requirement_columns=req_cols,
        selection=selection,
        window=window,
        fits=comp.fits,
        threshold_m=threshold_m,
        space_of=_space_finder(project),
        reference=project.manifest.reference,
        task_tables=task_tables,
    )
    bcf = write_run_bcf(runs, out_dir, ifc_path=project.manifest.ifc, project_name=project.name,
                        created=run_issue_date(project, runs))
    add_playbacks(doc, runs, project_dir, out_dir, threshold_m=threshold_m, loaded=loaded)
    if bcf is not None:
        doc.note(f"{bcf.topics} element(s) not installed: one BCF topic each in {bcf.path.name}, for the "
                 "BIM authoring tool (a viewpoint at the element, its GlobalId selected).")
    doc.write(out_dir)
    return comp


def compare(
    project_dir: str | Path,
    scenarios: Sequence[str],
    *,
    out_dir: str | Path,
    seed: int | None = None,
    threshold_m: float = 1.0,
    progress: Progress | None = None,
) -> tuple[Comparison, list[ScenarioRun]]:
    """Simulate each scenario with the same seed into ``out_dir/<scenario>`` and compare them.

    Writes the comparison, the results written back to the 4D model and the report into ``out_dir``
    (atomically: the directory appears only when everything is written).

    Example:
        >>> comp, runs = compare("data/case_study", ["storage-outside", "storage-inside"],
        ...                      out_dir="runs/compare")  # doctest: +SKIP
        >>> print(comp.text())  # doctest: +SKIP
    """
    from kbplanner.core.outputs import run_directory
    from kbplanner.model.project_manifest import read_manifest

    project_dir, out_dir = Path(project_dir), Path(out_dir)
    manifest = read_manifest(project_dir)
    unknown = [n for n in scenarios if n not in manifest.scenarios]
    if unknown or not scenarios:
        raise KbplannerError(
            f"unknown scenario(s) {unknown}" if unknown else "no scenario given",
            file=manifest.path,
            fix="choose from: " + ", ".join(sorted(manifest.scenarios)),
        )
    runs: list[ScenarioRun] = []
    with run_directory(out_dir) as stage:
        for name in scenarios:
            runs.append(
                simulate_scenario(project_dir, name, seed=seed, out_dir=stage / name, progress=progress)
            )
        comp = write_outputs(project_dir, runs, stage, threshold_m=threshold_m)
    for r in runs:
        r.run_dir = out_dir / r.scenario
    comp.runs = {r.scenario: RunRecord.load(r.run_dir) for r in runs}
    return comp, runs
