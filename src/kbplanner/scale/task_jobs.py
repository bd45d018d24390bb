"""Whole-building runs, one job: B1-B5 of one robotized task, in whichever process takes it.

A job names the project, the scenario, the task and where its run directory goes; :func:`run_job`
simulates it with the scenario loaded (and its world tables read) once per process, and returns the
task's figures (deterministic) with the job's wall and CPU seconds (not deterministic, kept apart).
A process keeps every scenario of one project it has loaded, so a pool shared by the scenarios of a
``kbplanner run`` loads each scenario once per process, whatever order the jobs come in.
"""

from __future__ import annotations

import gc
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kbplanner.analysis.comparison import ScenarioRun, simulate_scenario
from kbplanner.analysis.report import scenario_figures
from kbplanner.analysis.run_record import RunRecord
from kbplanner.analysis.work_done import work_done
from kbplanner.core.heap import growing
from kbplanner.core.output_dirs import output_options
from kbplanner.model.project_data import ProjectData

if TYPE_CHECKING:
    from kbplanner.world.tables import WorldTables

log = logging.getLogger(__name__)

TASK_COLUMNS = ["task", "label", "world date", "installed", "elements", "simulated (min)",
                "per element (min)", "min separation (m)", "time < 1 m (s)", "stops for workers", "work done"]


@dataclass(frozen=True)
class TaskFigures:
    """What the simulation of one robotized task gave (deterministic: no wall times)."""

    task_id: str
    label: str
    world_date: str
    installed: int
    elements: int
    sim_time_s: float
    per_element_min: float | None
    min_separation_m: float
    below_threshold_s: float
    worker_stops: int
    run_dir: str  # relative to the tasks directory (``out_dir``)
    work: str = ""  # what the run did in words (kbplanner.analysis.work_done)

    def row(self) -> list[Any]:
        """One row of ``tasks.csv``."""
        return [self.task_id, self.label, self.world_date, self.installed, self.elements,
                round(self.sim_time_s / 60.0, 2),
                None if self.per_element_min is None else round(self.per_element_min, 2),
                round(self.min_separation_m, 2), round(self.below_threshold_s, 1), self.worker_stops,
                self.work]


@dataclass(frozen=True)
class _Job:
    project_dir: Path
    scenario: str | None
    task_id: str
    label: str
    seed: int | None
    out_dir: Path
    rel_dir: str
    keyframes: bool
    main: bool
    max_elements: int | None
    command: str = ""  # recorded in each run folder's marker, whichever process writes it


@dataclass(frozen=True)
class Outcome:
    """One job's result: the figures, the main task's run, and the job's wall and CPU seconds (in the
    process that ran it); ``start_s``/``end_s`` (from the stage's start) and ``process`` (0: the
    command's own) are filled in by the process that handed the job out."""

    figures: TaskFigures
    run: ScenarioRun | None
    wall_s: float
    cpu_s: float
    start_s: float = 0.0
    end_s: float = 0.0
    process: int = 0


_LOADED: dict[tuple[str, str | None], ProjectData] = {}
_TABLES: dict[tuple[str, str | None], WorldTables] = {}


def _key(project_dir: Path, scenario: str | None) -> tuple[str, str | None]:
    return str(project_dir.resolve()), scenario


def keep(project_dir: Path, scenario: str | None, project: ProjectData,
         tables: WorldTables | None = None) -> None:
    """Use ``project`` (and ``tables``) for the scenario's jobs in this process (already loaded)."""
    key = _key(project_dir, scenario)
    _forget_other_projects(key[0])
    _LOADED[key] = project
    if tables is not None:
        _TABLES[key] = tables
    else:
        _TABLES.pop(key, None)


def _forget_other_projects(project: str) -> None:
    gone = [k for k in _LOADED if k[0] != project]
    for k in gone:
        _LOADED.pop(k, None)
        _TABLES.pop(k, None)
    if gone:  # what warm set aside may be garbage now
        gc.unfreeze()


def _loaded(project_dir: Path, scenario: str | None) -> ProjectData:
    """The loaded scenario, once per process (a worker process simulates several tasks, of one or more
    scenarios of one project)."""
    key = _key(project_dir, scenario)
    if key not in _LOADED:
        _forget_other_projects(key[0])
        _LOADED[key] = ProjectData.load(project_dir, scenario=scenario)
    return _LOADED[key]


