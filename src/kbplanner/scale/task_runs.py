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

import logging
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kbplanner.analysis.comparison import ScenarioRun
from kbplanner.core.errors import KbplannerError
from kbplanner.core.output_dirs import current_command
from kbplanner.core.outputs import atomic_write_text, write_json
from kbplanner.core.tables import render
from kbplanner.model.project_data import ProjectData
from kbplanner.scale.task_jobs import TASK_COLUMNS, Outcome, TaskFigures, _Job, keep
from kbplanner.scale.task_pool import (
    Dispatch,
    TaskPool,
    _longest_first,
    cost_key,
    previous_costs,
    read_costs,
    start_order,
    write_costs,
)

if TYPE_CHECKING:
    from concurrent.futures import Future

    from kbplanner.world.tables import WorldTables

__all__ = ["TASK_COLUMNS", "ScenarioPart", "SimulationRun", "SimulationStage", "TaskFigures", "TaskPool",
           "TaskRunsResult", "_Job", "_longest_first", "robotized_tasks", "simulate_scenarios",
           "simulate_tasks"]

log = logging.getLogger(__name__)

Say = Callable[[str], None]


@dataclass
class TaskRunsResult:
    """Every task of one scenario: figures in task order, the main task's run, wall and CPU times.

    ``wall_s`` is the scenario's part of the simulation stage: from the stage's start to the end of its
    last task (with a pool shared by several scenarios the processes also ran the others' tasks in that
    time: ``stage`` holds the whole stage's figures)."""

    scenario: str | None
    out_dir: Path
    tasks: list[TaskFigures] = field(default_factory=list)
    main: ScenarioRun | None = None
    wall_s: float = 0.0
    task_wall_s: dict[str, float] = field(default_factory=dict)
    workers: int = 1
    task_cpu_s: dict[str, float] = field(default_factory=dict)
    task_span_s: dict[str, tuple[float, float, int]] = field(default_factory=dict)
    stage: dict[str, Any] = field(default_factory=dict)

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

    @property
    def cpu_s(self) -> float:
        """CPU seconds of the tasks (in the processes that ran them)."""
        return sum(self.task_cpu_s.values())

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

    def timing(self) -> dict[str, Any]:
        """Wall-clock figures (not deterministic): the scenario's simulated, wall and CPU seconds, its
        real-time factor (simulated / wall) and each task's simulated, wall and CPU seconds, start and
        end (from the stage's start) and process (0: the command's own)."""
        sim = {t.task_id: t.sim_time_s for t in self.tasks}
        return {
            "sim_time_s": round(self.sim_time_s, 1), "wall_s": round(self.wall_s, 3),
            "cpu_s": round(self.cpu_s, 3),
            "real_time_factor": round(self.sim_time_s / self.wall_s, 1) if self.wall_s > 0 else None,
            "per_task": {k: {"sim_time_s": round(sim.get(k, 0.0), 1), "wall_s": round(w, 3),
                             "cpu_s": round(self.task_cpu_s.get(k, 0.0), 3),
                             "start_s": self.task_span_s.get(k, (0.0, 0.0, 0))[0],
                             "end_s": self.task_span_s.get(k, (0.0, 0.0, 0))[1],
                             "process": self.task_span_s.get(k, (0.0, 0.0, 0))[2]}
                         for k, w in self.task_wall_s.items()}}

    def write(self, out_dir: Path) -> None:
        """``tasks.csv``, ``tasks.json`` (deterministic) and ``tasks_timings.json`` (wall times)."""
        atomic_write_text(out_dir / "tasks.csv", render(TASK_COLUMNS, self.rows(), fmt="csv"))
        write_json(out_dir / "tasks.json", {
            "scenario": self.scenario, "tasks": [asdict(t) for t in self.tasks], "installed": self.installed,
            "elements": self.elements, "sim_time_s": round(self.sim_time_s, 3)})
        write_json(out_dir / "tasks_timings.json", {
            "workers": self.workers, **self.timing(),
            "tasks": {k: round(v, 3) for k, v in self.task_wall_s.items()}, "stage": self.stage})


@dataclass
class ScenarioPart:
    """One scenario of a simulation stage: where its tasks go and, when loaded already, the scenario."""

    scenario: str | None
    out_dir: Path
    main_dir: Path | None = None
    project: ProjectData | None = None
    tables: WorldTables | None = None


