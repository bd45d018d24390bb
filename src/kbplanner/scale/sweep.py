"""Scenario sweeps (analysis, after B5): many variants of one project simulated, compared, Pareto-ranked.

A sweep takes a project directory and ``--vary`` axes and gives one result row per variant:

- ``storage``: candidate material storage locations. A candidate is a scenario name (that scenario as
  it is), ``X,Y`` or ``X,Y,YAW`` (site frame, metres, radians: the base scenario's storage moved there,
  its robot pickup location moved with it keeping the same pose relative to the storage), or
  ``grid:STEP`` (every point of a STEP-metre grid over the site extent where the storage footprint and
  the pickup location are free of obstacles). Candidates are separated by ``;`` or given by repeated
  ``--vary storage=...`` options.
- ``seed``: simulation seeds (``1,2,3``).
- ``start``: robot start times (``07:00,10:00``): the simulation begins that long after the
  calendar's ``work_start`` into the workers' day (worker motions are planned from the start of the
  day and shifted; the executor receives them through its ``workers`` argument).

A variant's change is an in-memory overlay on the loaded model (rdflib edits replacing the storage's
and the pickup location's pose); the user's files are never edited. Variants are the product of the
axes in the order given, with deterministic ids (``v001-...``) and seeds. A moved candidate whose
storage or pickup location is not free is a ``rejected`` result row with the reason, not an error.

Execution: serially in this process (``workers=1``), in local processes
(``ProcessPoolExecutor`` with the ``spawn`` context: each process loads the project itself), or on
a Dask (``dask://HOST:PORT``) or Ray (``ray://HOST:PORT``) cluster. The results do not depend on
where a variant ran. ``pareto_front`` gives the variants not dominated in (time below the safety
threshold, total duration), both minimised; ``write_sweep`` writes ``sweep.csv``, ``sweep.json``,
``pareto.csv`` and ``pareto.png``.

Example:
    >>> spec = SweepSpec(Path("data/case_study"), scenario="storage-outside",
    ...                  axes=parse_vary(["storage=18.5,-16;12,-16", "seed=1,2"]))  # doctest: +SKIP
    >>> result = run_sweep(spec, out_dir=Path("runs/sweep"), workers=2)  # doctest: +SKIP
    >>> [r.variant for r in result.front]  # doctest: +SKIP
"""

from __future__ import annotations

import csv
import io
import logging
import math
import multiprocessing
import tempfile
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import nullcontext
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from rdflib import Graph, Literal, URIRef

from kbplanner.core.errors import KbplannerError
from kbplanner.core.outputs import atomic_write_bytes, atomic_write_text, run_directory, write_json
from kbplanner.core.vocab import KBP

if TYPE_CHECKING:
    from kbplanner.model.project_data import ProjectData
    from kbplanner.simulation.workers import WorkerMotion
    from kbplanner.world.build import World
    from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

AXES = ("storage", "seed", "start")
PICKUP_CLEARANCE_M = 0.4  # the robot's half width, about: free space needed around the pickup location
SAMPLE_STEP_M = 0.05  # spacing of the points checked inside the storage footprint
OK, REJECTED, FAILED = "ok", "rejected", "failed"
SAFETY_KEYS = {"threshold": "below_threshold_s", "iso": "below_separation_s"}
CONNECT_TIMEOUT_S = 30  # Dask: seconds to reach the scheduler (Ray Client waits about as long)
RAY_CONNECT_ATTEMPTS = 4  # Ray Client sessions that failed to start (see _ray_connect)

Progress = Callable[[int, int, str], None]  # (done, total, variant id)


class SweepError(KbplannerError):
    """A sweep that cannot be set up: bad ``--vary`` syntax, an unknown scenario, a missing extra."""


# ---- variants ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StorageCandidate:
    """A storage location to try: a named scenario, or the base storage moved to x, y (m), yaw (rad)."""

    label: str
    scenario: str | None = None
    x: float | None = None
    y: float | None = None
    yaw: float | None = None  # None: keep the base storage's yaw

    @property
    def moved(self) -> bool:
        """True for a moved storage, False for a named scenario."""
        return self.scenario is None


@dataclass(frozen=True)
class Variant:
    """One variant of the project: its id, scenario, storage candidate, seed and start time."""

    id: str
    scenario: str
    storage: StorageCandidate | None
    seed: int
    start: str  # HH:MM
    start_offset_s: float


