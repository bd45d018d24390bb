"""Whole-building runs, the processes: which job starts when, on which process (B1-B5 of many tasks).

:class:`TaskPool` is the ``workers - 1`` spawned processes, started ahead and warmed with the
scenarios they will simulate; :func:`dispatch` hands the jobs out, the command's own process taking
the next job whenever it is free, as does each spawned process. What is written never depends on who
ran what or when (results are kept by job index); only the wall time does, so the order matters: the
longest jobs first leave fewer idle processes at the end. :func:`start_order` puts first the jobs
that took most CPU in the last run of the same project (``task_costs.json`` in the project cache,
:func:`read_costs` / :func:`write_costs`), else most wall time in the run folder being replaced
(:func:`previous_costs`), else the ``[simulation]`` task (it draws key frames) and then the jobs with
most elements.
"""

from __future__ import annotations

import atexit
import contextlib
import dataclasses
import functools
import json
import logging
import multiprocessing
import os
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from concurrent import futures
from concurrent.futures import Future, ProcessPoolExecutor
from pathlib import Path
from typing import Any

from kbplanner.scale.task_jobs import Outcome, _Job, ready, run_job, warm

log = logging.getLogger(__name__)

COSTS_FILE = "task_costs.json"


def _started() -> None:
    """Nothing: submitted once per worker process so that each starts (and warms up) at once."""