@dataclass
class SimulationStage:
    """Every task of one or more scenarios simulated on one set of processes."""

    results: list[TaskRunsResult]
    wall_s: float
    workers: int

    @property
    def sim_time_s(self) -> float:
        """Simulated seconds over every task."""
        return sum(r.sim_time_s for r in self.results)

    @property
    def cpu_s(self) -> float:
        """CPU seconds of every task."""
        return sum(r.cpu_s for r in self.results)

    def timing(self) -> dict[str, Any]:
        """The stage's wall-clock figures: simulated, wall and CPU seconds, the real-time factor
        (simulated / wall) and how busy the processes were (CPU / (wall x processes)); per scenario
        :meth:`TaskRunsResult.timing`."""
        procs = max(1, min(self.workers, sum(len(r.tasks) for r in self.results)))
        return {
            "workers": self.workers, "sim_time_s": round(self.sim_time_s, 1), "wall_s": round(self.wall_s, 3),
            "cpu_s": round(self.cpu_s, 3),
            "real_time_factor": round(self.sim_time_s / self.wall_s, 1) if self.wall_s > 0 else None,
            "busy": round(self.cpu_s / (self.wall_s * procs), 3) if self.wall_s > 0 else None,
            "scenarios": {r.scenario or "": r.timing() for r in self.results}}


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
    part = ScenarioPart(scenario, out_dir, main_dir, project, tables)
    stage = simulate_scenarios(project_dir, [part], tasks=tasks, seed=seed, workers=workers,
                               keyframes=keyframes, progress=progress, max_elements=max_elements, pool=pool)
    return stage.results[0]


def _jobs_of(project_dir: Path, part: ScenarioPart, project: ProjectData, tasks: Sequence[str] | None,
             seed: int | None, keyframes: bool, max_elements: int | None) -> tuple[list[_Job], list[int]]:
    """The jobs of one scenario, in schedule order, and their element counts (for the start order)."""
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
        where = part.main_dir if (is_main and part.main_dir is not None) else part.out_dir / task_id
        rel = Path(os.path.relpath(where.resolve(), part.out_dir.resolve())).as_posix()
        jobs.append(_Job(project_dir, part.scenario, task_id, label, seed, where, rel,
                         keyframes and is_main, is_main, max_elements, current_command()))
    return jobs, sizes


def simulate_scenarios(
    project_dir: Path,
    parts: Sequence[ScenarioPart],
    *,
    tasks: Sequence[str] | None = None,
    seed: int | None = None,
    workers: int = 1,
    keyframes: bool = False,
    progress: Say | None = None,
    max_elements: int | None = None,
    pool: TaskPool | None = None,
    previous: Mapping[str | None, Path] | None = None,
) -> SimulationStage:
    """Simulate every robotized task (or ``tasks``) of several scenarios of one project on one set of
    ``workers`` processes (this one and ``workers - 1`` spawned, or ``pool``'s, warmed with these
    scenarios): the jobs of all scenarios share the processes, so a long task of one scenario runs
    beside the short ones of another. Each scenario's tables and run directories are written as by
    :func:`simulate_tasks` and are the same whatever the number of workers and the start order (from
    the last run's CPU seconds per task, see :mod:`kbplanner.scale.task_pool`, else the wall seconds per
    task in ``previous``, each scenario's tasks directory of the run folder being replaced); the costs
    of this run are recorded for the next.

    Raises:
        KbplannerError: an unknown task id, fewer than one worker.
    """
    return SimulationRun(project_dir, parts, tasks=tasks, seed=seed, workers=workers, keyframes=keyframes,
                         progress=progress, max_elements=max_elements, pool=pool,
                         previous=previous).begin().finish()


