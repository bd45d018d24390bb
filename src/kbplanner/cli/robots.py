"""``kbplanner robots PROJECT --task ID``: which robots of the knowledge base can do a task (B3).

Lists every robot, fit or not, with every check and reason (capabilities, payload, doors, site
limits). Exit code 0 (an unfit robot is a result), 2 on bad input.
"""

from __future__ import annotations

import argparse
import json
import sys

from kbplanner.core.errors import KbplannerError
from kbplanner.core.tables import render
from kbplanner.knowledge.robot_selection import select_robots
from kbplanner.knowledge.task_specs import robotized_tasks
from kbplanner.project import Project


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("robots", help="assess every robot of the knowledge base for a robotized task (B3)")
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--scenario", help="scenario overlay to apply (default: the bare model)")
    p.add_argument("--task",
                   help="robotized task id (default: [simulation] task, else the only robotized task)")
    p.add_argument("--format", choices=("text", "table", "json"), default="text")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    project = Project.load(args.project, scenario=args.scenario)
    task = args.task or project.default_task()
    if task is None:
        ids = [t.task_id for t in robotized_tasks(project.model)]
        if len(ids) != 1:
            raise KbplannerError("choose a robotized task with --task", element=project.name,
                                 fix="robotized tasks: " + (", ".join(ids) or "none"))
        task = ids[0]
    sel = select_robots(project.model, project.kb, task, scenario=args.scenario)
    if args.format == "text":
        sys.stdout.write(sel.text())
    elif args.format == "table":
        sys.stdout.write(render(["robot", "verdict", "check", "reason"], sel.rows(), "table"))
    else:
        data = [{"robot": a.robot.label, "iri": str(a.robot.iri), "fit": a.fit, "urdf": a.robot.urdf,
                 "checks": [{"check": c.check, "ok": c.ok, "message": c.message} for c in a.checks]}
                for a in sel.assessments]
        sys.stdout.write(json.dumps({"task": sel.task.task_id, "specification": sel.spec.spec_id,
                                     "robots": data}, indent=2, allow_nan=False) + "\n")
    return 0
