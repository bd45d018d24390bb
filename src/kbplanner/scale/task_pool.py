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

import contextlib
import dataclasses
import json
import logging
import multiprocessing
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from kbplanner.scale.task_jobs import Outcome, _Job, run_job, warm

log = logging.getLogger(__name__)

COSTS_FILE = "task_costs.json"


def _started() -> None:
    """Nothing: submitted once per worker process so that each starts (and warms up) at once."""


class TaskPool:
    """The ``workers - 1`` spawned processes of a simulation stage, started ahead of it.

    Each process loads the scenarios (one name or several) as soon as it starts, so a caller that has
    other work first (the pipeline: validation, the world) hands over warm processes. Processes are
    spawned: a fork of a process that has PyBullet, OMPL and thread pools loaded is not safe, and the
    start-up (imports, the scenario from the project cache) overlaps the caller's own work.
    Use as a context manager; leaving it on an error stops the processes without waiting.
    """

    def __init__(self, project_dir: Path, scenarios: str | Sequence[str | None] | None, workers: int) -> None:
        names = tuple(scenarios) if isinstance(scenarios, (list, tuple)) else (scenarios,)
        self.children = max(0, workers - 1)
        self.executor: ProcessPoolExecutor | None = None
        if self.children:
            self.executor = ProcessPoolExecutor(max_workers=self.children,
                                                mp_context=multiprocessing.get_context("spawn"),
                                                initializer=warm, initargs=(project_dir, names))
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


Tell = Callable[[_Job, Outcome], None]


def dispatch(jobs: Sequence[_Job], order: Sequence[int], workers: int, tell: Tell,
             pool: TaskPool | None = None, t0: float | None = None) -> dict[int, Outcome]:
    """Run ``jobs`` (taken in ``order``) on ``workers`` processes: this one and ``workers - 1`` spawned.

    This process takes the next job whenever it is free, and so does each spawned process (one thread
    here waits for each); results are kept by job index, so what is written does not depend on who
    ran what or when. Each outcome gets its start and end (seconds from ``t0``, as seen here: a spawned
    process's include handing the job over) and the process that ran it. The first error (in job
    order) is raised once every started job has ended.
    """
    start = time.perf_counter() if t0 is None else t0
    pending = deque(order)
    lock = threading.Lock()
    done: dict[int, Outcome] = {}
    failed: dict[int, BaseException] = {}

    def take() -> int | None:
        with lock:
            return pending.popleft() if pending and not failed else None

    def record(i: int, outcome: Outcome | None, error: BaseException | None, began: float, who: int) -> None:
        ended = time.perf_counter()
        with lock:
            if error is not None:
                failed[i] = error
            elif outcome is not None:
                done[i] = dataclasses.replace(outcome, start_s=round(began - start, 3),
                                              end_s=round(ended - start, 3), process=who)
                tell(jobs[i], done[i])

    def feed(executor: ProcessPoolExecutor | None, who: int) -> None:
        assert executor is not None  # a thread per spawned process
        while (i := take()) is not None:
            began = time.perf_counter()
            try:
                record(i, executor.submit(run_job, jobs[i]).result(), None, began, who)
            except BaseException as exc:  # raised again in the calling thread
                record(i, None, exc, began, who)

    if workers <= 1 or len(jobs) <= 1:
        for j in order:
            began = time.perf_counter()
            record(j, run_job(jobs[j]), None, began, 0)
        return done
    scenarios = list(dict.fromkeys(j.scenario for j in jobs))
    with (TaskPool(jobs[0].project_dir, scenarios, min(workers, len(jobs))) if pool is None
          else contextlib.nullcontext(pool)) as tp:
        children = min(tp.children, len(jobs) - 1)
        threads = [threading.Thread(target=feed, args=(tp.executor, k + 1), daemon=True)
                   for k in range(children)]
        for t in threads:
            t.start()
        while (i := take()) is not None:
            began = time.perf_counter()
            try:
                record(i, run_job(jobs[i]), None, began, 0)
            except BaseException as exc:  # raised below, once the others ended
                record(i, None, exc, began, 0)
        for t in threads:
            t.join()
    if failed:
        raise failed[min(failed)]
    return done


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
