"""Scenarios over seeds (analysis, ``kbplanner compare --seeds``): distributions, not one seed.

``compare_seeds`` simulates every scenario once per seed (B1-B5 through
:func:`kbplanner.analysis.comparison.simulate_scenario`, the pipeline's simulate step) into
``DIR/<scenario>/seed-<N>/``, and, for the time cost of monitoring, the seeds asked for again with
speed and separation monitoring off into ``DIR/<scenario>/seed-<N>-monitoring-off/``. Each run's
figures are the ones of its ``metrics.json`` (``safety`` and ``totals``: the same definitions as
``comparison.csv``, see :mod:`kbplanner.simulation.safety`). Per scenario: the median and the worst
case over seeds of each figure (:data:`FIGURES`), the collisions (seed, time, who, cause), and the
time monitoring costs (duration with monitoring on minus off, seed by seed). The outputs
(:mod:`kbplanner.analysis.seed_report`) are written atomically into ``DIR``.

Runs that install no element (B4 found no feasible first element) are kept and listed, but have no
duration or separation worth a median: the figures are over the runs that installed at least one.
"""

from __future__ import annotations

import statistics
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from kbplanner.analysis.comparison import simulate_scenario
from kbplanner.analysis.run_record import RunRecord
from kbplanner.model.project_data import ProjectData

Say = Callable[[str], None]


@dataclass(frozen=True)
class Figure:
    """A figure of a run: its key, its label, and whether its worst case is the largest value."""

    key: str
    label: str
    worst_is_max: bool = True


FIGURES = (
    Figure("duration_min", "duration (min)"),
    Figure("min_separation_m", "min separation (m)", worst_is_max=False),
    Figure("time_below_1m_s", "time < 1 m (s)"),
    Figure("time_below_protective_s", "time < S_p (s)"),
    Figure("stops", "stops"),
    Figure("stop_time_s", "stopped (s)"),
    Figure("slowdowns", "slow-downs"),
    Figure("time_lost_s", "time lost to stops and slow-downs (s)"),
    Figure("collisions", "collisions"),
)


@dataclass
class SeedRun:
    """One simulated run of one scenario and seed."""

    scenario: str
    seed: int
    monitoring: str
    run_dir: str  # relative to the output folder
    installed: int
    elements: int
    figures: dict[str, float | None]
    collisions: list[dict[str, Any]] = field(default_factory=list)

    @classmethod
    def of(cls, scenario: str, seed: int, monitoring: str, rec: RunRecord, run_dir: str) -> SeedRun:
        """The run's figures from its record (``metrics.json``)."""
        s = rec.metrics.get("safety", {})
        totals = rec.metrics.get("totals", {})
        figs: dict[str, float | None] = {
            "duration_min": round(float(totals.get("sim_time_s", 0.0)) / 60.0, 3)
        }
        for f in FIGURES[1:]:
            v = s.get(f.key)
            figs[f.key] = None if v is None else v if isinstance(v, int) else float(v)
        hits = [
            {"t_s": e.get("t_s"), "worker": e.get("details", {}).get("worker"),
             "cause": e.get("details", {}).get("cause"),
             "robot_speed_mps": e.get("details", {}).get("robot_speed_mps")}
            for e in rec.events
            if e.get("kind") == "collision"
        ]
        return cls(scenario, seed, monitoring, run_dir, int(totals.get("installed", 0)),
                   int(totals.get("elements", 0)), figs, hits)

    @property
    def counted(self) -> bool:
        """Whether the run enters the medians (it installed at least one element)."""
        return self.installed > 0


def median_worst(runs: Sequence[SeedRun], fig: Figure) -> tuple[float | None, float | None]:
    """Median and worst case of a figure over the counted runs (None: no value)."""
    vals = [v for r in runs if r.counted and (v := r.figures.get(fig.key)) is not None]
    if not vals:
        return None, None
    worst = max(vals) if fig.worst_is_max else min(vals)
    return round(statistics.median(vals), 3), round(worst, 3)


@dataclass
class MonitoringCost:
    """Duration with monitoring on minus off, over the seeds run both ways (seconds)."""

    seeds: list[int]
    delta_s: list[float]
    off_collisions: int

    @property
    def median_s(self) -> float | None:
        """Median extra time with monitoring."""
        return round(float(statistics.median(self.delta_s)), 2) if self.delta_s else None

    @property
    def worst_s(self) -> float | None:
        """Largest extra time with monitoring."""
        return round(max(self.delta_s), 2) if self.delta_s else None


