"""B5 set-up, built early in a second process: what the step reads from the kept folders that depends on
the world and its maps only, made while the first process runs B4 (issue 14, a user's first run).

A first ``kbplanner simulate`` of a project builds what later runs read from ``PROJECT/.kbplanner-cache``:
the configuration spaces, the grid cell paths and corridor routes, the reactive workers' walking map and
legs, the static bodies' triangles. Of these only the last three are known before B4 ends: every other
one is searched on a window round B4's base poses, for the footprint of the element as the step grasped
it, on the map with the elements as the step installed them (a key that differs in one float or one
cell is another space). :func:`start` forks a process that makes, with the code the step uses:

- the workers' walking map (:func:`kbplanner.simulation.walk_store.walk_cells_kept`: a distance
  transform of the ground map, some 0.07 s) and every worker's stop-to-stop legs (those a worker walks
  from where they stand at a stop, the first of each worker from the very point: the case study's
  Dijkstra searches over the 520 x 420 cell walking map, about 0.17 s of a first run's step), with the
  router the crowd uses (:class:`kbplanner.simulation.workers._Router`, the same map, clearance and code),
  kept by :mod:`kbplanner.simulation.walk_store`;
- the static bodies' triangles (:func:`kbplanner.simulation.sim_world.static_chunks`: the mesh files
  read and merged, some 0.1 s), kept by :mod:`kbplanner.simulation.static_store`.

The step reads them at its start as it reads an earlier run's.

- Outputs: the same by construction. What is kept is read back as the very arrays the step makes
  (``tests/test_walk_store.py``, ``tests/test_static_store.py``, ``tests/test_early_builds.py``); what
  the early process has not kept yet when the step starts is made by the step as before.
- Files: written atomically (:func:`kbplanner.core.outputs.atomic_write_bytes`): a process killed
  half-way leaves the file it had or none. Nothing is started without a kept folder (``kbplanner
  --no-cache``, ``KBPLANNER_NO_CACHE=1``) or ``fork`` (not Linux); no walking legs for scripted workers.
- A run that kept them before: the early process reads them and ends (a few hundredths of a second on
  the other core).
- B4 ahead of B5 (:mod:`kbplanner.planning.refine_ahead`, a first run: B4 in a second process): no
  process is started; the command makes them itself (:func:`build`) while B5's first element waits for
  B4's first (forked beside the step, they came too late for it: the step searched them itself).
- :meth:`EarlyBuilds.finish` waits for the process: the command calls it once the step has run (its
  CPU is then counted with the command's); after an error the process is left to end by itself.

Example:
    >>> early = start(project, world, grid, cspace_store.folder_for(project.cache_entry))  # doctest: +SKIP
    >>> ...  # B4, then executor.simulate reads the legs
    >>> early.finish()  # doctest: +SKIP
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from kbplanner.model.project_data import ProjectData
    from kbplanner.simulation.workers import WorkerSpec, _Router
    from kbplanner.world.occupancy import OccupancyGrid
    from kbplanner.world.world_types import World

log = logging.getLogger(__name__)


@dataclass
class EarlyBuilds:
    """The early process (``pid`` None: none was started)."""

    pid: int | None = None
    status: int | None = None  # its exit status once finished

    def finish(self) -> int | None:
        """Wait for the process (at once when it has ended); its exit status (None: none started)."""
        if self.pid is not None and self.status is None:
            try:
                self.status = os.waitstatus_to_exitcode(os.waitpid(self.pid, 0)[1])
            except ChildProcessError:  # reaped by someone else (SIGCHLD ignored)
                self.status = 0
            if self.status != 0:
                log.info("the early builds' process %d ended with status %s (the step searched what it "
                         "did not keep)", self.pid, self.status)
        return self.status


def possible(folder: Path | None) -> bool:
    """Whether early builds can be made: a kept folder, the cache on, ``fork`` (Linux)."""
    return folder is not None and os.environ.get("KBPLANNER_NO_CACHE", "").strip() in ("", "0") \
        and sys.platform == "linux" and hasattr(os, "fork")


def start(project: ProjectData, world: World, grid: OccupancyGrid, folder: Path | None,
          *, reactive_workers: bool = True) -> EarlyBuilds:
    """Fork the process that keeps the workers' walking map and legs (``reactive_workers``) and the static
    bodies' triangles in ``folder``'s kept folders (the configuration spaces' folder,
    :func:`kbplanner.world.cspace_store.folder_for`); returns at once.

    ``grid``: the robot's storey map (the workers walk on :func:`~kbplanner.simulation.floors.walk_grid`
    of it). Call before any thread is started (a progress bar's): the fork copies this process."""
    if not possible(folder):
        return EarlyBuilds()
    return forked(lambda: build(project, world, grid, folder, reactive_workers=reactive_workers))


def build(project: ProjectData, world: World, grid: OccupancyGrid, folder: Path | None,
          *, reactive_workers: bool = True) -> None:
    """What :func:`start`'s process keeps, made and kept in this process (nothing without a kept folder or
    with the cache off): ``kbplanner simulate`` calls it while B4 runs ahead of B5 in a second process
    (:mod:`kbplanner.planning.refine_ahead`), before B5's first element, which waits for B4's first."""
    if not possible(folder):
        return
    from kbplanner.simulation.floors import walk_grid
    from kbplanner.simulation.sim_world import static_chunks
    from kbplanner.simulation.workers import load_workers
    from kbplanner.world import cspace_store

    if reactive_workers:
        keep_walking_legs(load_workers(project.model), walk_grid(world, grid), folder)
    with cspace_store.kept_in(folder):
        static_chunks(world)  # the static bodies' triangles (read, or made and kept)


def forked(work: Callable[[], object]) -> EarlyBuilds:
    """``work()`` in a forked copy of this process, which then ends (status 0, or 1 when ``work`` raised)
    without this process's exit handlers; returns at once (no process where none can be forked)."""
    try:
        pid = os.fork()
    except OSError as exc:
        log.info("no early builds (%s): the step searches the walking legs", exc)
        return EarlyBuilds()
    if pid == 0:  # the early process
        code = 1
        try:
            logging.disable(logging.CRITICAL)  # the step says what a search has to say
            work()
            code = 0
        finally:
            os._exit(code)
    return EarlyBuilds(pid)


def keep_walking_legs(specs: Sequence[WorkerSpec], ground: OccupancyGrid | None, folder: Path | None) -> int:
    """Route the workers' stop-to-stop legs on their walking map ``ground`` and keep them in ``folder``'s
    kept folders (the legs kept before are read, not searched); how many legs were searched."""
    from kbplanner.simulation import walk_store
    from kbplanner.world import cspace_store

    with cspace_store.kept_in(folder):
        router = walking_router(ground)
        walk_store.read_into(router)
        searched = route_stops(router, specs)
        walk_store.write_from(router)
    return searched


def walking_router(ground: OccupancyGrid | None) -> _Router:
    """The reactive workers' router on their walking map (as :class:`kbplanner.simulation.crowd.Crowd`
    makes it)."""
    from kbplanner.simulation import walk_store
    from kbplanner.simulation.separation import WORKER_RADIUS_M
    from kbplanner.simulation.workers import _Router

    return _Router(ground, WORKER_RADIUS_M,
                   walk_store.walk_cells_kept(ground, WORKER_RADIUS_M) if ground is not None else None)


def route_stops(router: _Router, specs: Sequence[WorkerSpec]) -> int:
    """Route each worker's legs from every stop to the next (the route's order, the last back to the
    first) into ``router``'s memo; how many legs were not known before."""
    before = len(router._memo)
    for spec in specs:
        stops = spec.stops
        if len(stops) < 2:
            continue
        for k, here in enumerate(stops):
            there = stops[(k + 1) % len(stops)]
            router.path((here.x, here.y), (there.x, there.y))
    return len(router._memo) - before
