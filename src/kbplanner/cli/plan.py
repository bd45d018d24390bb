"""``kbplanner plan PROJECT [--task ID] [--robot R] [--scenario S] [--seed N] [--no-feasibility]
[--out DIR]``: the plan (B1-B3) and its feasibility (B4).

Plans a robotized task: its actions for every element in work order, each skill input fetched from
the model by SPARQL, effective parameters, and the robot chosen by the ranking of the robot
selection (B1-B3). Then, unless ``--no-feasibility``, B4 (:func:`kbplanner.planning.manipulation.refine_plan`,
the checks ``simulate`` relies on: stack, payload, base poses on the occupancy grid, inverse kinematics
of every arm pose, carry footprints), so "feasible" means installable. Prints a table (step, element,
action, skill, key inputs, feasible or why not), one verdict per element (installable, or the step,
the reason and the fix: :mod:`kbplanner.planning.feasibility`) and the robot selection; with ``--out``
writes ``plan.json`` and ``plan.ttl`` (the refined plan), ``feasibility.json`` (the verdicts),
``plan.png`` (the storey, every element installable or not) and one figure per infeasible element
(``infeasible-stepNNN-LABEL.png``: :mod:`kbplanner.analysis.plan_figures`), each atomically.

Exit codes: 0 every step is feasible; 1 the plan has infeasible steps (a result: missing model
information, no robot fits, an element that cannot be picked or installed; the plan is still printed
and written); 2 bad input (unknown task, robot or scenario, a broken knowledge base).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kbplanner.cli.arguments import add_force, check_out
from kbplanner.core.tables import render

if TYPE_CHECKING:
    from kbplanner.planning.feasibility import ElementVerdict
    from kbplanner.planning.plan_model import Plan
    from kbplanner.world.occupancy import OccupancyGrid
    from kbplanner.world.world_types import World

EXIT_FEASIBLE = 0
EXIT_INFEASIBLE = 1
MAX_REASONS = 12  # distinct infeasibility reasons printed; plan.json has all


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "plan", help="the action-level plan of a robotized task and its feasibility: steps, skill inputs, "
                     "robot (B1-B3), base and arm poses (B4)",
        description="Plan a robotized task (B1-B3): every action of its task specification for every "
                    "element, inputs fetched from the model, effective parameters, the chosen robot; then "
                    "check that every element can be picked and installed (B4, the checks simulate relies "
                    "on) and give each infeasible element its reason, a figure and a fix.",
        epilog="Exit codes: 0 every step feasible; 1 some step infeasible (the plan is still printed and "
               "written); 2 bad input (unknown task, robot or scenario).")
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--task", help="robotized task id (default: [simulation] task, or the only "
                                  "robotized task)")
    p.add_argument("--robot", help="robot id of the knowledge base, e.g. husky-ur5 (default: the first "
                                   "robot that fits, by the ranking)")
    p.add_argument("--scenario", help="scenario overlay to apply (default: the bare model)")
    p.add_argument("--date", help="date of the world that places the elements at their storage "
                                  "(default: [simulation] date, else the task's start)")
    p.add_argument("--seed", type=int, help="random seed of B4 (default: [project] seed of project.toml)")
    p.add_argument("--no-feasibility", action="store_true",
                   help="skip B4 (base and arm poses): only the action-level plan B1-B3")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="write plan.json, plan.ttl, feasibility.json and the figures into DIR (new, or one "
                        "kbplanner wrote)")
    add_force(p)
    p.set_defaults(func=run)


def _short(text: str) -> str:
    return text.rsplit("#", 1)[-1].rsplit("/", 1)[-1]


def _value(v: Any, box: bool = False) -> str:
    if box and isinstance(v, list) and len(v) == 6:  # a tool path box: min and max corner
        return "box (" + ", ".join(f"{float(a):.2f}" for a in v[:3]) + ") - (" + ", ".join(
            f"{float(a):.2f}" for a in v[3:]) + ")"
    if isinstance(v, list) and len(v) == 6 and all(isinstance(x, int | float) for x in v):
        x, y, z, _roll, _pitch, yaw = (float(a) for a in v)
        return f"({x:.2f}, {y:.2f}, {z:.2f}; yaw {yaw:.2f})"
    if isinstance(v, list):
        return "[" + ", ".join(f"{float(a):.2f}" for a in v) + "]"
    if isinstance(v, str) and "://" in v:
        return _short(v)
    return str(v)


def plan_rows(plan: Plan) -> list[tuple[Any, ...]]:
    """One row per step: step, element, action, skill, key inputs, feasible or the reason."""
    labels = {e.iri: e.label for e in plan.elements}
    rows = []
    for s in plan.steps:
        boxes = {s.roles.get("ToolPathRole")}
        inputs = "; ".join(f"{k} {_value(v, k in boxes)}" for k, v in s.inputs.items() if v != s.element)
        verdict = "yes" if s.feasible else f"NO: {s.reason}"
        rows.append((s.step, labels.get(s.element, _short(s.element)), f"{s.action_order} {s.action_label}",
                     s.skill_id, inputs, verdict))
    return rows


def plan_text(plan: Plan) -> str:
    """The readable plan: header, step table, infeasibility reasons, robot selection, notes."""
    chosen = f"{plan.robot_label} ({plan.robot_id}, {plan.robot_urdf})" if plan.robot_id else "none"
    out = [f"plan of task {plan.task_id} '{plan.task_label}' with {plan.spec_id} "
           f"({plan.scenario or 'bare model'}): {len(plan.elements)} elements, {len(plan.steps)} steps",
           f"robot: {chosen}",
           f"element order: {plan.order_rule}", ""]
    out.append(render(["step", "element", "action", "skill", "key inputs", "feasible"], plan_rows(plan),
                      "table").rstrip("\n"))
    bad = [s for s in plan.steps if not s.feasible]
    if bad:
        reasons: dict[str, int] = {}
        skipped = 0
        for s in bad:
            if (s.reason or "").startswith("skipped"):
                skipped += 1
                continue
            for r in (s.reason or "").split("; "):
                reasons[r] = reasons.get(r, 0) + 1
        out.append(f"\n{len(bad)} of {len(plan.steps)} steps are infeasible"
                   + (f" ({skipped} skipped after an infeasible step of their element)" if skipped else "")
                   + ":")
        listed = sorted(reasons.items())
        out.extend(f"  - {r}" + (f" (x{n})" if n > 1 else "") for r, n in listed[:MAX_REASONS])
        if len(listed) > MAX_REASONS:
            out.append(f"  ... and {len(listed) - MAX_REASONS} more (plan.json has every step's reason)")
    out.append("")
    out.append("robot selection (fit first, then smallest footprint, then largest payload margin):")
    for robot in plan.selection:
        verdict = ("fit" if robot["fit"] else "not fit") + (", chosen" if robot["chosen"] else "")
        out.append(f"  {robot['rank']}. {robot['robot_id']} ({robot['label']}): {verdict}")
        out.extend(f"       - {reason}" for reason in robot["reasons"])
    if plan.notes:
        out.append("\nnotes:")
        out.extend(f"  - {n}" for n in plan.notes)
    return "\n".join(out) + "\n"


def verdict_text(verdicts: list[ElementVerdict], figures: dict[str, str]) -> str:
    """One line per element (installable, or the step and the reason) with the fix and the figure."""
    from kbplanner.planning.feasibility import needs_figure

    bad = [v for v in verdicts if not v.feasible]
    out = [f"\nfeasibility (B4): {len(verdicts) - len(bad)} of {len(verdicts)} elements installable"]
    for v in verdicts:
        if v.feasible:
            out.append(f"  {v.label}: installable")
            continue
        out.append(f"  {v.label}: NOT installable, step {v.step} ({v.skill_id} {v.action}): {v.reason}")
        out.append(f"      fix: {v.fix}")
        if v.iri in figures:
            out.append(f"      figure: {figures[v.iri]}")
    if not figures and any(needs_figure(v) for v in bad):
        out.append("  (a figure per infeasible element: run again with --out DIR)")
    return "\n".join(out) + "\n"


def _refine(plan: Plan, world: World, grid: OccupancyGrid, seed: int, cache_dir: Path | None) -> Plan:
    """B4 with progress on stderr (a bar on a terminal, plain count lines otherwise)."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from kbplanner.cli.progress import plain_counter
    from kbplanner.planning.refine_cache import refine_kept
    from kbplanner.world.cspace_store import folder_for, kept_in

    console = Console(stderr=True)
    lines = plain_counter(console)
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True, disable=lines is not None) as bar:
        b4 = bar.add_task("B4 arm and base poses", total=len(plan.elements))

        def tell(_label: str, done: int, total: int) -> None:
            bar.update(b4, completed=done, total=total)
            if lines is not None:
                lines.count("B4 arm and base poses", done, total)

        with kept_in(folder_for(cache_dir)):  # B4's configuration spaces, kept beside the project cache
            return refine_kept(plan, world, seed=seed, grid=grid, progress=tell, cache_dir=cache_dir)