@dataclass
class SeedStudy:
    """All runs of ``compare --seeds``, with the per-scenario statistics."""

    scenarios: list[str]
    seeds: list[int]
    monitoring: str
    runs: list[SeedRun]
    cost_runs: list[SeedRun] = field(default_factory=list)

    def of(self, scenario: str, *, cost: bool = False) -> list[SeedRun]:
        """The runs of a scenario (``cost``: the monitoring-off ones)."""
        return [r for r in (self.cost_runs if cost else self.runs) if r.scenario == scenario]

    def statistics(self, scenario: str, *, cost: bool = False) -> dict[str, dict[str, float | None]]:
        """{figure: {"median", "worst"}} of a scenario."""
        runs = self.of(scenario, cost=cost)
        out = {}
        for f in FIGURES:
            med, worst = median_worst(runs, f)
            out[f.key] = {"median": med, "worst": worst}
        return out

    def monitoring_cost(self, scenario: str) -> MonitoringCost | None:
        """Duration with monitoring minus without, seed by seed (None: no monitoring-off runs)."""
        off = {r.seed: r for r in self.of(scenario, cost=True)}
        if not off:
            return None
        seeds, delta = [], []
        for r in self.of(scenario):
            o = off.get(r.seed)
            if o is None or not (r.counted and o.counted) or (r.installed != o.installed):
                continue  # compare like with like: the same elements installed both ways
            seeds.append(r.seed)
            delta.append(round(60.0 * (float(r.figures["duration_min"] or 0.0)
                                       - float(o.figures["duration_min"] or 0.0)), 2))
        return MonitoringCost(seeds, delta, sum(len(o.collisions) for o in off.values()))

    def collisions(self, *, cost: bool = False) -> list[tuple[SeedRun, dict[str, Any]]]:
        """Every collision event of the runs, with its run."""
        return [(r, c) for r in (self.cost_runs if cost else self.runs) for c in r.collisions]

    def incomplete(self) -> list[SeedRun]:
        """The runs (monitoring as asked) that did not install every element."""
        return [r for r in self.runs if r.installed < r.elements or not r.elements]


def run_seeds(
    project_dir: Path,
    scenarios: Sequence[str],
    seeds: Sequence[int],
    stage: Path,
    *,
    monitoring: str = "ssm",
    reactive_workers: bool = True,
    cost_seeds: Sequence[int] = (),
    progress: Say | None = None,
    line: Say | None = None,
    max_elements: int | None = None,
    jobs_n: int = 1,
) -> SeedStudy:
    """Simulate every scenario for every seed into ``stage`` (see module docstring).

    ``jobs_n`` > 1 runs that many simulations at a time, each in its own process (spawned, so that each
    has its own PyBullet and store); every run is seeded on its own, so its outputs are the same as in
    a serial study, and the study is assembled in job order.
    """
    say = progress or (lambda _m: None)
    tell = line or (lambda _m: None)
    # seed by seed, each scenario, then its monitoring-off runs: a study stopped early (its runs are in
    # DIR.partial, see benchmarks/seed_summary_of_runs.py) still holds whole seeds
    cost = list(cost_seeds) if monitoring != "off" else []
    jobs: list[tuple[str, int, str]] = []
    for s in [*seeds, *[c for c in cost if c not in seeds]]:
        jobs += [(n, s, monitoring) for n in scenarios] if s in seeds else []
        jobs += [(n, s, "off") for n in scenarios] if s in cost else []
    study = SeedStudy(list(scenarios), list(seeds), monitoring, [])
    rels = [f"{n}/seed-{s}" + ("-monitoring-off" if m != monitoring else "") for n, s, m in jobs]
    if jobs_n > 1 and len(jobs) > 1:
        _run_parallel(project_dir, jobs, rels, stage, jobs_n, reactive_workers, max_elements, tell)
    else:
        loaded: dict[str, ProjectData] = {}
        for i, ((name, seed, mon), rel) in enumerate(zip(jobs, rels, strict=True), start=1):
            if name not in loaded:
                loaded[name] = ProjectData.load(project_dir, scenario=name)
            tell(f"[{i}/{len(jobs)}] {name}, seed {seed}, monitoring {mon}: simulating")
            _simulate_one(project_dir, name, seed, mon, stage / rel, reactive_workers, max_elements,
                          project=loaded[name], progress=say)
            tell(f"[{i}/{len(jobs)}] " + _run_line(name, seed, mon, stage / rel))
    # in job order whatever order the runs finished in: the outputs do not depend on --jobs
    for (name, seed, mon), rel in zip(jobs, rels, strict=True):
        run = SeedRun.of(name, seed, mon, RunRecord.load(stage / rel), rel)
        (study.cost_runs if mon != monitoring else study.runs).append(run)
    return study


