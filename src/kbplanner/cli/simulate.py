"""``kbplanner simulate PROJECT [--scenario S] [--seed N] [--task ID] [--robot R] [--max-elements N] ...``.

Builds the world at the project's ``[simulation] date``, the action-level plan (B1-B3,
:func:`kbplanner.planning.planner.plan_task`), refines it with arm and base poses (B4,
:func:`kbplanner.planning.manipulation.refine_plan`) and executes it in PyBullet (B5,
:func:`kbplanner.simulation.executor.simulate`), writing the run directory ``DIR`` atomically. Shows progress
over elements and steps and a summary table at the end. ``--max-elements N`` simulates the first N
elements of the plan's order only (a quick look; the elements left out are named on stderr).

Exit codes: 0 every element installed; 1 some element not installed (the reasons are in the table
and in ``DIR/metrics.json``), or no robot fits the task (nothing simulated); 2 bad input (unknown
project, scenario, task or robot, no ``[simulation] date``).
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable
from pathlib import Path

from kbplanner.cli.arguments import add_force, check_out, positive_int, seed_int

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "simulate",
        help="plan, refine and simulate the robotized task in PyBullet; write a run directory (B1-B5)",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--scenario", help="scenario overlay to apply (default: the bare model)")
    p.add_argument("--seed", type=seed_int, help="random seed (default: [project] seed of project.toml)")
    p.add_argument("--task", help="robotized task id (default: [simulation] task)")
    p.add_argument("--robot", help="robot id of the knowledge base (default: the first fitting one)")
    p.add_argument("--max-elements", type=positive_int, metavar="N",
                   help="simulate the first N elements of the task's order only (a quick look)")
    p.add_argument("--gui", action="store_true", help="show the PyBullet GUI when a display exists")
    p.add_argument("--no-keyframes", action="store_true", help="do not render key frame images")
    p.add_argument("--monitoring", choices=("ssm", "off"), default="ssm",
                   help="ISO/TS 15066 speed and separation monitoring (default ssm; off: what-if)")
    p.add_argument("--scripted-workers", action="store_true",
                   help="workers walk their routes without yielding (the old precomputed motions)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="run folder: new, or one kbplanner wrote (replaced)")
    p.add_argument("--mcap", type=Path, metavar="FILE", help="also write the run as MCAP (see export-mcap)")
    add_force(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TaskID, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from kbplanner.cli.progress import plain_counter
    from kbplanner.planning import refine_ahead
    from kbplanner.planning.plan_model import Plan
    from kbplanner.planning.planner import plan_task
    from kbplanner.planning.refine_cache import refine_kept
    from kbplanner.project import Project
    from kbplanner.simulation import early_builds
    from kbplanner.simulation.executor import INSTALLED, SimulationResult, simulate
    from kbplanner.simulation.skills import ExecSettings
    from kbplanner.world import map_store
    from kbplanner.world.build import build_world
    from kbplanner.world.cspace_store import folder_for, kept_in
    from kbplanner.world.maps import storey_map

    check_out(args.out)
    console = Console(stderr=True)
    project = Project.load(args.project, scenario=args.scenario)
    seed = args.seed if args.seed is not None else project.manifest.seed
    world = build_world(project, project.world_date(args.task), args.task)
    plan = plan_task(project, args.task, args.robot, world=world)
    if not plan.robot_id:
        reasons = sorted({s.reason or "" for s in plan.steps if not s.feasible})
        sys.stdout.write("no robot of the knowledge base fits the task; nothing simulated\n")
        for r in reasons[:5]:
            sys.stdout.write(f"  {r}\n")
        return 1
    if args.max_elements is not None and args.max_elements < len(plan.elements):
        left = [e.label or e.global_id for e in plan.elements[args.max_elements:]]
        console.print(f"--max-elements {args.max_elements}: simulating {args.max_elements} of "
                      f"{len(plan.elements)} elements; left out: {', '.join(left)}", highlight=False)
        plan.keep_first(args.max_elements)
    with map_store.kept_in(map_store.folder_for(project.cache_entry)):  # a map an earlier command made
        grid = storey_map(world).grid
    settings = ExecSettings(keyframes=not args.no_keyframes, monitoring=args.monitoring,
                            reactive_workers=not args.scripted_workers)
    # B4 in a second process while B5 runs (no refined plan kept); the workers' walking legs and the static
    # bodies then kept here before B5's first element, which waits for B4's first, else by a second
    # process while B4 runs (forked before the progress bar's thread starts; the step reads them as an
    # earlier run's; left alone on an error, the early process ends by itself)
    kept = folder_for(project.cache_entry)
    ahead = refine_ahead.start(plan, world, seed=seed, grid=grid, cache_dir=project.cache_entry, folder=kept)
    early = early_builds.start(project, world, grid, kept, reactive_workers=settings.reactive_workers) \
        if ahead is None else early_builds.EarlyBuilds()
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    lines = plain_counter(console)  # plain lines where stderr is no terminal (logs, nohup)
    try:
        with Progress(*columns, console=console, transient=False, disable=lines is not None) as bar:
            b4 = bar.add_task("B4 arm and base poses", total=len(plan.elements))

            def refined_one(_label: str, done: int, total: int) -> None:
                bar.update(b4, completed=done, total=total)
                if lines is not None:
                    lines.count("B4 arm and base poses", done, total)

            b5: list[TaskID] = []

            def tell(label: str, done: int, total: int) -> None:
                if ahead is not None:
                    ahead.poll()  # B4's progress, from its process
                if not b5:
                    b5.append(bar.add_task("B5 simulation", total=total))
                bar.update(b5[0], completed=done, total=total, description=f"B5 simulation: {label}")
                if lines is not None:
                    lines.count(f"B5 simulation: {label}", done, total)

            def run_b5(refined: Plan, ready: Callable[[str], None] | None = None) -> SimulationResult:
                if b5:
                    bar.reset(b5[0])
                return simulate(project, refined, seed=seed, out_dir=args.out, progress=tell, world=world,
                                grid=grid, settings=settings, gui=args.gui, ready=ready)

            result: SimulationResult | None = None
            refined: Plan | None = None
            if ahead is not None:  # B5 of element k once B4 (in its process) refined it
                ahead.progress = refined_one
                early_builds.build(project, world, grid, kept, reactive_workers=settings.reactive_workers)
                try:
                    result = run_b5(ahead.plan, ahead.ready)
                except refine_ahead.AheadDiffers as differs:  # B4's order feedback: B5 again, its plan
                    refined = differs.plan
                except refine_ahead.AheadFailed as exc:  # B4 again here: its error as the sequential path's
                    log.info("B4 ahead of B5 failed (%s): B4 then B5", exc)
                except Exception:  # B5's error; B4's first where B4 failed too (the sequential path's order)
                    why = ahead.b4_failed()
                    if why is None:
                        raise
                    log.info("B4 ahead of B5 failed (%s): B4 then B5", why)
            if result is None:
                if refined is None:
                    with kept_in(kept):  # B4's configuration spaces, kept beside the cache
                        refined = refine_kept(plan, world, seed=seed, grid=grid, progress=refined_one,
                                              cache_dir=project.cache_entry)  # B4, or an earlier run's
                result = run_b5(refined)
    finally:
        if ahead is not None:
            ahead.close()
    early.finish()  # (ended long before: its CPU counted with the command's)
    table = Table(title=f"{plan.task_id} ({plan.spec_id}) with {plan.robot_label or plan.robot_id}, "
                        f"{project.scenario or 'bare model'}, seed {seed}")
    for col in ("element", "outcome", "time (s)", "placement error", "reason"):
        table.add_column(col)
    for e in result.elements:
        err = (f"{1000 * e.placement_error_m:.1f} mm / {e.placement_error_deg:.2f} deg"
               if e.placement_error_m is not None and e.placement_error_deg is not None else "")
        table.add_row(e.label, e.outcome, f"{e.duration_s:.1f}", err, e.reason or "")
    out = Console(width=160)
    out.print(table)
    totals = result.metrics["totals"]
    out.print(f"installed {totals['installed']} of {totals['elements']}; simulated {result.sim_time_s:.1f} s "
              f"in {result.wall_time_s:.1f} s wall; {totals['stops']} safety stop(s); wrote "
              f"{len(result.files)} files to {args.out}")
    if args.mcap is not None:
        from kbplanner.cli.export_mcap import report, write_run_mcap

        report(write_run_mcap(args.out, args.mcap, grid=grid, start=project.world_date(args.task)))
    safety = result.metrics["safety"]
    if safety["collisions"]:
        out.print(f"COLLISIONS: {safety['collisions']} contact event(s) between the robot and a worker "
                  "(events.jsonl, kind 'collision')")
    out.print(f"safety: min. separation {safety['min_separation_m']} m, {safety['time_below_1m_s']} "
                  f"s below 1 m, "
              f"{safety['time_below_protective_s']} s below S_p, {safety['slowdowns']} slow-down(s), "
              f"{safety['time_lost_s']} s lost to monitoring ({safety['monitoring']})")
    if safety.get("workers_off_robot_floor"):
        out.print(f"safety: {safety['workers_off_robot_floor']} worker(s) on another floor than the robot "
                  f"({safety['dz_m']} m apart): out of its hazard scope")
    if safety["collisions"]:
        return 1
    return 0 if all(e.outcome == INSTALLED for e in result.elements) and result.elements else 1