def run(args: argparse.Namespace) -> int:
    from kbplanner.analysis.plan_figures import element_figure, plan_overview
    from kbplanner.core.outputs import atomic_write_bytes, atomic_write_text, json_text, run_directory
    from kbplanner.model.dates import parse_date
    from kbplanner.planning.feasibility import element_verdicts, figure_name, needs_figure
    from kbplanner.planning.plan_rdf import plan_turtle
    from kbplanner.planning.planner import plan_task
    from kbplanner.planning.step_kinds import robot_name
    from kbplanner.planning.task_and_robot import resolve_task
    from kbplanner.project import Project
    from kbplanner.robot.robot_table import load_robot_specs
    from kbplanner.world import map_store
    from kbplanner.world.build import build_world
    from kbplanner.world.maps import storey_map

    check_out(args.out)
    at = parse_date(args.date) if args.date is not None else None  # checked before the project load
    project = Project.load(args.project, scenario=args.scenario)
    grid = world = None
    if args.no_feasibility:
        plan = plan_task(project, args.task, args.robot, at=at)
    else:
        task = resolve_task(project, args.task).task_id  # an unknown task: the planner's error (exit 2)
        world = build_world(project, at if at is not None else project.world_date(task), task)
        plan = plan_task(project, task, args.robot, world=world)
        if plan.robot_id:
            with map_store.kept_in(map_store.folder_for(project.cache_entry)):  # a map made before
                grid = storey_map(world).grid
            seed = args.seed if args.seed is not None else project.manifest.seed
            plan = _refine(plan, world, grid, seed, project.cache_entry)
    verdicts = element_verdicts(plan)
    figures: dict[str, bytes] = {}
    names: dict[str, str] = {}
    if args.out is not None and grid is not None and world is not None:
        spec = load_robot_specs().get(robot_name(plan))
        for v in verdicts:
            if needs_figure(v):
                names[v.iri] = figure_name(v)
                figures[names[v.iri]] = element_figure(grid, world, plan, v, spec)
        figures["plan.png"] = plan_overview(grid, world, plan, verdicts)
    text = plan_text(plan)
    if not args.no_feasibility:
        text += verdict_text(verdicts, {i: str(args.out / n) for i, n in names.items()} if args.out else {})
    if args.out is not None:
        js, ttl = plan.to_json(), plan_turtle(plan, project.kb)
        with run_directory(args.out) as stage:
            atomic_write_text(stage / "plan.json", js)
            atomic_write_text(stage / "plan.ttl", ttl)
            if not args.no_feasibility:
                atomic_write_text(stage / "feasibility.json", json_text(
                    {"elements": [dict(v.to_dict(), figure=names.get(v.iri)) for v in verdicts],
                     "installable": sum(1 for v in verdicts if v.feasible), "total": len(verdicts)},
                    name="feasibility.json") + "\n")
            for name, png in figures.items():
                atomic_write_bytes(stage / name, png)
        written = ["plan.json", "plan.ttl"] + (["feasibility.json"] if not args.no_feasibility else [])
        pngs = f" and {len(figures)} figure(s)" if figures else ""
        text += f"\nwrote {', '.join(written)}{pngs} to {args.out}\n"
    sys.stdout.write(text)
    return EXIT_FEASIBLE if plan.feasible else EXIT_INFEASIBLE