@dataclass(frozen=True)
class SweepAxes:
    """The parsed ``--vary`` values (raw storage candidates, seeds, start times)."""

    storage: tuple[str, ...] = ()
    seed: tuple[int, ...] = ()
    start: tuple[str, ...] = ()


def _bad_vary(text: str, why: str, fix: str) -> SweepError:
    return SweepError(f"bad --vary {text!r}: {why}", element=text, fix=fix)


def parse_vary(texts: Sequence[str]) -> SweepAxes:
    """Parse ``--vary AXIS=VALUES`` options (``storage=...``, ``seed=1,2``, ``start=07:00,10:00``).

    Example:
        >>> parse_vary(["seed=1,2", "storage=1,2;grid:2"]).storage
        ('1,2', 'grid:2')
    """
    storage: list[str] = []
    seeds: list[int] = []
    starts: list[str] = []
    for text in texts:
        axis, sep, values = text.partition("=")
        axis = axis.strip()
        if not sep or axis not in AXES:
            raise _bad_vary(text, f"expected AXIS=VALUES with AXIS one of {', '.join(AXES)}",
                            "write e.g. --vary storage=12.0,-16.0 --vary seed=1,2 --vary start=07:00,10:00")
        if not values.strip():
            raise _bad_vary(text, f"no values for {axis}", f"give at least one value after {axis}=")
        if axis == "storage":
            for cand in values.split(";"):
                if cand.strip():
                    storage.append(cand.strip())
        elif axis == "seed":
            for v in values.split(","):
                try:
                    seeds.append(int(v.strip()))
                except ValueError:
                    raise _bad_vary(text, f"seed {v.strip()!r} is not an integer",
                                    "write --vary seed=1,2,3") from None
        else:
            for v in values.split(","):
                _clock_s(v.strip(), text)
                starts.append(v.strip())
    return SweepAxes(tuple(storage), tuple(dict.fromkeys(seeds)), tuple(dict.fromkeys(starts)))


def _clock_s(value: str, text: str) -> float:
    hh, sep, mm = value.partition(":")
    if not sep or not hh.isdigit() or not mm.isdigit() or int(mm) > 59 or int(hh) > 23:
        raise _bad_vary(text, f"start time {value!r} is not HH:MM", "write --vary start=07:00,10:30")
    return int(hh) * 3600.0 + int(mm) * 60.0


def parse_storage(value: str, scenarios: Iterable[str]) -> StorageCandidate | float:
    """A storage candidate: a scenario name, ``X,Y[,YAW]``; or the step (m) of ``grid:STEP``."""
    known = set(scenarios)
    if value in known:
        return StorageCandidate(label=value, scenario=value)
    if value.startswith("grid:"):
        try:
            step = float(value[5:])
        except ValueError:
            step = -1.0
        if not step > 0 or not math.isfinite(step):
            raise _bad_vary(f"storage={value}", "grid step must be a positive number of metres",
                            "write --vary storage=grid:2.0")
        return step
    parts = value.split(",")
    try:
        nums = [float(p) for p in parts]
    except ValueError:
        nums = []
    if len(nums) not in (2, 3) or not all(math.isfinite(n) for n in nums):
        raise _bad_vary(f"storage={value}",
                        "a storage candidate is a scenario name, X,Y, X,Y,YAW or grid:STEP",
                        "use metres and radians in the site frame, e.g. storage=12.0,-16.0,1.5708; "
                        "scenarios: " + (", ".join(sorted(known)) or "none"))
    x, y = round(nums[0], 3), round(nums[1], 3)
    yaw = round(nums[2], 6) if len(nums) == 3 else None
    label = f"x{x:.2f}y{y:.2f}" + (f"r{yaw:.2f}" if yaw is not None else "")
    return StorageCandidate(label=label, x=x, y=y, yaw=yaw)


# ---- the storage in the model and the in-memory overlay ------------------------------------------
@dataclass(frozen=True)
class StorageInfo:
    """The material storage of the task elements: IRIs, pose, size and pickup pose (m, rad)."""

    iri: str
    pose_iri: str
    pickup_iri: str
    x: float
    y: float
    yaw: float
    size: tuple[float, float]
    pickup: tuple[float, float, float]


def _num(g: Graph, s: URIRef, p: URIRef, file: Any, fix: str) -> float:
    v = g.value(s, p)
    if not isinstance(v, Literal):
        raise SweepError(f"{s} has no numeric {p}", file=file, element=str(s), fix=fix)
    return float(v.toPython())