def _quick_exit() -> None:
    """A spawned process's last step (at its exit, after the pool's own clean-up: every result sent):
    end without the interpreter's teardown, which frees the loaded scenarios object by object."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            stream.flush()
    os._exit(0)


def _begin(project_dir: Path, names: Sequence[str | None], load: bool) -> None:
    """A spawned process's start: its quick exit registered, then :func:`warm` (``load``) or
    :func:`ready` (the imports and the named queries, while the caller loads the project)."""
    atexit.register(_quick_exit)
    if load:
        warm(project_dir, names)
    else:
        ready()


class TaskPool:
    """The ``workers - 1`` spawned processes of a simulation stage, started ahead of it.

    Each process loads the scenarios (one name or several) as soon as it starts, so a caller that has
    other work first (the pipeline: validation, the world) hands over warm processes; with ``load=False``
    it imports the modules a task uses and parses the named queries only, and loads the scenarios when
    told (:meth:`load`: the caller loads them first, so that they come from the project cache). Processes are
    spawned: a fork of a process that has PyBullet, OMPL and thread pools loaded is not safe, and the
    start-up (imports, the scenario from the project cache) overlaps the caller's own work.
    Use as a context manager; leaving it on an error stops the processes without waiting.
    """

    def __init__(self, project_dir: Path, scenarios: str | Sequence[str | None] | None, workers: int, *,
                 load: bool = True) -> None:
        names = tuple(scenarios) if isinstance(scenarios, (list, tuple)) else (scenarios,)
        self.project_dir, self.names = project_dir, names
        self.children = max(0, workers - 1)
        self.executor: ProcessPoolExecutor | None = None
        self.ending: threading.Thread | None = None  # :meth:`release`: the processes are ending
        if self.children:
            self.executor = ProcessPoolExecutor(
                max_workers=self.children, mp_context=multiprocessing.get_context("spawn"),
                initializer=functools.partial(_begin, project_dir, names, load))
            for _ in range(self.children):  # the pool starts a process per submission while none is idle
                self.executor.submit(_started)

    def load(self) -> None:
        """Have each process load the scenarios now (a pool started with ``load=False`` before the
        caller had loaded them, i.e. before they were in the project cache, imports only)."""
        if self.executor is not None:
            for _ in range(self.children):  # one per process: each idle one takes the next
                self.executor.submit(warm, self.project_dir, self.names)

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future[Any] | None:
        """Run ``fn(*args)`` on the next free process (after what was submitted before it); None
        without spawned processes."""
        return None if self.executor is None else self.executor.submit(fn, *args)

    def release(self) -> None:
        """No more jobs: the processes are told to end, and end (each freeing what it loaded: seconds
        on a whole building) while the caller goes on (the pipeline: its report); leaving the pool
        then waits for them. Nothing a job wrote depends on it: every job has returned."""
        if self.executor is not None and self.ending is None:
            self.ending = threading.Thread(target=self.executor.shutdown, name="task-pool-end", daemon=True)
            self.ending.start()

    def __enter__(self) -> TaskPool:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *_exc: object) -> None:
        if self.executor is None:
            return
        if exc_type is not None:  # an error: do not wait for a process still loading the project
            procs = list((getattr(self.executor, "_processes", None) or {}).values())
            for proc in procs:
                proc.terminate()
            for proc in procs:  # ended before the caller removes the folder it may be writing into
                proc.join(timeout=10.0)
            if self.ending is None:  # else released: its thread shuts the executor down
                self.executor.shutdown(wait=False, cancel_futures=True)
            return
        if self.ending is not None:  # released: the processes are ending
            self.ending.join()
            return
        self.executor.shutdown(wait=True, cancel_futures=True)


Tell = Callable[[_Job, Outcome], None]


class Dispatch:
    """Jobs handed out to this process and ``workers - 1`` spawned ones, in ``order``.

    :meth:`begin` starts the spawned processes on the jobs (one thread here waits for each), so a
    caller can do other work meanwhile (the pipeline validates the scenarios and builds their worlds);
    :meth:`run_here` makes this process take the next job whenever it is free too, until none is left;
    :meth:`wait` returns the outcomes by job index, so what is written does not depend on who ran what
    or when. Each outcome gets its start and end (seconds from ``t0``, as seen here: a spawned process's
    include handing the job over) and the process that ran it (0: this one).

    Jobs of a scenario in ``unconfirmed`` run ahead of the decision whether the scenario is simulated
    at all (its validation and robot selection): :meth:`confirm` keeps them, :meth:`drop` discards
    them (the jobs not started are skipped, the outcomes of the others forgotten; :meth:`settle` waits
    for its running ones, so that their folders can be removed). An unconfirmed scenario's error is
    held until it is confirmed (then raised) or dropped (then forgotten), and stops only that
    scenario's jobs; the first error of a confirmed scenario (in job order) stops every job and is
    raised by :meth:`wait` once every started job has ended.
    """

    def __init__(self, jobs: Sequence[_Job], order: Sequence[int], workers: int, tell: Tell,
                 pool: TaskPool | None = None, t0: float | None = None,
                 unconfirmed: Sequence[str | None] = ()) -> None:
        self.jobs, self.workers, self.tell, self.pool = jobs, workers, tell, pool
        self.start = time.perf_counter() if t0 is None else t0
        self.pending = deque(order)
        self.lock = threading.Condition()
        self.done: dict[int, Outcome] = {}
        self.failed: dict[int, BaseException] = {}
        self.held: dict[int, BaseException] = {}
        self.unconfirmed = set(unconfirmed)
        self.dropped: set[str | None] = set()
        self.running: set[int] = set()
        self.threads: list[threading.Thread] = []
        self.stack = contextlib.ExitStack()

    def _take(self) -> int | None:
        with self.lock:
            while self.pending and not self.failed:
                i = self.pending.popleft()
                scenario = self.jobs[i].scenario
                if scenario in self.dropped or any(self.jobs[k].scenario == scenario for k in self.held):
                    continue
                self.running.add(i)
                return i
            return None

    def _record(self, i: int, outcome: Outcome | None, error: BaseException | None, began: float,
                who: int) -> None:
        ended = time.perf_counter()
        with self.lock:
            self.running.discard(i)
            scenario = self.jobs[i].scenario
            if scenario in self.dropped:
                pass
            elif error is not None:
                (self.held if scenario in self.unconfirmed else self.failed)[i] = error
            elif outcome is not None:
                self.done[i] = dataclasses.replace(outcome, start_s=round(began - self.start, 3),
                                                   end_s=round(ended - self.start, 3), process=who)
                self.tell(self.jobs[i], self.done[i])
            self.lock.notify_all()

    def _run(self, i: int, who: int, executor: ProcessPoolExecutor | None) -> None:
        began = time.perf_counter()
        try:
            job = self.jobs[i]
            outcome = run_job(job) if executor is None else executor.submit(run_job, job).result()
        except BaseException as exc:  # raised again by wait(), in the calling thread
            self._record(i, None, exc, began, who)
        else:
            self._record(i, outcome, None, began, who)

    def _feed(self, executor: ProcessPoolExecutor, who: int, gate: Sequence[Future[Any]]) -> None:
        if gate:  # the spawned processes' earlier work: no job is handed over before it is done
            futures.wait(gate)
        while (i := self._take()) is not None:
            self._run(i, who, executor)

    def begin(self, here: bool = True, gate: Sequence[Future[Any]] = ()) -> Dispatch:
        """Start the spawned processes on the jobs (``here``: this process will take jobs from the start
        too, so one spawned process fewer is needed for a few jobs). With ``gate`` (what the spawned
        processes were given before, e.g. the pipeline's validations), each takes its first job once
        those are done, not before: the first jobs go to whichever process is free first."""
        if self.workers <= 1 or len(self.jobs) <= (1 if here else 0):
            return self
        scenarios = list(dict.fromkeys(j.scenario for j in self.jobs))
        tp = self.stack.enter_context(
            TaskPool(self.jobs[0].project_dir, scenarios, min(self.workers, len(self.jobs)))
            if self.pool is None else contextlib.nullcontext(self.pool))
        executor = tp.executor
        if executor is None:
            return self
        children = min(tp.children, len(self.jobs) - (1 if here else 0))
        self.threads = [threading.Thread(target=self._feed, args=(executor, k + 1, gate), daemon=True)
                        for k in range(children)]
        for t in self.threads:
            t.start()
        return self

    def confirm(self, scenario: str | None) -> None:
        """The scenario is simulated: its jobs' outcomes are kept and a held error is raised."""
        with self.lock:
            self.unconfirmed.discard(scenario)
            for i in [i for i in self.held if self.jobs[i].scenario == scenario]:
                self.failed[i] = self.held.pop(i)

    def drop(self, scenario: str | None) -> None:
        """The scenario is not simulated: its jobs are skipped and their outcomes and errors forgotten."""
        with self.lock:
            self.unconfirmed.discard(scenario)
            self.dropped.add(scenario)
            for table in (self.done, self.held):
                for i in [i for i in table if self.jobs[i].scenario == scenario]:
                    del table[i]

    def settle(self, scenario: str | None) -> None:
        """Wait until no job of the scenario is running."""
        with self.lock:
            while any(self.jobs[i].scenario == scenario for i in self.running):
                self.lock.wait()

    def run_one(self) -> bool:
        """This process takes the next job, if any (False: none was left)."""
        i = self._take()
        if i is None:
            return False
        self._run(i, 0, None)
        return True

    def run_here(self) -> None:
        """This process takes the next job whenever it is free, until none is left."""
        while (i := self._take()) is not None:
            self._run(i, 0, None)

    def wait(self) -> dict[int, Outcome]:
        """Every started job ended: the outcomes by job index; the first error raised (in job order)."""
        for t in self.threads:
            t.join()
        self.stack.close()
        if self.failed:
            raise self.failed[min(self.failed)]
        return self.done


def dispatch(jobs: Sequence[_Job], order: Sequence[int], workers: int, tell: Tell,
             pool: TaskPool | None = None, t0: float | None = None) -> dict[int, Outcome]:
    """Run ``jobs`` (taken in ``order``) on ``workers`` processes: this one and ``workers - 1`` spawned
    (:class:`Dispatch`, every scenario confirmed). The first error (in job order) is raised once every
    started job has ended.
    """
    run = Dispatch(jobs, order, workers, tell, pool, t0)
    with run.stack:  # an interruption here stops the spawned processes without waiting
        run.begin().run_here()
        return run.wait()


def _longest_first(jobs: Sequence[_Job], sizes: Sequence[float]) -> list[int]:
    """Job indices in the order to start them on several processes: the main task first (it draws key
    frames), then by elements, most first, then in schedule order; fewer idle processes at the end."""
    return sorted(range(len(jobs)), key=lambda i: (not jobs[i].main, -sizes[i], i))


def cost_key(job: _Job) -> str:
    """A job's entry in ``task_costs.json``: scenario, task and the element limit."""
    limit = "all" if job.max_elements is None else str(job.max_elements)
    return f"{job.scenario or ''}|{job.task_id}|{limit}"


def start_order(jobs: Sequence[_Job], sizes: Sequence[float], costs: Mapping[str, float]) -> list[int]:
    """The order to start the jobs in: by the CPU seconds each took last time (most first) when every
    job has one, else :func:`_longest_first` (the main tasks, then most elements)."""
    known = [costs.get(cost_key(j)) for j in jobs]
    if jobs and all(c is not None for c in known):
        return sorted(range(len(jobs)), key=lambda i: (-(known[i] or 0.0), i))
    return _longest_first(jobs, sizes)


def previous_costs(jobs: Sequence[_Job], sizes: Sequence[float],
                   previous: Mapping[str | None, Path]) -> dict[str, float]:
    """Each job's wall seconds in the run folder being replaced (``previous``: a scenario's tasks
    directory there), when that run simulated the same number of elements of the task; a first
    estimate for a project without ``task_costs.json`` (e.g. a fresh project cache). Only the start
    order depends on it: anything unreadable is left out."""
    out: dict[str, float] = {}
    read: dict[str | None, tuple[dict[str, Any], dict[str, Any]]] = {}
    for job, size in zip(jobs, sizes, strict=True):
        where = previous.get(job.scenario)
        if where is None:
            continue
        if job.scenario not in read:
            try:
                timing = json.loads((where / "tasks_timings.json").read_text(encoding="utf-8"))
                walls = timing.get("tasks", {})
                figures = json.loads((where / "tasks.json").read_text(encoding="utf-8")).get("tasks", [])
                read[job.scenario] = (walls, {str(t.get("task_id")): t for t in figures})
            except (OSError, ValueError, AttributeError):
                read[job.scenario] = ({}, {})
        walls, figures = read[job.scenario]
        wall, fig = walls.get(job.task_id), figures.get(job.task_id)
        if isinstance(wall, (int, float)) and isinstance(fig, dict) and fig.get("elements") == size:
            out[cost_key(job)] = float(wall)
    return out


def _costs_path(project_dir: Path) -> Path | None:
    from kbplanner.model.project_cache import enabled
    from kbplanner.model.project_data import cache_root

    return cache_root(project_dir) / COSTS_FILE if enabled() else None


def read_costs(project_dir: Path) -> dict[str, float]:
    """The CPU seconds of each job in the last run of this project (empty when none was recorded, the
    cache is off or the file cannot be read: only the start order depends on it)."""
    path = _costs_path(project_dir)
    if path is None or not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        entry = data.get(str(project_dir.resolve()), {}) if isinstance(data, dict) else {}
        return {str(k): float(v) for k, v in entry.items()}
    except (OSError, ValueError, TypeError, AttributeError) as exc:
        log.info("task costs not read from %s: %s", path, exc)
        return {}


def write_costs(project_dir: Path, measured: Mapping[str, float]) -> None:
    """Record each job's CPU seconds for the next run's start order (best effort: never an error)."""
    path = _costs_path(project_dir)
    if path is None or not measured:
        return
    from kbplanner.core.outputs import atomic_write_text

    try:
        data = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}
    except (OSError, ValueError):  # unreadable: written anew
        data = {}
    try:
        if not isinstance(data, dict):
            data = {}
        entry = dict(data.get(str(project_dir.resolve()), {}))
        entry.update({k: round(v, 2) for k, v in measured.items()})
        data[str(project_dir.resolve())] = dict(sorted(entry.items()))
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps(data, indent=1, sort_keys=True) + "\n")
    except (OSError, ValueError, TypeError, AttributeError) as exc:
        log.info("task costs not written to %s: %s", path, exc)
