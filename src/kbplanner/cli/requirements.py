"""``kbplanner requirements PROJECT``: the additional modeling requirements (A3) of a project.

Prints one row per requirement (``--format table``), one line per element (``csv``), the full
result (``json``) or RDF (``ttl``). ``--template FILE`` also writes a Turtle skeleton of exactly what is
missing; ``--ids FILE`` writes them as buildingSMART IDS and ``--augmented-ifc FILE`` (with
``--scenario``) an IFC with the values (:mod:`kbplanner.cli.ids_files`). Exit code 0 whether or not
requirements remain (they are a result); 2 on bad input.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.cli.arguments import check_out_file
from kbplanner.core.output_dirs import FILE_SIGNATURE
from kbplanner.core.store_spec import add_store_argument
from kbplanner.core.tables import render

if TYPE_CHECKING:
    from kbplanner.knowledge.requirements import RequirementsResult

FORMATS = ("table", "csv", "json", "ttl")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("requirements",
                       help="list the additional modeling requirements of the robotized tasks (A3)")
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--scenario", help="scenario overlay to apply (default: the bare model)")
    add_store_argument(p)
    p.add_argument("--task", help="only this robotized task id")
    p.add_argument("--format", choices=FORMATS, default="table")
    p.add_argument("--template", metavar="FILE", type=Path,
                   help="write a Turtle skeleton of what is missing (fill it in, add it to the project)")
    p.add_argument("--ids", metavar="FILE", type=Path,
                   help="write the requirements of the bare model as a buildingSMART IDS 1.0 file")
    p.add_argument("--augmented-ifc", metavar="FILE", type=Path,
                   help="with --scenario: a copy of the IFC with the IDS properties set from the scenario")
    p.set_defaults(func=run)


def format_result(result: RequirementsResult, fmt: str) -> str:
    """The result in one of ``FORMATS``."""
    from kbplanner.knowledge.requirements import RequirementsResult

    if fmt == "csv":
        return result.to_csv()
    if fmt == "json":
        return result.to_json()
    if fmt == "ttl":
        return str(result.to_graph().serialize(format="turtle"))
    if not result.requirements:
        return result.text()
    table = render(list(RequirementsResult.TABLE_COLUMNS), result.table_rows(), "table",
                   title=f"Additional modeling requirements ({len(result.requirements)})")
    met = [c for c in result.checks if c.unmet == 0]
    tail = "".join(f"already in the model: {c.task_id} action {c.action_order} {c.skill_id} "
                   f"'{c.input_name}' ({c.needs})\n" for c in met)
    return table + tail


def run(args: argparse.Namespace) -> int:
    from kbplanner.core.outputs import atomic_write_text
    from kbplanner.knowledge.requirements import derive_requirements
    from kbplanner.project import Project

    check_out_file(args.template, "--template")
    project = Project.load(args.project, scenario=args.scenario, store=args.store)
    result = derive_requirements(project.model, project.kb, task_id=args.task)
    if args.ids is not None or args.augmented_ifc is not None:
        from kbplanner.cli.ids_files import write_ids_files  # ifctester: only when asked

        write_ids_files(project, result, args.task, args.ids, args.augmented_ifc)
    sys.stdout.write(format_result(result, args.format))
    if args.template is not None:
        atomic_write_text(args.template, f"{FILE_SIGNATURE} requirements --template\n"
                          + result.template(project.base))
        sys.stderr.write(f"wrote template {args.template}\n")
    return 0
