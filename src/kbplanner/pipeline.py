"""The main job (all steps): one project, every scenario, from IFC to the report, into one run directory.

``run_pipeline(project_dir, out_dir)`` loads the bare 4D model and derives the additional modeling
requirements (A1-A3, with a Turtle template of what is missing), then for each scenario validates
the augmented model (A4-A5), selects robots (B3), builds the world at the simulation date (A6) and
simulates the robotized task (B1-B5) with the project's seed (``tasks="all"``: every robotized task of
every scenario, on processes the scenarios share, once each scenario's world is built); finally it
compares the scenarios, writes the simulated durations back to the 4D model and writes the report.
Every stage is timed; the run directory is assembled in ``OUT.partial`` and renamed when complete.
"""

from __future__ import annotations

import contextlib
import logging
import resource
import shutil
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kbplanner.analysis.comparison import Comparison, ScenarioRun, simulate_scenario, write_outputs
from kbplanner.core.heap import frozen, growing, set_aside
from kbplanner.core.outputs import atomic_write_text, input_hashes, run_directory, versions, write_json
from kbplanner.project import Project, read_manifest

if TYPE_CHECKING:
    from concurrent.futures import Future

    from kbplanner.scale.task_jobs import Verdict
    from kbplanner.scale.task_runs import ScenarioPart, SimulationRun, SimulationStage, TaskPool

log = logging.getLogger(__name__)

