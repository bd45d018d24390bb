"""Whole-building runs (B1-B5 for every robotized task of a scenario), one task per worker process.

The main job simulates the project's ``[simulation] task``. :func:`simulate_tasks` simulates each
robotized task of the schedule (on a generated building: the framing of each storey), each in the
world at its own date (the ``[simulation] date`` for the ``[simulation] task``, the task's start for
the others), with the same seed, each into its own run directory, on ``workers`` local processes.
A task's simulation depends only on the project, the task and the seed, so the figures and files are
the same whatever the number of workers (a test checks 1 and 2); wall times are kept apart
(``timings``, never in the deterministic tables).

Example:
    >>> from pathlib import Path
    >>> r = simulate_tasks(Path("runs/b10x8"), "storage-in-units", out_dir=Path("runs/b10x8-tasks"),
    ...                    workers=2)  # doctest: +SKIP
    >>> sum(t.installed for t in r.tasks), r.sim_time_s / r.wall_s  # doctest: +SKIP
    (1120, 240.3)
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kbplanner.analysis.comparison import ScenarioRun, simulate_scenario
from kbplanner.analysis.report import scenario_figures
from kbplanner.analysis.run_record import RunRecord
from kbplanner.analysis.work_done import work_done
from kbplanner.core.errors import KbplannerError
from kbplanner.core.output_dirs import current_command, output_options
from kbplanner.core.outputs import atomic_write_text, write_json
from kbplanner.core.tables import render
from kbplanner.model.project_data import ProjectData

if TYPE_CHECKING:
    from kbplanner.world.tables import WorldTables

log = logging.getLogger(__name__)

Say = Callable[[str], None]

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


@dataclass
class TaskRunsResult:
    """Every task of one scenario: figures in task order, the main task's run, wall times."""

    scenario: str | None
    out_dir: Path
    tasks: list[TaskFigures] = field(default_factory=list)
    main: ScenarioRun | None = None
    wall_s: float = 0.0
    task_wall_s: dict[str, float] = field(default_factory=dict)
    workers: int = 1

    @property
    def installed(self) -> int:
        """Elements installed over all tasks."""
        return sum(t.installed for t in self.tasks)

    @property
    def elements(self) -> int:
        """Elements of all tasks."""
        return sum(t.elements for t in self.tasks)

    @property
    def sim_time_s(self) -> float:
        """Simulated seconds over all tasks."""
        return sum(t.sim_time_s for t in self.tasks)

    def rows(self) -> list[list[Any]]:
        """The table of ``tasks.csv`` with a totals row."""
        out = [t.row() for t in self.tasks]
        seps = [t.min_separation_m for t in self.tasks]
        out.append(["all", f"{len(self.tasks)} tasks", "", self.installed, self.elements,
                    round(self.sim_time_s / 60.0, 2),
                    round(self.sim_time_s / 60.0 / self.installed, 2) if self.installed else None,
                    round(min(seps), 2) if seps else None,
                    round(sum(t.below_threshold_s for t in self.tasks), 1),
                    sum(t.worker_stops for t in self.tasks), ""])
        return out

    def text(self) -> str:
        """The table as aligned text."""
        return render(TASK_COLUMNS, self.rows())

    def write(self, out_dir: Path) -> None:
        """``tasks.csv``, ``tasks.json`` (deterministic) and ``tasks_timings.json`` (wall times)."""
        atomic_write_text(out_dir / "tasks.csv", render(TASK_COLUMNS, self.rows(), fmt="csv"))
        write_json(out_dir / "tasks.json", {
            "scenario": self.scenario, "tasks": [asdict(t) for t in self.tasks], "installed": self.installed,
            "elements": self.elements, "sim_time_s": round(self.sim_time_s, 3)})
        write_json(out_dir / "tasks_timings.json", {
            "workers": self.workers, "wall_s": round(self.wall_s, 3),
            "real_time_factor": round(self.sim_time_s / self.wall_s, 1) if self.wall_s > 0 else None,
            "tasks": {k: round(v, 3) for k, v in self.task_wall_s.items()}})


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


_LOADED: dict[tuple[str, str | None], ProjectData] = {}
_TABLES: dict[tuple[str, str | None], WorldTables] = {}


def _loaded(project_dir: Path, scenario: str | None) -> ProjectData:
    """The loaded scenario, once per process (a worker process simulates several tasks)."""
    key = (str(project_dir.resolve()), scenario)
    if key not in _LOADED:
        _LOADED.clear()
        _TABLES.clear()
        _LOADED[key] = ProjectData.load(project_dir, scenario=scenario)
    return _LOADED[key]


