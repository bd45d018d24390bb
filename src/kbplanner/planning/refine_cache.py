"""B4 kept (arm and base poses per skill): a refined plan stored by a content hash of everything B4 reads.

B4 (:func:`kbplanner.planning.manipulation.refine_plan`) is deterministic: the same plan, world, grid,
seed and settings, with the same code, robot files and package versions, give the same refined plan.
:func:`refine_kept` takes what ``refine_plan`` takes and a folder (the loaded project's cache entry,
:attr:`kbplanner.model.project_data.ProjectData.cache_entry`; ``None``: nothing kept) and returns the
plan ``refine_plan`` returns: read from ``FOLDER/refined/KEY.json`` when it is there, else refined and
written there. So a second command on the same project, scenario, task and seed (``kbplanner plan``
then ``kbplanner simulate``; ``simulate`` again with ``--monitoring off``, without key frames, into
another folder) skips B4.

- Key: SHA-256 of the format, the versions of Python and of the packages a run depends on (PyBullet's
  numeric IK among them), the source of every kbplanner module, the robot files (``sim/robots/``), the
  world (its ``repr``: every element, pose, box, mesh path, storey, site object and worker), the plan
  given to B4 (its JSON), the occupancy grid (origin, resolution, band, cells), the seed, the settings
  and ``reorder``. Any change makes another key.
- Value: the refined plan's JSON (:meth:`Plan.to_json`); :meth:`Plan.from_json` reads it back (JSON keeps
  every float exactly), and the runs of both are byte-identical (``tests/test_refine_cache.py``).
- Off: with the project cache (``kbplanner --no-cache``, ``KBPLANNER_NO_CACHE=1``: the project has no
  cache entry). A file that cannot be read is ignored and B4 runs; one that cannot be written is
  logged, never an error (written atomically: two commands at once each see a whole file or none).
  The newest ``KEEP`` plans of an entry are kept.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.core.outputs import atomic_write_text, versions
from kbplanner.core.resources import data_dir
from kbplanner.planning.plan_model import Plan
from kbplanner.planning.step_kinds import elements_in_order

if TYPE_CHECKING:  # B4's search and IK are imported only when B4 runs (a kept plan needs none of it)
    from kbplanner.planning.pose_search import RefineSettings
    from kbplanner.world.occupancy import OccupancyGrid
    from kbplanner.world.world_types import World

log = logging.getLogger(__name__)

FORMAT = "1"
SUBDIR = "refined"
KEEP = 16  # refined plans kept per project cache entry (the newest)
_code_memo: list[str] = []


def code_digest() -> str:
    """SHA-256 of the source of every kbplanner module and of the robot files (URDFs, robot table)."""
    if not _code_memo:
        root = Path(__file__).resolve().parents[1]
        h = hashlib.sha256()
        for path in sorted(root.rglob("*.py")):
            h.update(path.relative_to(root).as_posix().encode())
            h.update(path.read_bytes())
        robots = data_dir("sim") / "robots"
        for path in sorted(p for p in robots.rglob("*") if p.is_file()):
            h.update(path.relative_to(robots).as_posix().encode())
            h.update(path.read_bytes())
        _code_memo.append(h.hexdigest())
    return _code_memo[0]


def refine_key(plan: Plan, world: World, grid: OccupancyGrid | None, seed: int,
               settings: RefineSettings | None, reorder: bool) -> str:
    """The content hash a refined plan is kept under (see module docstring)."""
    h = hashlib.sha256()
    for part in (FORMAT, repr(sorted(versions().items())), code_digest(), repr(world), plan.to_json(),
                 repr(seed), _settings_text(settings), repr(reorder)):
        h.update(part.encode("utf-8"))
        h.update(b"\0")
    if grid is None:
        h.update(b"no grid")
    else:
        h.update(repr((grid.origin, grid.resolution, grid.band, grid.occupied.shape)).encode("utf-8"))
        h.update(grid.occupied.tobytes())
    return h.hexdigest()


def _settings_text(settings: RefineSettings | None) -> str:
    """The key's text of B4's settings: the defaults (``None``) as ``"defaults"`` (their values are in the
    source, so in :func:`code_digest`), others by their ``repr``; ``pose_search`` is imported only then."""
    if settings is None:
        return "defaults"
    from kbplanner.planning.pose_search import RefineSettings

    return "defaults" if settings == RefineSettings() else repr(settings)


def refine_kept(
    plan: Plan,
    world: World,
    *,
    seed: int,
    cache_dir: Path | None,
    grid: OccupancyGrid | None = None,
    settings: RefineSettings | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    reorder: bool = True,
    stop: Callable[[Plan], bool] | None = None,
) -> Plan:
    """:func:`~kbplanner.planning.manipulation.refine_plan`, kept in ``cache_dir`` (see module docstring).

    A kept plan is reported to ``progress`` as every element done. ``stop``: as ``refine_plan``'s (asked
    after each element of B4's first pass; a plan it stopped is not kept).
    """
    if cache_dir is None or not plan.robot_id:
        return refine_plan(plan, world, seed=seed, grid=grid, settings=settings, progress=progress,
                           reorder=reorder, stop=stop)
    if grid is None:
        from kbplanner.world.maps import storey_map

        grid = storey_map(world).grid
    path = kept_path(plan, world, seed=seed, cache_dir=cache_dir, grid=grid, settings=settings,
                     reorder=reorder)
    kept = _read(path)
    if kept is not None:
        log.info("B4: refined plan from the cache (%s)", path.name)
        order = elements_in_order(kept)
        if progress is not None:
            for n, iri in enumerate(order, start=1):
                progress(iri, n, len(order))
        return kept
    out = refine_plan(plan, world, seed=seed, grid=grid, settings=settings, progress=progress,
                      reorder=reorder, stop=stop)
    if not _stopped(out):
        _write(path, out)
    return out


def kept_path(plan: Plan, world: World, *, seed: int, cache_dir: Path, grid: OccupancyGrid,
              settings: RefineSettings | None = None, reorder: bool = True) -> Path:
    """Where :func:`refine_kept` keeps the refined plan of these inputs."""
    return Path(cache_dir) / SUBDIR / f"{refine_key(plan, world, grid, seed, settings, reorder)}.json"


def kept_plan(plan: Plan, world: World, *, seed: int, cache_dir: Path | None, grid: OccupancyGrid,
              settings: RefineSettings | None = None, reorder: bool = True) -> Plan | None:
    """The refined plan :func:`refine_kept` would read for these inputs, or None (none kept, no cache)."""
    if cache_dir is None or not plan.robot_id:
        return None
    return _read(kept_path(plan, world, seed=seed, cache_dir=cache_dir, grid=grid, settings=settings,
                           reorder=reorder))


def _stopped(plan: Plan) -> bool:
    """Whether ``stop`` ended B4 (:data:`kbplanner.planning.manipulation.STOPPED`; the text is repeated
    here: the module is imported only when B4 runs)."""
    return bool(plan.notes) and plan.notes[-1].startswith("B4 stopped by the caller after ")


def refine_plan(plan: Plan, world: World, *, seed: int, grid: OccupancyGrid | None,
                settings: RefineSettings | None, progress: Callable[[str, int, int], None] | None,
                reorder: bool, stop: Callable[[Plan], bool] | None = None) -> Plan:
    """B4 (:func:`kbplanner.planning.manipulation.refine_plan`), its search and IK modules imported here,
    when a plan is refined: a command whose refined plan is kept imports none of them (issue 14)."""
    from kbplanner.planning import manipulation

    return manipulation.refine_plan(plan, world, seed=seed, grid=grid, settings=settings, progress=progress,
                                    reorder=reorder, stop=stop)


def _read(path: Path) -> Plan | None:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError:
        return None
    try:
        plan = Plan.from_json(text)
    except (ValueError, TypeError, KeyError) as exc:  # a damaged file: B4 runs again and replaces it
        log.warning("ignoring the kept refined plan %s: %s", path, exc)
        return None
    return plan if plan.to_json() == text else None


def _write(path: Path, plan: Plan) -> None:
    try:
        atomic_write_text(path, plan.to_json())
        kept = sorted(path.parent.glob("*.json"), key=lambda p: (p.stat().st_mtime_ns, p.name), reverse=True)
        for old in kept[KEEP:]:
            old.unlink(missing_ok=True)
    except OSError as exc:
        log.warning("could not keep the refined plan in %s: %s", path.parent, exc)