def find_storage(model: Graph, *, file: Any = None) -> StorageInfo:
    """The one material storage the model's elements are stored in (``kbp:storedIn``)."""
    storages = sorted({str(o) for o in model.objects(None, KBP.storedIn)})
    fix = ("sweep from a scenario with one kbp:MaterialStorage "
           "(see data/case_study/scenarios/storage_outside.ttl)")
    if len(storages) != 1:
        raise SweepError(f"{len(storages)} material storages hold elements; "
                         "a moved candidate needs exactly one",
                         file=file, element=", ".join(storages) or "kbp:storedIn", fix=fix)
    s = URIRef(storages[0])
    pose, pickup = model.value(s, KBP.installedPose), model.value(s, KBP.pickupLocation)
    if not isinstance(pose, URIRef) or not isinstance(pickup, URIRef):
        raise SweepError("the storage has no kbp:installedPose or kbp:pickupLocation (as IRIs)",
                         file=file, element=str(s), fix="give both poses as named kbp:Pose nodes")
    return StorageInfo(
        iri=str(s), pose_iri=str(pose), pickup_iri=str(pickup),
        x=_num(model, pose, KBP.x, file, fix), y=_num(model, pose, KBP.y, file, fix),
        yaw=_num(model, pose, KBP.yaw, file, fix) if model.value(pose, KBP.yaw) is not None else 0.0,
        size=(_num(model, s, KBP.sizeX, file, fix), _num(model, s, KBP.sizeY, file, fix)),
        pickup=(_num(model, pickup, KBP.x, file, fix), _num(model, pickup, KBP.y, file, fix),
                _num(model, pickup, KBP.yaw, file, fix) if model.value(pickup, KBP.yaw) is not None else 0.0),
    )


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def moved_pickup(st: StorageInfo, x: float, y: float, yaw: float) -> tuple[float, float, float]:
    """The pickup pose after moving the storage to (x, y, yaw): same pose relative to the storage."""
    px, py, pyaw = st.pickup
    c, s = math.cos(-st.yaw), math.sin(-st.yaw)
    rx, ry = c * (px - st.x) - s * (py - st.y), s * (px - st.x) + c * (py - st.y)
    c2, s2 = math.cos(yaw), math.sin(yaw)
    return (round(x + c2 * rx - s2 * ry, 6), round(y + s2 * rx + c2 * ry, 6),
            round(_wrap(yaw + pyaw - st.yaw), 6))


@dataclass
class Overlay:
    """An in-memory change of the model: the (subject, predicate) pairs it replaces and what it adds."""

    clear: list[tuple[URIRef, URIRef]]
    add: Graph

    def turtle(self) -> str:
        """The added triples as Turtle (for the record)."""
        return str(self.add.serialize(format="turtle"))


def storage_overlay(st: StorageInfo, x: float, y: float, yaw: float) -> Overlay:
    """The overlay moving the storage to (x, y, yaw) and its pickup location with it."""
    clear: list[tuple[URIRef, URIRef]] = []
    add = Graph()
    add.bind("kbp", str(KBP))
    for iri, (nx, ny, nyaw) in ((st.pose_iri, (x, y, yaw)), (st.pickup_iri, moved_pickup(st, x, y, yaw))):
        node = URIRef(iri)
        for p, v in ((KBP.x, nx), (KBP.y, ny), (KBP.yaw, nyaw)):
            clear.append((node, p))
            add.add((node, p, Literal(float(v))))
    return Overlay(clear, add)


def apply_overlay(model: Graph, overlay: Overlay) -> None:
    """Apply an overlay to a loaded model in memory (never to the user's files)."""
    for s, p in overlay.clear:
        model.remove((s, p, None))
    for t in overlay.add:
        model.add(t)


# ---- free-space checks ---------------------------------------------------------------------------
def free_ground_grid(world: World, storage_iri: str) -> OccupancyGrid:
    """The task storey's occupancy grid with the storage itself left out (where could it stand?)."""
    from kbplanner.world.exports import storey_map

    others = tuple(o for o in world.site_objects if o.iri != storage_iri)
    return storey_map(replace(world, site_objects=others)).grid


