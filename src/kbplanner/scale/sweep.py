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

The parts: the ``--vary`` axes and variants (:mod:`.sweep_axes`), the storage, its overlay and
the free-space checks (:mod:`.sweep_storage`), one variant simulated (:mod:`.sweep_simulate`), the
execution backends (:mod:`.sweep_backends`), the Pareto front and output files
(:mod:`.sweep_pareto`); this module builds the variants of a :class:`SweepSpec` and runs the sweep
(:func:`run_sweep`).

Example:
    >>> spec = SweepSpec(Path("data/case_study"), scenario="storage-outside",
    ...                  axes=parse_vary(["storage=18.5,-16;12,-16", "seed=1,2"]))  # doctest: +SKIP
    >>> result = run_sweep(spec, out_dir=Path("runs/sweep"), workers=2)  # doctest: +SKIP
    >>> [r.variant for r in result.front]  # doctest: +SKIP
"""

from __future__ import annotations

import logging
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kbplanner.core.outputs import run_directory
from kbplanner.scale.sweep_axes import (
    StorageCandidate,
    SweepAxes,
    SweepError,
    Variant,
    clock_s,
    parse_storage,
)
from kbplanner.scale.sweep_axes import parse_vary as parse_vary  # documented with SweepSpec, run_sweep
from kbplanner.scale.sweep_backends import Progress, execute
from kbplanner.scale.sweep_pareto import SAFETY_KEYS, SweepResult, pareto_front, write_sweep
from kbplanner.scale.sweep_simulate import REJECTED, VariantResult, VariantTask, rounded
from kbplanner.scale.sweep_storage import (
    PICKUP_CLEARANCE_M,
    StorageInfo,
    find_storage,
    free_ground_grid,
    grid_candidates,
    site_check,
)

if TYPE_CHECKING:
    from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SweepSpec:
    """What to sweep: the project, the base scenario, the axes and run options."""

    project_dir: Path
    scenario: str | None = None  # base scenario of moved candidates (default: the first one)
    axes: SweepAxes = field(default_factory=SweepAxes)
    max_elements: int | None = None
    threshold_m: float = 1.0
    clearance_m: float = PICKUP_CLEARANCE_M



def build_variants(spec: SweepSpec, *, base: StorageInfo | None = None, grid: OccupancyGrid | None = None
                   ) -> tuple[list[Variant], dict[str, str]]:
    """The sweep's variants in a deterministic order, and the rejection reason of each rejected one.

    ``base`` and ``grid`` (the base scenario's storage and its free-ground map) are needed for moved
    and grid candidates (:func:`prepare_base` gives them).
    """
    from kbplanner.model.project_manifest import read_manifest

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
    work_start = clock_s(manifest.calendar.work_start, f"calendar work_start {manifest.calendar.work_start}")
    starts = spec.axes.start or (manifest.calendar.work_start,)
    variants: list[Variant] = []
    rejected: dict[str, str] = {}
    n = 0
    for c in cands:
        for seed in seeds:
            for start in starts:
                offset = clock_s(start, f"start={start}") - work_start
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
    from kbplanner.model.project_data import ProjectData
    from kbplanner.model.project_manifest import read_manifest
    from kbplanner.world.build import world_of

    manifest = read_manifest(spec.project_dir)
    parsed = [parse_storage(r, manifest.scenarios) for r in spec.axes.storage]
    if not any(isinstance(c, float) or c.moved for c in parsed):
        return None
    project = ProjectData.load(spec.project_dir, scenario=_base_scenario(spec, manifest))
    st = find_storage(project.model, file=manifest.path)
    return st, free_ground_grid(world_of(project), st.iri)



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
                                  storage_y=c.y, storage_yaw=rounded(yaw, 4), seed=v.seed, start=v.start,
                                  status=REJECTED, reason=rejected[v.id]))
    result = SweepResult(rows=rows, front=pareto_front(rows, safety), safety=safety, out_dir=out_dir)
    if stage is not None:
        write_sweep(result, stage)
    return result
