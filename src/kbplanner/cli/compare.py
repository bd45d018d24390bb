"""``kbplanner compare PROJECT --scenarios A,B [--seed N | --seeds 1-20] --out DIR``: scenarios side by side.

With one seed: writes ``DIR/<scenario>/`` (each run), ``comparison.csv``, ``comparison.json``, the
simulated durations written back to the 4D model (``scenarios/<scenario>/results.ttl``,
``schedule_with_results.csv``) and ``report.html`` / ``report.md``.

With ``--seeds`` (``1-20``, ``1,3,5``, ``1-5,9``): runs each scenario for each seed into
``DIR/<scenario>/seed-<N>/`` (a line per run), then per scenario the median and worst case of minimum
separation, time below 1 m and below the ISO/TS 15066 protective separation distance, stops,
slow-downs, time lost to them, collisions and duration: ``seeds.csv``, ``seed_summary.csv``,
``seed_summary.json``, ``figures/seeds.png`` and ``summary.html`` / ``summary.md`` (does each scenario
still pay against the first?). ``--monitoring-cost [SEEDS]`` runs those seeds (default: all) again with
monitoring off, into ``DIR/<scenario>/seed-<N>-monitoring-off/``, and reports the time monitoring costs.
``--jobs N`` runs N simulations at a time (one process each; on 2 cores shared with other work
``--jobs 2`` took 0.69 of the serial time, docs/safety.md); every run is seeded on its own, so the
outputs do not depend on N.

Exit 0 when every element was installed in every run and no run had a collision; 1 otherwise (a
collision is listed with scenario, seed, time and worker; the runs with monitoring off for its cost do
not count); 2 on bad input (unknown scenario, bad seed list).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.cli.arguments import add_force, check_out, int_at_least, positive_float, seed_int, seed_list

if TYPE_CHECKING:
    from rich.console import Console


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "compare",
        help="simulate scenarios with the same seed and compare them (table + report)",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--scenarios", required=True, help="comma-separated scenario names, e.g. A,B")
    which = p.add_mutually_exclusive_group()
    which.add_argument("--seed", type=seed_int, help="random seed (default: [project] seed)")
    which.add_argument("--seeds", type=seed_list, metavar="SEEDS",
                       help="run every scenario for each of these seeds (1-20, 1,3,5): distributions")
    p.add_argument("--monitoring", choices=("ssm", "off"), default="ssm",
                   help="with --seeds: ISO/TS 15066 speed and separation monitoring (default ssm)")
    p.add_argument("--scripted-workers", action="store_true",
                   help="with --seeds: workers walk their routes without yielding")
    p.add_argument("--monitoring-cost", type=seed_list, nargs="?", const="all", metavar="SEEDS",
                   help="with --seeds: run these seeds (default: all) again with monitoring off and report "
                        "the time monitoring costs")
    p.add_argument("--jobs", type=int_at_least(1, 64), default=1, metavar="N",
                   help="with --seeds: run N simulations at a time, each in its own process (default 1; "
                        "the outputs are the same for any N)")
    p.add_argument("--threshold", type=positive_float,
                   help="proximity threshold in metres (default 1.0; with --seeds: the runs' 1 m)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="output folder: new, or one kbplanner wrote (replaced)")
    add_force(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from kbplanner.analysis.comparison import compare
    from kbplanner.cli.progress import status

    check_out(args.out)
    names = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    err = Console(stderr=True)
    if args.seeds is not None:
        if args.threshold is not None:
            sys.stderr.write("kbplanner compare: with --seeds the figures are the runs' metrics.json ones "
                             "(1 m threshold); drop --threshold\n")
            return 2
        return _run_seeds(args, names, err)
    seeds_only = (args.monitoring != "ssm", args.scripted_workers, args.monitoring_cost is not None,
                  args.jobs != 1)
    if any(seeds_only):
        sys.stderr.write("kbplanner compare: --monitoring, --scripted-workers, --monitoring-cost and --jobs "
                         "go with --seeds\n")
        return 2
    with status(err, "comparing") as say:
        comp, runs = compare(
            Path(args.project),
            names,
            out_dir=args.out,
            seed=args.seed,
            threshold_m=1.0 if args.threshold is None else args.threshold,
            progress=say,
        )
    sys.stdout.write(comp.text())
    sys.stdout.write(f"report: {Path(args.out) / 'report.html'}\n")
    return 0 if all(r.installed == r.elements for r in runs) else 1


def _run_seeds(args: argparse.Namespace, names: list[str], err: Console) -> int:
    from kbplanner.analysis.seed_report import compare_seeds
    from kbplanner.cli.progress import status

    cost = args.monitoring_cost
    if cost == "all":
        cost = list(args.seeds)
    if cost is not None and args.monitoring == "off":
        sys.stderr.write("kbplanner compare: --monitoring-cost compares with monitoring on; drop "
                         "--monitoring off\n")
        return 2
    with status(err, "comparing over seeds") as say:
        study, data = compare_seeds(
            Path(args.project), names, list(args.seeds), out_dir=args.out, monitoring=args.monitoring,
            reactive_workers=not args.scripted_workers, cost_seeds=cost, jobs_n=args.jobs,
            progress=say if err.is_terminal else None,  # plain logs: one line per run, not per step
            line=lambda m: err.print(m, highlight=False, markup=False, soft_wrap=True),
        )
    out = sys.stdout
    for name, entry in data["scenarios"].items():
        fig = entry["figures"]
        out.write(f"{name}: {entry['runs']} runs; duration median {fig['duration_min']['median']} min, "
                  f"worst {fig['duration_min']['worst']} min; min separation median "
                  f"{fig['min_separation_m']['median']} m, worst {fig['min_separation_m']['worst']} m; "
                  f"collisions {sum(len(r.collisions) for r in study.of(name))}\n")
        if "monitoring_cost_s" in entry:
            c = entry["monitoring_cost_s"]
            out.write(f"  time cost of monitoring: median {c['median']} s, worst {c['worst']} s over "
                      f"{len(c['seeds_compared'])} seed(s); {c['collisions_without_monitoring']} "
                      "collision(s) without monitoring\n")
    for v in data["versus"]:
        out.write(f"{v['scenario']} vs {v['against']}: {v['verdict']}\n")
    hits = data["collisions"]
    if hits:
        out.write(f"COLLISIONS: {len(hits)}\n")
        for c in hits:
            out.write(f"  {c['scenario']}, seed {c['seed']}: t = {c['t_s']} s, {c['worker']}: {c['cause']}\n")
    incomplete = study.incomplete()
    if incomplete:
        out.write("not every element installed: " + ", ".join(
            f"{r.scenario} seed {r.seed} ({r.installed}/{r.elements})" for r in incomplete) + "\n")
    out.write(f"summary: {Path(args.out) / 'summary.html'}\n")
    return 1 if hits or incomplete else 0