class SimulationRun:
    """A simulation stage (:func:`simulate_scenarios`) in steps, so that it can begin before the caller
    knows whether each scenario is to be simulated: :meth:`begin` starts the spawned processes on the
    jobs; scenarios named in ``unconfirmed`` are then :meth:`confirm`-ed (with their world tables) or
    :meth:`drop`-ped (their jobs skipped, their outcomes forgotten); :meth:`finish` has this process
    take jobs too, waits for the last and writes the tables. What is written is the same as
    :func:`simulate_scenarios` writes for the confirmed scenarios."""

    def __init__(self, project_dir: Path, parts: Sequence[ScenarioPart], *,
                 tasks: Sequence[str] | None = None, seed: int | None = None, workers: int = 1,
                 keyframes: bool = False, progress: Say | None = None, max_elements: int | None = None,
                 pool: TaskPool | None = None, previous: Mapping[str | None, Path] | None = None,
                 unconfirmed: Sequence[str | None] = ()) -> None:
        say = progress or (lambda _m: None)
        if workers < 1:
            raise KbplannerError(f"workers must be at least 1, got {workers}", element="--workers",
                                 fix="give --workers 1 or more (the number of cores is a good choice)")
        self.project_dir, self.parts, self.workers, self.pool = project_dir, list(parts), workers, pool
        self.unconfirmed = list(unconfirmed)
        self.jobs: list[_Job] = []
        sizes: list[int] = []
        self.owner: list[int] = []
        for k, part in enumerate(parts):
            project = part.project or ProjectData.load(project_dir, scenario=part.scenario)
            keep(project_dir, part.scenario, project, part.tables)
            pjobs, psizes = _jobs_of(project_dir, part, project, tasks, seed, keyframes, max_elements)
            self.jobs += pjobs
            sizes += psizes
            self.owner += [k] * len(pjobs)
        for part in parts:
            part.out_dir.mkdir(parents=True, exist_ok=True)
        counts = [self.owner.count(k) for k in range(len(parts))]
        finished = [0] * len(parts)

        def tell(job: _Job, res: Outcome) -> None:
            k = next(i for i, p in enumerate(parts) if p.scenario == job.scenario)
            finished[k] += 1
            f = res.figures
            say(f"{job.scenario or 'bare'}: tasks {finished[k]}/{counts[k]} ({f.task_id}: {f.installed}/"
                f"{f.elements} installed, {f.sim_time_s / 60.0:.1f} min simulated in {res.wall_s:.0f} s)")

        self.tell = tell
        self.order = list(range(len(self.jobs)))
        if workers > 1:
            costs = read_costs(project_dir)
            if previous and not all(cost_key(j) in costs for j in self.jobs):
                costs = previous_costs(self.jobs, sizes, previous)
            self.order = start_order(self.jobs, sizes, costs)
        self.t0 = time.perf_counter()
        self.dispatch = Dispatch(self.jobs, self.order, workers, tell, pool, self.t0, self.unconfirmed)

    def begin(self, here: bool = True, gate: Sequence[Future[Any]] = ()) -> SimulationRun:
        """Start the spawned processes on the jobs (``here``: this process takes jobs at once too, by
        :meth:`finish`; else it has other work first; ``gate``: what the spawned processes do first,
        :meth:`Dispatch.begin`)."""
        self.t0 = self.dispatch.start = time.perf_counter()
        self.dispatch.begin(here, gate)
        return self

    def confirm(self, scenario: str | None, project: ProjectData | None = None,
                tables: WorldTables | None = None) -> None:
        """The scenario is simulated (``project`` and ``tables``: as loaded and read here, for this
        process's jobs)."""
        if project is not None:
            keep(self.project_dir, scenario, project, tables)
        self.dispatch.confirm(scenario)

    def drop(self, scenario: str | None) -> None:
        """The scenario is not simulated: its jobs are skipped, their outcomes forgotten; returns once
        none of them runs (the caller may then remove what they wrote)."""
        self.dispatch.drop(scenario)
        self.dispatch.settle(scenario)
        self.parts = [p for p in self.parts if p.scenario != scenario]

    def release(self) -> None:
        """The stage is over: the spawned processes of ``pool`` end while the caller goes on
        (:meth:`TaskPool.release`; leaving the pool waits for them)."""
        if self.pool is not None:
            self.pool.release()

    def finish(self) -> SimulationStage:
        """This process takes jobs too until none is left; every scenario's tables written, the costs
        recorded; the stage's figures (its wall time from :meth:`begin`)."""
        for scenario in self.unconfirmed:  # every scenario not dropped by now is simulated
            if scenario not in self.dispatch.dropped:
                self.dispatch.confirm(scenario)
        with self.dispatch.stack:
            self.dispatch.run_here()
            done = self.dispatch.wait()
        wall = time.perf_counter() - self.t0
        parts = self.parts
        results = [TaskRunsResult(scenario=p.scenario, out_dir=p.out_dir, workers=self.workers)
                   for p in parts]
        by_scenario = {p.scenario: r for p, r in zip(parts, results, strict=True)}
        kept = [i for i in range(len(self.jobs)) if self.jobs[i].scenario in by_scenario]
        for i in kept:
            job, res = self.jobs[i], done[i]
            r = by_scenario[job.scenario]
            r.tasks.append(res.figures)
            r.task_wall_s[job.task_id] = res.wall_s
            r.task_cpu_s[job.task_id] = res.cpu_s
            r.task_span_s[job.task_id] = (res.start_s, res.end_s, res.process)
            r.wall_s = max(r.wall_s, res.end_s)
            if res.run is not None:
                r.main = res.run
        stage = SimulationStage(results, wall, self.workers)
        shared = stage.timing()
        shared.pop("scenarios")
        shared["scenarios_sharing"] = [p.scenario or "" for p in parts]
        for r in results:
            if len(parts) > 1:
                r.stage = shared
            r.write(r.out_dir)
            log.info("%d tasks of %s: %d/%d installed, %.0f s simulated in %.0f s wall", len(r.tasks),
                     r.scenario, r.installed, r.elements, r.sim_time_s, r.wall_s)
        write_costs(self.project_dir, {cost_key(self.jobs[i]): done[i].cpu_s for i in kept})
        return stage