def site_check(grid: OccupancyGrid, st: StorageInfo, x: float, y: float, yaw: float, *,
               clearance_m: float = PICKUP_CLEARANCE_M) -> str | None:
    """Why the storage cannot stand at (x, y, yaw), or None when its footprint and pickup pose are free."""
    hx, hy = st.size[0] / 2, st.size[1] / 2
    us = np.linspace(-hx, hx, max(2, math.ceil(2 * hx / SAMPLE_STEP_M) + 1))
    vs = np.linspace(-hy, hy, max(2, math.ceil(2 * hy / SAMPLE_STEP_M) + 1))
    c, s = math.cos(yaw), math.sin(yaw)
    for u in us:
        for v in vs:
            px, py = x + c * u - s * v, y + s * u + c * v
            if not grid.contains(px, py):
                return f"storage footprint leaves the site map at ({px:.2f}, {py:.2f})"
            if grid.is_occupied(px, py):
                return f"storage footprint overlaps an obstacle at ({px:.2f}, {py:.2f})"
    kx, ky, _ = moved_pickup(st, x, y, yaw)
    if not grid.contains(kx, ky):
        return f"pickup location ({kx:.2f}, {ky:.2f}) is outside the site map"
    free = grid.clearance_at(kx, ky)
    if free < clearance_m:
        return (f"pickup location ({kx:.2f}, {ky:.2f}) has {free:.2f} m free around it, "
                f"needs {clearance_m:.2f} m")
    return None


def grid_candidates(grid: OccupancyGrid, st: StorageInfo, step_m: float, *,
                    clearance_m: float = PICKUP_CLEARANCE_M) -> list[StorageCandidate]:
    """Storage positions on a ``step_m`` grid over the map where storage and pickup pose are free."""
    ext = grid.extent
    out = []
    for y in np.arange(ext.ymin + step_m / 2, ext.ymax, step_m):
        for x in np.arange(ext.xmin + step_m / 2, ext.xmax, step_m):
            fx, fy = round(float(x), 3), round(float(y), 3)
            if site_check(grid, st, fx, fy, st.yaw, clearance_m=clearance_m) is None:
                out.append(StorageCandidate(label=f"x{fx:.2f}y{fy:.2f}", x=fx, y=fy))
    log.info("grid:%s gives %d free storage positions", step_m, len(out))
    return out


# ---- the sweep specification ---------------------------------------------------------------------
@dataclass(frozen=True)
class SweepSpec:
    """What to sweep: the project, the base scenario, the axes and run options."""

    project_dir: Path
    scenario: str | None = None  # base scenario of moved candidates (default: the first one)
    axes: SweepAxes = field(default_factory=SweepAxes)
    max_elements: int | None = None
    threshold_m: float = 1.0
    clearance_m: float = PICKUP_CLEARANCE_M


@dataclass(frozen=True)
class VariantTask:
    """What one process needs to simulate a variant (picklable)."""

    project_dir: str
    variant: Variant
    max_elements: int | None
    threshold_m: float
    run_dir: str | None  # keep the run here; None: a temporary directory


@dataclass
class VariantResult:
    """One row of the sweep table."""

    variant: str
    scenario: str
    storage: str
    storage_x: float | None
    storage_y: float | None
    storage_yaw: float | None
    seed: int
    start: str
    status: str  # ok | rejected | failed
    reason: str = ""
    installed: int = 0
    elements: int = 0
    total_min: float | None = None
    per_frame_min: float | None = None
    min_separation_m: float | None = None
    below_threshold_s: float | None = None
    below_separation_s: float | None = None
    stops: int = 0
    stop_time_s: float | None = None

    @property
    def complete(self) -> bool:
        """Simulated with every element installed."""
        return self.status == OK and self.elements > 0 and self.installed == self.elements


COLUMNS = [f.name for f in fields(VariantResult)]


def _round(v: float | None, nd: int = 3) -> float | None:
    return None if v is None else round(float(v), nd)


