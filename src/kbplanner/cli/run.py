"""``kbplanner run PROJECT --out DIR``: the main job, every step on every scenario, with a summary."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.cli.arguments import add_force, check_out, positive_int, seed_int

if TYPE_CHECKING:
    from rich.table import Table

    from kbplanner.pipeline import PipelineResult


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("run", help="the full pipeline on a project: requirements, validation, robots, "
                                   "world, for every scenario, into one run directory")
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--out", required=True,
                   help="run folder: new, or one kbplanner wrote (replaced when the run completes)")
    add_force(p)
    p.add_argument("--scenario", action="append", dest="scenarios",
                   help="only this scenario (repeatable; default: all)")
    p.add_argument("--seed", type=seed_int, help="random seed of the simulations (default: [project] seed)")
    p.add_argument("--no-simulation", action="store_true",
                   help="stop after the world (requirements, validation, robots, world only)")
    p.add_argument("--tasks", choices=("main", "all"), default="main",
                   help="simulate the [simulation] task only (main, default) or every robotized task of the "
                        "schedule, each in the world at its start (all: a whole building)")
    p.add_argument("--max-elements", type=positive_int, metavar="N",
                   help="simulate the first N elements of each task only (a quick look)")
    p.add_argument("--workers", type=positive_int, default=1,
                   help="local processes for --tasks all (default 1; the number of cores is a good choice)")
    p.set_defaults(func=run)


def summary_table(result: PipelineResult) -> Table:
    """The final summary as a rich table."""
    from rich.table import Table

    t = Table(title=f"kbplanner run: {result.project}")
    t.add_column("scenario")
    t.add_column("conforms")
    t.add_column("fit robots")
    t.add_column("world (static / at storage)")
    t.add_column("map cells")
    t.add_column("installed")
    for s in result.scenarios:
        t.add_row(s.name, "yes" if s.conforms else f"no ({s.violations})", ", ".join(s.fit_robots) or "none",
                  f"{s.world_static} / {s.world_task_elements}", f"{s.map_cells[1]} x {s.map_cells[0]}",
                  (f"{s.installed}/{s.elements}" + (f" ({s.tasks} tasks)" if s.tasks > 1 else ""))
                  if s.simulated else "not simulated")
    return t


def simulation_speed(result: PipelineResult) -> str:
    """The simulation stage's speed in words (``--tasks all``): simulated, wall and CPU seconds and the
    real-time factor of the stage and of each scenario (``run_timings.json``, ``simulation``)."""
    sim = result.simulation
    assert sim is not None
    t = sim.timing()
    lines = [f"Simulation of every task: {t['sim_time_s']:,.1f} s simulated in {t['wall_s']:.1f} s wall "
             f"({t['real_time_factor']}x real time) on {sim.workers} process(es), {t['cpu_s']:.1f} s CPU"]
    for name, sc in t["scenarios"].items():
        lines.append(f"  {name}: {sc['sim_time_s']:,.1f} s simulated, its last task done after "
                     f"{sc['wall_s']:.1f} s ({sc['real_time_factor']}x), {sc['cpu_s']:.1f} s CPU")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.table import Table

    from kbplanner.analysis.report import COMPARISON_COLUMNS
    from kbplanner.cli.progress import status
    from kbplanner.pipeline import run_pipeline

    check_out(args.out)
    err = Console(stderr=True)
    out = Console(width=max(Console().width, 150))
    with status(err, "starting") as say:
        result = run_pipeline(Path(args.project), Path(args.out), scenarios=args.scenarios,
                              say=say, simulate=not args.no_simulation, seed=args.seed,
                              tasks=args.tasks, workers=args.workers, max_elements=args.max_elements)
    out.print(f"Bare model: {result.requirements} additional modeling requirement(s) "
              f"covering {result.requirement_elements} element(s) (requirements.csv)")
    out.print(summary_table(result))
    if result.comparison is not None:
        comp = Table(title="scenarios side by side (same seed)")
        for c in COMPARISON_COLUMNS:
            comp.add_column(c)
        for row in result.comparison.rows():
            comp.add_row(*("" if v is None else str(v) for v in row))
        out.print(comp)
        out.print(f"Report: {result.out_dir / 'report.html'} (and report.md)")
    stages = Table(title="time per stage")
    stages.add_column("stage")
    stages.add_column("scenario")
    stages.add_column("seconds", justify="right")
    stages.add_column("peak MiB", justify="right")
    for tm in result.timings:
        stages.add_row(tm.stage, tm.scenario or "", f"{tm.seconds:.2f}", f"{tm.peak_rss_mb:.0f}")
    out.print(stages)
    if result.simulation is not None:
        out.print(simulation_speed(result))
    out.print(f"Total {result.seconds:.1f} s. Results in {result.out_dir}/")
    sys.stdout.flush()
    if not result.ok:
        sys.stderr.write(negative_result(result))
    return 0 if result.ok else 1


def negative_result(result: PipelineResult, shown: int = 20) -> str:
    """The ``Negative result`` lines of a run that did not install everything: per scenario that does
    not conform, its violations; per simulated scenario, each element not installed with its reason
    (from its ``simulation/metrics.json``; the first ``shown``, all are in the report)."""
    import json

    lines = []
    for s in result.scenarios:
        where = result.out_dir / "scenarios" / s.name
        if not s.conforms:
            lines.append(f"  {s.name}: the model does not conform ({s.violations} violation(s), "
                         f"{where / 'validation.txt'}): nothing simulated")
        elif s.simulated and s.installed < s.elements:
            lines.append(f"  {s.name}: {s.elements - s.installed} of {s.elements} element(s) not installed")
            metrics = where / "simulation" / "metrics.json"
            failed = ([e for e in json.loads(metrics.read_text(encoding="utf-8"))["per_element"]
                       if e["outcome"] != "installed"] if metrics.is_file() else [])
            for e in failed[:shown]:
                why = e["reason"] or "no reason"
                lines.append(f"    {e['label'] or e['global_id']}: {e['outcome']}: {why}")
            if len(failed) > shown:
                lines.append(f"    ... {len(failed) - shown} more in {metrics}")
    return ("Negative result: not every scenario installed every element (report.html says more):\n"
            + "\n".join(lines) + "\n")
