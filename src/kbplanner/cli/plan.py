"""``kbplanner plan PROJECT [--task ID] [--robot R] [--scenario S] [--out DIR]``: the plan (B1-B3).

Plans a robotized task: its actions for every element in work order, each skill input fetched from
the model by SPARQL, effective parameters, and the robot chosen by the ranking of the robot
selection. Prints a table (step, element, action, skill, key inputs, feasible or why not) and the
robot selection; with ``--out`` writes ``plan.json`` and ``plan.ttl`` (each atomically).

Exit codes: 0 every step is feasible; 1 the plan has infeasible steps (a result: missing model
information, or no robot fits; the plan is still printed and written); 2 bad input (unknown task,
robot or scenario, a broken knowledge base).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kbplanner.cli.arguments import add_force, check_out
from kbplanner.core.tables import render

if TYPE_CHECKING:
    from kbplanner.planning.plan_model import Plan

EXIT_FEASIBLE = 0
EXIT_INFEASIBLE = 1
MAX_REASONS = 12  # distinct infeasibility reasons printed; plan.json has all


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "plan", help="the action-level plan of a robotized task: steps, skill inputs, robot (B1-B3)",
        description="Plan a robotized task (B1-B3): every action of its task specification for every "
                    "element, inputs fetched from the model, effective parameters, the chosen robot.",
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
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="write plan.json and plan.ttl into DIR (new, or one kbplanner wrote)")
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
        for s in bad:
            for r in (s.reason or "").split("; "):
                reasons[r] = reasons.get(r, 0) + 1
        out.append(f"\n{len(bad)} of {len(plan.steps)} steps are infeasible:")
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


def run(args: argparse.Namespace) -> int:
    from kbplanner.core.outputs import atomic_write_text, run_directory
    from kbplanner.model.dates import parse_date
    from kbplanner.planning.plan_rdf import plan_turtle
    from kbplanner.planning.planner import plan_task
    from kbplanner.project import Project

    check_out(args.out)
    at = parse_date(args.date) if args.date is not None else None  # checked before the project load
    project = Project.load(args.project, scenario=args.scenario)
    plan = plan_task(project, args.task, args.robot, at=at)
    text = plan_text(plan)
    if args.out is not None:
        js, ttl = plan.to_json(), plan_turtle(plan, project.kb)
        with run_directory(args.out) as stage:
            atomic_write_text(stage / "plan.json", js)
            atomic_write_text(stage / "plan.ttl", ttl)
        text += f"\nwrote plan.json and plan.ttl to {args.out}\n"
    sys.stdout.write(text)
    return EXIT_FEASIBLE if plan.feasible else EXIT_INFEASIBLE