def build_variants(spec: SweepSpec, *, base: StorageInfo | None = None, grid: OccupancyGrid | None = None
                   ) -> tuple[list[Variant], dict[str, str]]:
    """The sweep's variants in a deterministic order, and the rejection reason of each rejected one.

    ``base`` and ``grid`` (the base scenario's storage and its free-ground map) are needed for moved
    and grid candidates (:func:`prepare_base` gives them).
    """
    from kbplanner.model.project_data import read_manifest

    manifest = read_manifest(spec.project_dir)
    scen = _base_scenario(spec, manifest)
    cands: list[StorageCandidate | None] = []
    for raw in spec.axes.storage:
        parsed = parse_storage(raw, manifest.scenarios)
        if isinstance(parsed, float):
            if base is None or grid is None:
                raise SweepError("grid candidates need the base storage and map", element=raw,
                                 fix="call prepare_base(spec) first")
            cands.extend(grid_candidates(grid, base, parsed, clearance_m=spec.clearance_m))
        else:
            cands.append(parsed)
    cands = list(dict.fromkeys(cands)) or [None]
    seeds = spec.axes.seed or (manifest.seed,)
    work_start = _clock_s(manifest.calendar.work_start, f"calendar work_start {manifest.calendar.work_start}")
    starts = spec.axes.start or (manifest.calendar.work_start,)
    variants: list[Variant] = []
    rejected: dict[str, str] = {}
    n = 0
    for c in cands:
        for seed in seeds:
            for start in starts:
                offset = _clock_s(start, f"start={start}") - work_start
                if offset < 0:
                    raise SweepError(f"start {start} is before the calendar's work_start "
                                     f"{manifest.calendar.work_start}", file=manifest.path, element=start,
                                     fix="choose start times at or after work_start")
                n += 1
                label = c.label if c is not None else scen
                vid = f"v{n:03d}-{label}-s{seed}-t{start.replace(':', '')}"
                scenario = c.scenario if c is not None and c.scenario else scen
                variants.append(Variant(vid, scenario, c, seed, start, offset))
                if c is not None and c.moved:
                    if base is None or grid is None:
                        raise SweepError("moved candidates need the base storage and map", element=c.label,
                                         fix="call prepare_base(spec) first")
                    why = site_check(grid, base, c.x or 0.0, c.y or 0.0,
                                     base.yaw if c.yaw is None else c.yaw, clearance_m=spec.clearance_m)
                    if why:
                        rejected[vid] = why
    return variants, rejected


def _base_scenario(spec: SweepSpec, manifest: Any) -> str:
    if spec.scenario is not None:
        if spec.scenario not in manifest.scenarios:
            raise SweepError(f"unknown scenario {spec.scenario!r}", file=manifest.path, element=spec.scenario,
                             fix="choose one of: " + (", ".join(sorted(manifest.scenarios)) or "none"))
        return str(spec.scenario)
    if not manifest.scenarios:
        raise SweepError("the project has no scenario to sweep", file=manifest.path,
                         fix="add a [scenarios.NAME] with the storage overlay to project.toml")
    return str(sorted(manifest.scenarios)[0])


def prepare_base(spec: SweepSpec) -> tuple[StorageInfo, OccupancyGrid] | None:
    """The base scenario's storage and free-ground map, when moved or grid candidates need them."""
    from kbplanner.model.project_data import ProjectData, read_manifest
    from kbplanner.world.build import world_of

    manifest = read_manifest(spec.project_dir)
    parsed = [parse_storage(r, manifest.scenarios) for r in spec.axes.storage]
    if not any(isinstance(c, float) or c.moved for c in parsed):
        return None
    project = ProjectData.load(spec.project_dir, scenario=_base_scenario(spec, manifest))
    st = find_storage(project.model, file=manifest.path)
    return st, free_ground_grid(world_of(project), st.iri)


# ---- one variant (runs in a worker process) ------------------------------------------------------
def shifted_workers(project: ProjectData, grid: OccupancyGrid, *, seed: int, horizon_s: float,
                    offset_s: float) -> list[WorkerMotion]:
    """The workers' motions from ``offset_s`` seconds into their day on: planned from 0, shifted."""
    from kbplanner.simulation.workers import plan_workers

    motions = plan_workers(project.model, grid, seed=seed, horizon_s=horizon_s + offset_s)
    if offset_s <= 0:
        return motions
    for m in motions:
        m.segments = [(t0 - offset_s, t1 - offset_s, pts, cum) for t0, t1, pts, cum in m.segments
                      if t1 - offset_s >= 0.0]
    return motions