def _project(project_dir: Path, scenario: str | None) -> tuple[ProjectData, WorldTables]:
    """The loaded scenario and its world tables, once per process (each task's world is built from the
    same tables instead of reading the building again)."""
    from kbplanner.world.tables import world_tables

    project = _loaded(project_dir, scenario)
    key = (str(project_dir.resolve()), scenario)
    tables = _TABLES.get(key)
    if tables is None or tables.model_id != id(project.model):
        tables = _TABLES[key] = world_tables(project)
    return project, tables


_Outcome = tuple[TaskFigures, ScenarioRun | None, float]


def _warm(project_dir: Path, scenario: str | None) -> None:
    """A new worker process loads the scenario before its first task (its world tables at the first
    task: by then the project cache holds their rows). An error is left for the task to raise (with
    its message) when it loads the scenario again."""
    try:
        _loaded(project_dir, scenario)
    except Exception as exc:  # the task raises it again, as a task's error
        log.info("worker process could not load %s (%s): %s", project_dir, scenario, exc)


def _started() -> None:
    """Nothing: submitted once per worker process so that each starts (and warms up) at once."""


class TaskPool:
    """The ``workers - 1`` spawned processes of :func:`simulate_tasks`, started ahead of it.

    Each process loads the scenario as soon as it starts, so a caller that has other work first (the
    pipeline: validation, the world) hands over warm processes.
    Use as a context manager; leaving it on an error stops the processes without waiting.
    """

    def __init__(self, project_dir: Path, scenario: str | None, workers: int) -> None:
        self.children = max(0, workers - 1)
        self.executor: ProcessPoolExecutor | None = None
        if self.children:
            self.executor = ProcessPoolExecutor(max_workers=self.children,
                                                mp_context=multiprocessing.get_context("spawn"),
                                                initializer=_warm, initargs=(project_dir, scenario))
            for _ in range(self.children):  # the pool starts a process per submission while none is idle
                self.executor.submit(_started)

    def __enter__(self) -> TaskPool:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *_exc: object) -> None:
        if self.executor is None:
            return
        if exc_type is not None:  # an error: do not wait for a process still loading the project
            for proc in list(getattr(self.executor, "_processes", {}).values()):
                proc.terminate()
        self.executor.shutdown(wait=exc_type is None, cancel_futures=True)


def _run(job: _Job) -> _Outcome:
    t0 = time.perf_counter()
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
    return figures, (run if job.main else None), time.perf_counter() - t0


def _dispatch(jobs: Sequence[_Job], order: Sequence[int], workers: int,
              tell: Callable[[_Job, _Outcome], None], pool: TaskPool | None = None) -> dict[int, _Outcome]:
    """Run ``jobs`` (taken in ``order``) on ``workers`` processes: this one and ``workers - 1`` spawned.

    This process takes the next job whenever it is free, and so does each spawned process (one thread
    here waits for each); results are kept by job index, so what is written does not depend on who
    ran what or when. The first error (in job order) is raised once every started job has ended.
    """
    pending = deque(order)
    lock = threading.Lock()
    done: dict[int, _Outcome] = {}
    failed: dict[int, BaseException] = {}

    def take() -> int | None:
        with lock:
            return pending.popleft() if pending and not failed else None

    def record(i: int, outcome: _Outcome | None, error: BaseException | None) -> None:
        with lock:
            if error is not None:
                failed[i] = error
            elif outcome is not None:
                done[i] = outcome
                tell(jobs[i], outcome)

    def feed(pool: ProcessPoolExecutor | None) -> None:
        assert pool is not None  # a thread per spawned process
        while (i := take()) is not None:
            try:
                record(i, pool.submit(_run, jobs[i]).result(), None)
            except BaseException as exc:  # raised again in the calling thread
                record(i, None, exc)

    with (TaskPool(jobs[0].project_dir, jobs[0].scenario, min(workers, len(jobs))) if pool is None
          else contextlib.nullcontext(pool)) as tp:
        children = min(tp.children, len(jobs) - 1)
        threads = [threading.Thread(target=feed, args=(tp.executor,), daemon=True) for _ in range(children)]
        for t in threads:
            t.start()
        while (i := take()) is not None:
            try:
                record(i, _run(jobs[i]), None)
            except BaseException as exc:  # raised below, once the others ended
                record(i, None, exc)
        for t in threads:
            t.join()
    if failed:
        raise failed[min(failed)]
    return done


def robotized_tasks(project: ProjectData) -> list[tuple[str, str, datetime | None]]:
    """(task id, label, start) of every robotized task, in schedule order."""
    return [(task_id, label, start) for task_id, label, start, _n in _robotized(project)]