def _project(project_dir: Path, scenario: str | None) -> tuple[ProjectData, WorldTables]:
    """The loaded scenario and its world tables, once per process (each task's world is built from the
    same tables instead of reading the building again)."""
    from kbplanner.world.tables import world_tables

    project = _loaded(project_dir, scenario)
    key = _key(project_dir, scenario)
    tables = _TABLES.get(key)
    if tables is None or tables.model_id != id(project.model):
        tables = _TABLES[key] = world_tables(project)
    return project, tables


def imports() -> None:
    """Import what a task uses (a new worker process, before it is given the project)."""
    import kbplanner.planning.manipulation
    import kbplanner.planning.planner
    import kbplanner.simulation.executor
    import kbplanner.world.build
    import kbplanner.world.maps
    import kbplanner.world.tables  # noqa: F401


def ready() -> None:
    """What a new worker process can do before it is given the project (while the command loads it):
    import what a task uses and parse every named query (1-4 s it would spend after the load)."""
    from kbplanner.core.named_queries import prepare_all

    imports()
    prepare_all()


def warm(project_dir: Path, scenarios: Sequence[str | None]) -> None:
    """A new worker process loads the scenarios and their world tables (with the merged graph they are
    read from) before its first task, and parses every named query: 1-2 s per process that its first
    task would otherwise spend, done while the command validates and builds the worlds. An error is
    left for the task to raise (with its message) when it loads the scenario again."""
    ready()  # done already by a process started before the load (TaskPool with load=False)
    with growing():  # the scenarios live as long as the process: set aside from the collector
        for scenario in scenarios:
            try:
                _project(project_dir, scenario)
            except Exception as exc:  # the task raises it again, as a task's error
                log.info("worker process could not load %s (%s): %s", project_dir, scenario, exc)


@dataclass(frozen=True)
class Verdict:
    """What :func:`validate_job` found (its report files are written where it was told)."""

    conforms: bool
    violations: int
    seconds: float


def validate_job(project_dir: Path, scenario: str | None, out_dir: Path) -> Verdict:
    """A4 of a loaded scenario in a task process: ``validation.ttl`` and ``validation.txt`` written into
    ``out_dir``, the same files the command's own validation writes (the pipeline hands it to a spawned
    process, whose first task waits less than the command's, while the command selects the robots and
    builds the world)."""
    from kbplanner.core.outputs import atomic_write_text
    from kbplanner.knowledge.validation import validate_model

    t0 = time.perf_counter()
    project = _loaded(project_dir, scenario)
    val = validate_model(project.model, project.kb)  # as Project.validate
    val.write(out_dir / "validation.ttl")
    atomic_write_text(out_dir / "validation.txt", val.text())
    return Verdict(val.conforms, len(val.violations), round(time.perf_counter() - t0, 3))


def run_job(job: _Job) -> Outcome:
    """Simulate one task (B1-B5) into its run directory; its figures and wall and CPU seconds."""
    t0, c0 = time.perf_counter(), time.process_time()
    project, tables = _project(job.project_dir, job.scenario)
    with output_options(command=job.command or None):
        run = simulate_scenario(job.project_dir, job.scenario, seed=job.seed, out_dir=job.out_dir,
                                keyframes=job.keyframes, task_id=job.task_id, project=project,
                                max_elements=job.max_elements, tables=tables)
    rec = RunRecord.load(job.out_dir)
    fig = scenario_figures(rec, rec.proximity(threshold_m=1.0))
    world_date = project.world_date(job.task_id).isoformat()  # the date simulate_scenario's world used
    figures = TaskFigures(
        task_id=job.task_id, label=job.label, world_date=world_date, installed=fig.installed,
        elements=fig.elements, sim_time_s=float(rec.metrics.get("totals", {}).get("sim_time_s", 0.0)),
        per_element_min=fig.per_element_min, min_separation_m=fig.min_separation_m,
        below_threshold_s=fig.below_threshold_s, worker_stops=fig.worker_stops, run_dir=job.rel_dir,
        work=work_done(rec.metrics))
    return Outcome(figures, run if job.main else None, time.perf_counter() - t0, time.process_time() - c0)