def run_variant(task: VariantTask) -> VariantResult:
    """Load the project, apply the variant's overlay, plan (B1-B4) and simulate (B5); one table row."""
    from kbplanner.analysis.report import scenario_figures
    from kbplanner.analysis.run_record import RunRecord
    from kbplanner.model.project_data import ProjectData
    from kbplanner.planning.manipulation import refine_plan
    from kbplanner.planning.planner import plan_task
    from kbplanner.simulation.executor import WORKER_HORIZON_S_PER_STEP, simulate
    from kbplanner.simulation.skills import ExecSettings
    from kbplanner.world.build import world_of
    from kbplanner.world.exports import storey_map

    v = task.variant
    project = ProjectData.load(task.project_dir, scenario=v.scenario)
    st = find_storage(project.model, file=project.manifest.path)
    x, y, yaw = st.x, st.y, st.yaw
    if v.storage is not None and v.storage.moved:
        x, y = float(v.storage.x or 0.0), float(v.storage.y or 0.0)
        yaw = st.yaw if v.storage.yaw is None else float(v.storage.yaw)
        apply_overlay(project.model, storage_overlay(st, x, y, yaw))
    label = v.storage.label if v.storage else v.scenario
    row = VariantResult(variant=v.id, scenario=v.scenario, storage=label,
                        storage_x=_round(x), storage_y=_round(y), storage_yaw=_round(yaw, 4), seed=v.seed,
                        start=v.start, status=OK)
    try:
        world = world_of(project)
        grid = storey_map(world).grid
        plan = plan_task(project, world=world)
        if not plan.robot_id:
            row.status, row.reason = FAILED, "no robot of the knowledge base fits the task"
            return row
        if task.max_elements is not None:
            plan.keep_first(task.max_elements)
        refined = refine_plan(plan, world, seed=v.seed, grid=grid)
        horizon = 1800.0 + WORKER_HORIZON_S_PER_STEP * len(refined.steps)
        workers = shifted_workers(project, grid, seed=v.seed, horizon_s=horizon, offset_s=v.start_offset_s)
        with tempfile.TemporaryDirectory(prefix="kbplanner-sweep-") as tmp:
            out = Path(task.run_dir) if task.run_dir else Path(tmp) / "run"
            simulate(project, refined, seed=v.seed, out_dir=out, world=world, grid=grid,
                     settings=ExecSettings(keyframes=False), workers=workers)
            rec = RunRecord.load(out)
            fig = scenario_figures(rec, rec.proximity(threshold_m=task.threshold_m))
    except KbplannerError as err:
        row.status, row.reason = FAILED, str(err).splitlines()[0]
        return row
    row.installed, row.elements = fig.installed, fig.elements
    row.total_min, row.per_frame_min = _round(fig.total_min), _round(fig.per_element_min)
    row.min_separation_m = _round(fig.min_separation_m)
    row.below_threshold_s = _round(fig.below_threshold_s)
    row.below_separation_s = _round(fig.below_separation_s)
    row.stops, row.stop_time_s = fig.worker_stops, _round(fig.stop_time_s)
    if row.installed < row.elements:
        row.reason = f"{row.elements - row.installed} element(s) not installed"
    return row


# ---- execution backends --------------------------------------------------------------------------
def _missing_extra(module: str, extra: str) -> SweepError:
    return SweepError(f"{module} is not installed; a cluster address needs it", element=module,
                      fix=f"pip install 'kbplanner[{extra}]' (or run with --workers N on this machine)")


def _unreachable(address: str, what: str, err: Exception) -> SweepError:
    return SweepError(f"cannot reach the cluster at {address} ({type(err).__name__}: {err})", element=address,
                      fix=f"start {what} there, or run with --workers N on this machine")


def _ray_connect(ray: Any, address: str) -> Any:
    """A Ray Client connection of its own to ``address`` (``allow_multiple``: not the process's global
    one, so a later sweep to another address never reuses this cluster); the caller disconnects it
    (leaving its ``with`` block alone does not disconnect such a connection).

    The Ray Client server sometimes accepts a connection and then fails to start the session's server
    process (``ConnectionAbortedError`` "Initialization failure from server": a fork race in Ray's
    client proxy, ray-project/ray issue 63202, within a second); that is tried again, up to
    ``RAY_CONNECT_ATTEMPTS`` times. No answer at all (``ConnectionError`` after about 30 s) is final.
    """
    what = "the Ray Client server of a Ray head (ray start --head --ray-client-server-port PORT)"
    for attempt in range(1, RAY_CONNECT_ATTEMPTS + 1):
        try:
            return ray.init(address=address, logging_level=logging.WARNING, allow_multiple=True)
        except ConnectionAbortedError as err:
            if attempt == RAY_CONNECT_ATTEMPTS:
                raise _unreachable(address, what, err) from None
            log.warning("Ray Client at %s: session start failed (attempt %d of %d), trying again",
                        address, attempt, RAY_CONNECT_ATTEMPTS)
        except ConnectionError as err:
            raise _unreachable(address, what, err) from None
    raise AssertionError("unreachable")  # pragma: no cover