def _robotized(project: ProjectData) -> list[tuple[str, str, datetime | None, int]]:
    """(task id, label, start, elements) of every robotized task, in schedule order."""
    out = []
    for row in project.query("tasks_and_elements").rows:
        _task, task_id, label, start, _finish, robotized, _spec, elements = row[:8]
        if not robotized or str(robotized).lower() in ("false", "0"):
            continue
        when = start.toPython() if hasattr(start, "toPython") else start
        out.append((str(task_id), str(label or task_id),
                    when.replace(tzinfo=None) if isinstance(when, datetime) else None, int(elements or 0)))
    return out


def _longest_first(jobs: Sequence[_Job], sizes: Sequence[int]) -> list[int]:
    """Job indices in the order to start them on several processes: the main task first (it draws key
    frames), then by elements, most first, then in schedule order; fewer idle processes at the end."""
    return sorted(range(len(jobs)), key=lambda i: (not jobs[i].main, -sizes[i], i))


def simulate_tasks(
    project_dir: Path,
    scenario: str | None,
    *,
    out_dir: Path,
    tasks: Sequence[str] | None = None,
    seed: int | None = None,
    workers: int = 1,
    main_dir: Path | None = None,
    keyframes: bool = False,
    progress: Say | None = None,
    project: ProjectData | None = None,
    max_elements: int | None = None,
    tables: WorldTables | None = None,
    pool: TaskPool | None = None,
) -> TaskRunsResult:
    """Simulate every robotized task (or ``tasks``) of a scenario; see the module docstring.

    Each task's run directory is ``out_dir/<task id>``; the ``[simulation] task`` goes to ``main_dir``
    instead when given (the pipeline's ``simulation`` directory, with key frames when ``keyframes``).
    Writes ``tasks.csv``, ``tasks.json`` and ``tasks_timings.json`` into ``out_dir``. ``max_elements``
    simulates the first elements of each task only. ``project`` (the loaded scenario) and ``tables`` (its
    world tables) save reading them again in this process, which runs tasks too: with ``workers`` = N,
    this process and N - 1 spawned ones each take the next task when free, the largest first.
    ``pool`` (a :class:`TaskPool` of the same project and scenario, started ahead) gives the spawned ones.

    Raises:
        KbplannerError: an unknown task id, fewer than one worker.
    """
    say = progress or (lambda _m: None)
    if workers < 1:
        raise KbplannerError(f"workers must be at least 1, got {workers}", element="--workers",
                             fix="give --workers 1 or more (the number of cores is a good choice)")
    project = project or ProjectData.load(project_dir, scenario=scenario)
    main_task = str(project.manifest.simulation.get("task") or "")
    known = _robotized(project)
    if tasks is not None:
        wanted = list(tasks)
        ids = {k[0] for k in known}
        unknown = [t for t in wanted if t not in ids]
        if unknown:
            raise KbplannerError(f"not a robotized task of the schedule: {', '.join(unknown)}",
                                 file=project.manifest.path, element=unknown[0],
                                 fix=f"use one of {', '.join(sorted(ids)) or '(none)'}")
        known = [k for k in known if k[0] in wanted]
    if not main_task and known:
        main_task = known[0][0]
    jobs = []
    sizes = [min(n, max_elements) if max_elements is not None else n for *_k, n in known]
    for task_id, label, _start, _n in known:
        is_main = task_id == main_task
        where = main_dir if (is_main and main_dir is not None) else out_dir / task_id
        rel = Path(os.path.relpath(where.resolve(), out_dir.resolve())).as_posix()
        jobs.append(_Job(project_dir, scenario, task_id, label, seed, where, rel,
                         keyframes and is_main, is_main, max_elements, current_command()))
    key = (str(project_dir.resolve()), scenario)
    _LOADED.clear()
    _TABLES.clear()
    _LOADED[key] = project
    if tables is not None:
        _TABLES[key] = tables
    result = TaskRunsResult(scenario=scenario, out_dir=out_dir, workers=workers)
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    done: dict[str, _Outcome] = {}

    def tell(job: _Job, res: _Outcome) -> None:
        done[job.task_id] = res
        f = res[0]
        say(f"{scenario or 'bare'}: tasks {len(done)}/{len(jobs)} ({f.task_id}: {f.installed}/{f.elements} "
            f"installed, {f.sim_time_s / 60.0:.1f} min simulated in {res[2]:.0f} s)")

    if workers == 1 or len(jobs) <= 1:
        for job in jobs:
            tell(job, _run(job))
    else:
        _dispatch(jobs, _longest_first(jobs, sizes), workers, tell, pool)
    result.wall_s = time.perf_counter() - t0
    for job in jobs:
        fig, run, wall = done[job.task_id]
        result.tasks.append(fig)
        result.task_wall_s[job.task_id] = wall
        if run is not None:
            result.main = run
    result.write(out_dir)
    log.info("%d tasks of %s: %d/%d installed, %.0f s simulated in %.0f s wall", len(jobs), scenario,
             result.installed, result.elements, result.sim_time_s, result.wall_s)
    return result