Say = Callable[[str], None]


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far (MiB)."""
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kb / 1024.0 if sys.platform != "darwin" else kb / (1024.0 * 1024.0)


@dataclass
class StageTiming:
    """Wall time, memory and CPU time (of the command's process) of one pipeline stage."""

    stage: str
    scenario: str | None
    seconds: float
    peak_rss_mb: float
    cpu_s: float | None = None  # None: timed elsewhere (it ran beside the others)


@dataclass
class ScenarioSummary:
    """What one scenario gave."""

    name: str
    conforms: bool
    violations: int
    fit_robots: list[str]
    world_static: int
    world_task_elements: int
    map_cells: tuple[int, int]
    installed: int = 0
    elements: int = 0
    simulated: bool = False
    tasks: int = 1
    sim_time_s: float | None = None


@dataclass
class PipelineResult:
    """The outcome of :func:`run_pipeline`."""

    out_dir: Path
    project: str
    requirements: int
    requirement_elements: int
    scenarios: list[ScenarioSummary] = field(default_factory=list)
    timings: list[StageTiming] = field(default_factory=list)
    seconds: float = 0.0
    comparison: Comparison | None = None
    simulation: SimulationStage | None = None  # --tasks all: every task's figures and wall-clock times

    @property
    def ok(self) -> bool:
        """True when every scenario conforms and, where simulated, installed every element."""
        return all(s.conforms and (not s.simulated or s.installed == s.elements) for s in self.scenarios)


class _Clock:
    def __init__(self, say: Say) -> None:
        self.say = say
        self.timings: list[StageTiming] = []

    @contextmanager
    def stage(self, name: str, scenario: str | None = None) -> Iterator[None]:
        label = f"{name} [{scenario}]" if scenario else name
        self.say(f"{label} ...")
        t0, c0 = time.perf_counter(), time.process_time()
        yield
        dt = time.perf_counter() - t0
        self.timings.append(StageTiming(name, scenario, round(dt, 3), round(peak_rss_mb(), 1),
                                        round(time.process_time() - c0, 3)))
        self.say(f"{label} done in {dt:.1f} s")

    def add(self, name: str, scenario: str | None, seconds: float) -> None:
        """A stage timed elsewhere (it ran beside the others)."""
        self.timings.append(StageTiming(name, scenario, round(seconds, 3), round(peak_rss_mb(), 1)))


def _project_files(project: Project) -> list[Path]:
    m = project.manifest
    files = [m.path, m.ifc, *m.site, *m.jobsite, *m.knowledge_base, *m.augmentation]
    if m.schedule is not None:
        files.append(m.schedule)
    for s in m.scenarios.values():
        files.extend(s.overlays)
    return files


def run_pipeline(project_dir: Path, out_dir: Path, *, scenarios: list[str] | None = None,
                 say: Say | None = None, simulate: bool = True, seed: int | None = None,
                 tasks: str = "main", workers: int = 1, max_elements: int | None = None) -> PipelineResult:
    """Run every stage on a project and write the run directory.

    ``tasks="all"`` simulates every robotized task of each scenario (a whole building: the
    ``[simulation] task`` into ``simulation/`` as usual, the others into ``tasks/<id>/``, with
    ``tasks.csv``), on ``workers`` local processes (:mod:`kbplanner.scale.task_runs`). ``max_elements``
    simulates
    the first elements of each task only (a quick look).

    Example:
        >>> r = run_pipeline(Path("data/case_study"), Path("runs/case_study"))  # doctest: +SKIP
        >>> [s.conforms for s in r.scenarios]  # doctest: +SKIP
        [True, True]
    """
    say = say or (lambda _m: None)
    t_start = time.perf_counter()
    manifest = read_manifest(project_dir)
    names = scenarios if scenarios is not None else sorted(manifest.scenarios)
    clock = _Clock(say)
    with frozen(), run_directory(out_dir) as stage, contextlib.ExitStack() as later:
        ahead = _tasks_ahead(project_dir, stage, names, clock, later, workers=workers, seed=seed,
                             max_elements=max_elements, previous=out_dir) \
            if simulate and tasks == "all" and workers > 1 else None
        with clock.stage("import and load"), growing():  # it lives to the report: set aside
            bare = Project.load(project_dir)
        with clock.stage("summary"):
            info = bare.info()
            write_json(stage / "info.json", asdict(info))
        with clock.stage("requirements"):
            req = bare.requirements()
            atomic_write_text(stage / "requirements.csv", req.to_csv())
            atomic_write_text(stage / "requirements.json", req.to_json())
            atomic_write_text(stage / "requirements.txt", req.text())
            if req.requirements:
                atomic_write_text(stage / "requirements_template.ttl", req.template(bare.base))
        result = PipelineResult(
            out_dir=out_dir, project=bare.name, requirements=len(req.requirements),
            requirement_elements=sum(len(r.elements) for r in req.requirements),
        )
        sims: dict[str, ScenarioRun] = {}
        task_tables: dict[str, tuple[list[str], list[list[Any]]]] = {}
        sel_rows: list[list[Any]] = []
        every_task = simulate and tasks == "all"
        parts: list[Any] = []  # kbplanner.scale.task_runs.ScenarioPart of each scenario to simulate
        loaded: dict[str | None, tuple[Any, Any]] = {}  # scenario -> (project, world tables)
        for name in names:
            sdir = stage / "scenarios" / name
            if ahead is not None:
                project = ahead.projects[name]  # loaded before the tasks began
            else:
                with clock.stage("load", name), growing():
                    project = Project.load(project_dir, scenario=name)
            if ahead is None or name not in ahead.checks:
                with clock.stage("validation", name):
                    val = project.validate()
                    val.write(sdir / "validation.ttl")
                    atomic_write_text(sdir / "validation.txt", val.text())
                conforms, violations = val.conforms, len(val.violations)
            with clock.stage("robot selection", name):
                sel = project.select_robots()
                atomic_write_text(sdir / "robots.txt", sel.text())
            with clock.stage("world", name):
                from kbplanner.world.build import world_of
                from kbplanner.world.exports import export_world
                from kbplanner.world.tables import world_tables

                tables = world_tables(project)  # read once: this world, then every task's (--tasks all)
                world = world_of(project, tables=tables)
                exported = export_world(world, sdir / "world")
            loaded[name] = (project, tables)  # again for the report's playback
            set_aside()  # the scenario's tables and validation live to the report
            if ahead is not None and name in ahead.checks:  # validated by a task process meanwhile
                verdict = ahead.verdict(name)
                clock.add("validation", name, verdict.seconds)
                conforms, violations = verdict.conforms, verdict.violations
            summary = ScenarioSummary(
                name=name, conforms=conforms, violations=violations,
                fit_robots=[a.robot.label for a in sel.fit],
                world_static=len(world.static),
                world_task_elements=len(world.task_elements),
                map_cells=exported.map.grid.shape if exported.map is not None else (0, 0),
            )
            result.scenarios.append(summary)
            if ahead is not None:
                if conforms and sel.fit:
                    ahead.run.confirm(name, project, tables)  # its tasks' outcomes are kept
                    sel_rows = [list(r) for r in sel.rows()]
                else:  # not simulated: what its tasks wrote ahead is removed
                    ahead.run.drop(name)
                    for written in (sdir / "tasks", sdir / "simulation"):
                        if written.is_dir():
                            shutil.rmtree(written)
            elif every_task and conforms and sel.fit:
                from kbplanner.scale.task_runs import ScenarioPart

                parts.append(ScenarioPart(name, sdir / "tasks", sdir / "simulation", project, tables))
                sel_rows = [list(r) for r in sel.rows()]
            elif simulate and conforms and sel.fit:
                with clock.stage("simulation", name):
                    srun = simulate_scenario(project_dir, name, seed=seed, out_dir=sdir / "simulation",
                                             progress=say, project=project, max_elements=max_elements)
                summary.simulated, summary.installed, summary.elements = True, srun.installed, srun.elements
                sims[name] = srun
                sel_rows = [list(r) for r in sel.rows()]
        if ahead is not None and ahead.run.parts:
            result.simulation = ahead.run.finish()
            alone = [r.scenario for r in result.simulation.results]  # one scenario: named, as before
            clock.add("simulation (every task)", alone[0] if len(alone) == 1 else None,
                      result.simulation.wall_s)
        elif parts:
            result.simulation = _simulate_every_task(project_dir, parts, clock, say, workers=workers,
                                                     seed=seed, max_elements=max_elements, pool=None,
                                                     previous=out_dir)
        if result.simulation is not None:
            for truns in result.simulation.results:
                summary = next(s for s in result.scenarios if s.name == truns.scenario)
                summary.simulated, summary.installed, summary.elements = True, truns.installed, truns.elements
                summary.tasks = len(truns.tasks)
                summary.sim_time_s = truns.sim_time_s
                if truns.main is not None:
                    sims[summary.name] = truns.main
                from kbplanner.scale.task_runs import TASK_COLUMNS

                task_tables[summary.name] = (list(TASK_COLUMNS), truns.rows())
        if ahead is not None:
            ahead.run.release()  # the spawned processes end (and free their memory) beside the report
        if sims:
            set_aside()  # what the tasks keep in this process
            with clock.stage("comparison and report"):
                result.comparison = write_outputs(project_dir, [sims[n] for n in names if n in sims], stage,
                                                  requirements=req, selection=sel_rows, project=bare,
                                                  task_tables=task_tables or None, loaded=loaded)
        later.close()  # the worker processes have ended here
        result.timings = clock.timings
        result.seconds = round(time.perf_counter() - t_start, 3)
        write_json(stage / "run_timings.json", {  # wall clock: not deterministic, unlike metrics.json
            "stages": [asdict(t) for t in clock.timings],
            "total_seconds": result.seconds,
            "peak_rss_mb": round(peak_rss_mb(), 1),
            **({"simulation": result.simulation.timing()} if result.simulation is not None else {}),
        })
        write_json(stage / "manifest.json", _manifest(bare, names, seed))
    return result


@dataclass
class _Ahead:
    """The tasks of every scenario begun before the scenarios are validated (``--tasks all``, several
    workers): the loaded scenarios, the stage in steps and each scenario's validation, handed to the
    spawned processes ahead of the tasks."""

    projects: dict[str, Project]
    run: SimulationRun
    checks: dict[str, Future[Verdict]] = field(default_factory=dict)

    def verdict(self, name: str) -> Verdict:
        """The scenario's validation, once done; meanwhile this process takes tasks (they ran ahead of
        the decision anyway): it starts its first task as soon as its own stages are done, and the
        spawned process, which waited less for its first, validates."""
        check = self.checks[name]
        while not check.done() and self.run.dispatch.run_one():
            pass
        return check.result()


def _tasks_ahead(project_dir: Path, stage: Path, names: list[str], clock: _Clock, later: contextlib.ExitStack,
                 *, workers: int, seed: int | None, max_elements: int | None, previous: Path) -> _Ahead:
    """Load every scenario and start the spawned processes on each scenario's validation (A4-A5: they
    are ready for their first task sooner than this process) and then on the tasks (B1-B5 of each
    robotized task), while this process goes on with the requirements, robot selection and world of
    each scenario, and takes tasks until each validation is done; a scenario that does not conform or
    has no fit robot is then dropped (its tasks skipped, their outcomes and folders removed), as if never
    simulated. What is written is the same as when the tasks start after the worlds (the validation
    files too, by whichever process); only the wall time differs."""
    from kbplanner.scale.task_jobs import validate_job
    from kbplanner.scale.task_runs import ScenarioPart, SimulationRun, TaskPool

    pool = later.enter_context(TaskPool(project_dir, names, workers, load=False))  # imports meanwhile
    projects: dict[str, Project] = {}
    for name in names:
        with clock.stage("load", name), growing():  # it lives to the report: set aside
            projects[name] = Project.load(project_dir, scenario=name)
            projects[name].keep_graphs()  # a cold load: the spawned processes unpickle its graphs
    pool.load()  # from the project cache now
    checks: dict[str, Future[Verdict]] = {}
    for name in names:  # ahead of every task: the spawned processes' queue is first come, first served
        check = pool.submit(validate_job, project_dir, name, stage / "scenarios" / name)
        if check is not None:
            checks[name] = check
    parts = [ScenarioPart(n, stage / "scenarios" / n / "tasks", stage / "scenarios" / n / "simulation",
                          projects[n], None) for n in names]
    before: dict[str | None, Path] | None = \
        {n: previous / "scenarios" / n / "tasks" for n in names} if previous.is_dir() else None
    clock.say("simulation (every task) ...")
    run = SimulationRun(project_dir, parts, seed=seed, workers=workers, keyframes=True, progress=clock.say,
                        max_elements=max_elements, pool=pool, previous=before, unconfirmed=names)
    later.enter_context(run.dispatch.stack)  # an error before the end stops the spawned processes
    # the spawned processes take their first task after the validations: the first tasks (the main task
    # first, which draws key frames) go to whichever process is free first, this one or a spawned one
    return _Ahead(projects, run.begin(here=False, gate=list(checks.values())), checks)


def _simulate_every_task(project_dir: Path, parts: list[ScenarioPart], clock: _Clock, say: Say, *,
                         workers: int, seed: int | None, max_elements: int | None,
                         pool: TaskPool | None, previous: Path | None = None) -> SimulationStage:
    """Every robotized task of every scenario in ``parts`` (B1-B5), on ``workers`` processes shared by the
    scenarios (a long task of one runs beside the short ones of another). With one process, or one
    scenario, a stage per scenario as before; else one stage for all, and in ``run_timings.json``
    (``simulation``) each scenario's simulated seconds, its wall seconds (from the stage's start to its
    last task's end) and real-time factor, and each task's wall and CPU seconds. ``previous`` (the run
    folder this run replaces, if any) gives a start order when the project cache has no task costs."""
    from kbplanner.scale.task_runs import SimulationStage, simulate_scenarios

    before = {p.scenario: previous / "scenarios" / (p.scenario or "") / "tasks" for p in parts} \
        if previous is not None and previous.is_dir() else None

    def run(ps: list[ScenarioPart]) -> SimulationStage:
        return simulate_scenarios(project_dir, ps, seed=seed, workers=workers, keyframes=True, progress=say,
                                  max_elements=max_elements, pool=pool, previous=before)

    if workers == 1 or len(parts) == 1:
        stages = []
        for part in parts:
            with clock.stage("simulation (every task)", part.scenario):
                stages.append(run([part]))
        results = [r for s in stages for r in s.results]
        return SimulationStage(results, sum(s.wall_s for s in stages), workers)
    with clock.stage("simulation (every task)", None):
        shared = run(parts)
    return shared


def _manifest(project: Project, scenarios: list[str], seed: int | None) -> dict[str, Any]:
    m = project.manifest
    return {
        "project": project.name,
        "project_dir": str(project.path),
        "scenarios": scenarios,
        "seed": m.seed if seed is None else seed,
        "inputs": input_hashes(_project_files(project), project.path),
        "versions": versions(),
        "command": "kbplanner run",
    }