def _simulate_one(project_dir: Path, name: str, seed: int, mon: str, out: Path, reactive_workers: bool,
                  max_elements: int | None, *, project: ProjectData | None = None,
                  progress: Say | None = None) -> None:
    """One run of the study: the pipeline's simulate step with the study's settings."""
    from kbplanner.simulation.skills import ExecSettings

    settings = ExecSettings(keyframes=False, monitoring=mon, reactive_workers=reactive_workers)
    simulate_scenario(project_dir, name, seed=seed, out_dir=out, progress=progress or (lambda _m: None),
                      project=project, settings=settings, max_elements=max_elements)


def _run_line(name: str, seed: int, mon: str, out: Path) -> str:
    """The progress line of a finished run: installed, duration, separation, collisions."""
    run = SeedRun.of(name, seed, mon, RunRecord.load(out), out.name)
    sep = run.figures.get("min_separation_m")
    return (f"{name}, seed {seed}, monitoring {mon}: installed {run.installed}/{run.elements}, "
            f"{run.figures['duration_min']:.2f} min, min separation "
            f"{'-' if sep is None else f'{sep:.2f} m'}, {len(run.collisions)} collision(s)")


_WORKER_PROJECTS: dict[str, ProjectData] = {}


def _worker_run(project_dir: Path, name: str, seed: int, mon: str, out: Path, reactive_workers: bool,
                max_elements: int | None) -> str:
    """A run in a worker process: the scenario's project is loaded once per process."""
    if name not in _WORKER_PROJECTS:
        _WORKER_PROJECTS[name] = ProjectData.load(project_dir, scenario=name)
    _simulate_one(project_dir, name, seed, mon, out, reactive_workers, max_elements,
                  project=_WORKER_PROJECTS[name])
    return _run_line(name, seed, mon, out)


def _run_parallel(project_dir: Path, jobs: list[tuple[str, int, str]], rels: list[str], stage: Path,
                  jobs_n: int, reactive_workers: bool, max_elements: int | None, tell: Say) -> None:
    """The study's runs in ``jobs_n`` spawned processes; a line per run as each finishes."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=jobs_n, mp_context=ctx) as pool:
        futures = {pool.submit(_worker_run, project_dir, n, s, m, stage / rel, reactive_workers,
                               max_elements): rel for (n, s, m), rel in zip(jobs, rels, strict=True)}
        tell(f"{len(jobs)} runs, {jobs_n} at a time")
        for done, fut in enumerate(as_completed(futures), start=1):
            tell(f"[{done}/{len(jobs)}] " + fut.result())


def study_of_runs(run_dirs: Sequence[Path], root: Path) -> SeedStudy:
    """A study from run directories already written (``compare --seeds`` runs, or ``simulate --seed N``
    runs): scenario and seed from each ``manifest.json``, monitoring from ``metrics.json``; the
    monitoring most runs used is the study's, runs with monitoring off besides it are the cost runs."""
    recs = [(d, RunRecord.load(d)) for d in sorted(run_dirs)]
    mons = [str(r.metrics.get("safety", {}).get("monitoring", "ssm")) for _, r in recs]
    main = "ssm" if "ssm" in mons else "off"
    study = SeedStudy([], [], main, [])
    for (d, rec), mon in zip(recs, mons, strict=True):
        name = rec.scenario or d.name
        seed = int(rec.manifest.get("seed", 0))
        run = SeedRun.of(name, seed, mon, rec, d.relative_to(root).as_posix() if d.is_relative_to(root)
                         else str(d))
        (study.runs if mon == main else study.cost_runs).append(run)
        if name not in study.scenarios:
            study.scenarios.append(name)
        if mon == main and seed not in study.seeds:
            study.seeds.append(seed)
    study.runs.sort(key=lambda r: (study.scenarios.index(r.scenario), r.seed))
    study.cost_runs.sort(key=lambda r: (study.scenarios.index(r.scenario), r.seed))
    study.seeds.sort()
    return study