def execute(tasks: Sequence[VariantTask], *, workers: int = 1, cluster: str | None = None,
            progress: Progress | None = None) -> list[VariantResult]:
    """Run the tasks serially, in ``workers`` local processes or on a cluster; results in task order."""
    say = progress or (lambda _d, _t, _v: None)
    total = len(tasks)
    results: dict[str, VariantResult] = {}
    if cluster:
        return _execute_cluster(tasks, cluster, say)
    if workers < 1:
        raise SweepError(f"--workers {workers} is not positive", element="--workers",
                         fix="use --workers 1 or more")
    if workers == 1 or total <= 1:
        for n, t in enumerate(tasks, start=1):
            results[t.variant.id] = run_variant(t)
            say(n, total, t.variant.id)
    else:
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=min(workers, total), mp_context=ctx) as pool:
            futures = {pool.submit(run_variant, t): t.variant.id for t in tasks}
            for n, fut in enumerate(as_completed(futures), start=1):
                results[futures[fut]] = fut.result()
                say(n, total, futures[fut])
    return [results[t.variant.id] for t in tasks]


def _execute_cluster(tasks: Sequence[VariantTask], address: str, say: Progress) -> list[VariantResult]:
    scheme, sep, rest = address.partition("://")
    if not sep or not rest or scheme not in ("dask", "ray"):
        raise SweepError(f"cluster address {address!r} is not dask://HOST:PORT or ray://HOST:PORT",
                         element=address, fix="write --cluster dask://127.0.0.1:8786 or --cluster ray://HOST:10001")
    total = len(tasks)
    results: dict[str, VariantResult] = {}
    if scheme == "dask":
        try:
            from dask.distributed import Client
            from dask.distributed import as_completed as dask_completed
        except ImportError:
            raise _missing_extra("dask.distributed", "cluster") from None
        try:
            client = Client(f"tcp://{rest}", timeout=CONNECT_TIMEOUT_S)
        except OSError as err:  # dask's connection time-out is an OSError too
            raise _unreachable(address, "a Dask scheduler (dask scheduler --port PORT)", err) from None
        with client:
            futures = client.map(run_variant, list(tasks), pure=False)
            ids = {f.key: t.variant.id for f, t in zip(futures, tasks, strict=True)}
            for n, fut in enumerate(dask_completed(futures), start=1):
                results[ids[fut.key]] = fut.result()
                say(n, total, ids[fut.key])
        return [results[t.variant.id] for t in tasks]
    try:
        import ray  # type: ignore[import-not-found,unused-ignore]
    except ImportError:
        raise _missing_extra("ray", "ray") from None
    context = _ray_connect(ray, address)
    try:
        with context:
            remote = ray.remote(run_variant)
            refs = {remote.remote(t): t.variant.id for t in tasks}
            pending = list(refs)
            n = 0
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    n += 1
                    results[refs[ref]] = ray.get(ref)
                    say(n, total, refs[ref])
    finally:
        context.disconnect()
    return [results[t.variant.id] for t in tasks]


# ---- the whole sweep and its outputs -------------------------------------------------------------
@dataclass
class SweepResult:
    """All rows (in variant order), the Pareto front and where the outputs went."""

    rows: list[VariantResult]
    front: list[VariantResult]
    safety: str
    out_dir: Path | None = None

    def table(self, rows: Sequence[VariantResult] | None = None, fmt: str = "table") -> str:
        """The rows (default: all) as an aligned text table or CSV."""
        from kbplanner.core.tables import render

        data = [[getattr(r, c) for c in COLUMNS] for r in (self.rows if rows is None else rows)]
        return render(COLUMNS, data, fmt)


def pareto_front(rows: Sequence[VariantResult], safety: str = "threshold") -> list[VariantResult]:
    """Complete variants not dominated in (time below the safety threshold, total duration), both minimised.

    ``safety`` is ``threshold`` (time below the proximity threshold) or ``iso`` (below the ISO/TS 15066
    protective separation distance). Variants that did not install every element are not candidates.
    Sorted by total duration, then variant id.
    """
    key = SAFETY_KEYS.get(safety)
    if key is None:
        raise SweepError(f"unknown safety objective {safety!r}", element=safety, fix="use threshold or iso")

    def point(r: VariantResult) -> tuple[float, float]:
        return float(getattr(r, key) or 0.0), float(r.total_min or 0.0)

    cands = [r for r in rows if r.complete]
    front = []
    for r in cands:
        a = point(r)
        dominated = any(b[0] <= a[0] and b[1] <= a[1] and b != a for b in map(point, cands))
        if not dominated:
            front.append(r)
    return sorted(front, key=lambda r: (point(r)[1], point(r)[0], r.variant))


def _csv(rows: Sequence[VariantResult]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for r in rows:
        w.writerow(["" if getattr(r, c) is None else getattr(r, c) for c in COLUMNS])
    return buf.getvalue()


def pareto_png(rows: Sequence[VariantResult], front: Sequence[VariantResult], safety: str) -> bytes:
    """A scatter of the complete variants, total duration over time below the threshold, front highlighted."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    key = SAFETY_KEYS[safety]
    label = ("time below the proximity threshold (s)" if safety == "threshold"
             else "time below the ISO/TS 15066 protective separation distance (s)")
    ok = [r for r in rows if r.complete]
    fig, ax = plt.subplots(figsize=(7, 5), dpi=100)
    ax.scatter([float(getattr(r, key) or 0.0) for r in ok], [float(r.total_min or 0.0) for r in ok],
               c="#9aa5b1", label="variants")
    fx = [float(getattr(r, key) or 0.0) for r in front]
    fy = [float(r.total_min or 0.0) for r in front]
    ax.plot(fx, fy, "-o", c="#d1495b", label="Pareto front")
    for r in front:
        ax.annotate(r.variant, (getattr(r, key), r.total_min), fontsize=7, xytext=(4, 4),
                    textcoords="offset points")
    ax.set_xlabel(label)
    ax.set_ylabel("total duration (min)")
    ax.set_title("Storage locations and start times: safety vs duration")
    ax.legend()
    ax.grid(alpha=0.3)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def write_sweep(result: SweepResult, out_dir: Path) -> None:
    """``sweep.csv``, ``sweep.json``, ``pareto.csv`` and ``pareto.png`` into ``out_dir``."""
    atomic_write_text(out_dir / "sweep.csv", _csv(result.rows))
    write_json(out_dir / "sweep.json", {"safety_objective": SAFETY_KEYS[result.safety],
                                        "rows": [asdict(r) for r in result.rows],
                                        "pareto": [r.variant for r in result.front]})
    atomic_write_text(out_dir / "pareto.csv", _csv(result.front))
    atomic_write_bytes(out_dir / "pareto.png", pareto_png(result.rows, result.front, result.safety))


def run_sweep(spec: SweepSpec, *, out_dir: Path | None = None, workers: int = 1,
              cluster: str | None = None, keep_runs: bool = False, safety: str = "threshold",
              progress: Progress | None = None) -> SweepResult:
    """Build the variants, simulate them (rejected ones are rows with their reason), rank, write outputs.

    With ``keep_runs`` each variant's run directory is kept as ``out_dir/runs/<variant id>``
    (on a cluster: that path on the machine that ran it).
    """
    if safety not in SAFETY_KEYS:
        raise SweepError(f"unknown safety objective {safety!r}", element=safety, fix="use threshold or iso")
    prepared = prepare_base(spec)
    base, grid = prepared if prepared is not None else (None, None)
    variants, rejected = build_variants(spec, base=base, grid=grid)
    if keep_runs and out_dir is None:
        raise SweepError("keep_runs needs an output directory", fix="give --out DIR")
    with run_directory(out_dir) if out_dir is not None else nullcontext(None) as stage:
        return _run_variants(spec, variants, rejected, base, stage, out_dir, workers, cluster, keep_runs,
                             safety, progress)


def _run_variants(spec: SweepSpec, variants: list[Variant], rejected: dict[str, str],
                  base: StorageInfo | None, stage: Path | None, out_dir: Path | None, workers: int,
                  cluster: str | None, keep_runs: bool, safety: str, progress: Progress | None
                  ) -> SweepResult:
    runs_dir = (stage / "runs").resolve() if keep_runs and stage is not None else None
    tasks = [VariantTask(str(Path(spec.project_dir).resolve()), v, spec.max_elements, spec.threshold_m,
                         str(runs_dir / v.id) if runs_dir is not None else None)
             for v in variants if v.id not in rejected]
    log.info("sweep: %d variants, %d rejected before simulation", len(variants), len(rejected))
    done = {r.variant: r for r in execute(tasks, workers=workers, cluster=cluster, progress=progress)}
    rows = []
    for v in variants:
        if v.id in done:
            rows.append(done[v.id])
            continue
        c = v.storage
        assert c is not None and base is not None
        yaw = base.yaw if c.yaw is None else c.yaw
        rows.append(VariantResult(variant=v.id, scenario=v.scenario, storage=c.label, storage_x=c.x,
                                  storage_y=c.y, storage_yaw=_round(yaw, 4), seed=v.seed, start=v.start,
                                  status=REJECTED, reason=rejected[v.id]))
    result = SweepResult(rows=rows, front=pareto_front(rows, safety), safety=safety, out_dir=out_dir)
    if stage is not None:
        write_sweep(result, stage)
    return result
