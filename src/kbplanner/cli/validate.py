"""``kbplanner validate PROJECT``: validate the (augmented) 4D model with SHACL (A4, A5).

Checks the well-formedness shapes of ``shapes/`` and the requirement shapes generated from the
knowledge base. Exit code 0 when the model conforms, 1 when it does not (the readable list is
printed), 2 on bad input. ``--report FILE`` writes the standard SHACL report as Turtle, or the
readable text when FILE ends in ``.txt``; ``--bcf FILE`` one BCF topic per non-conforming IFC element.
``--scenario all`` validates every scenario of ``project.toml`` in turn (the model as it will be simulated):
exit 0 when each conforms. Without ``--scenario`` the bare model is validated: its violations are the
additional modeling requirements that the scenarios' overlays are meant to meet.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from kbplanner.cli import EXIT_NEGATIVE, EXIT_OK
from kbplanner.cli.arguments import check_out_file
from kbplanner.core.store_spec import add_store_argument


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("validate", help="validate the 4D model and its augmentation with SHACL (A4)")
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--scenario",
                   help="scenario overlay to apply, or 'all' for every scenario of project.toml in turn "
                   "(default: the bare model)")
    add_store_argument(p)
    p.add_argument("--report", metavar="FILE", type=Path,
                   help="write the SHACL report (Turtle), or the text report if FILE ends in .txt")
    p.add_argument("--well-formedness-only", action="store_true",
                   help="skip the generated requirement shapes (check only shapes/*.ttl)")
    p.add_argument("--bcf", metavar="FILE", type=Path,
                   help="write one BCF topic per non-conforming IFC element (a .bcfzip)")
    p.add_argument("--bcf-version", choices=("2.1", "3.0"), default="3.0", help="BCF version (default 3.0)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from kbplanner.knowledge.validation import validate_model
    from kbplanner.project import Project

    check_out_file(args.report, "--report")
    if args.scenario == ALL:
        return _run_all(args)
    project = Project.load(args.project, scenario=args.scenario, store=args.store)
    result = validate_model(project.model, project.kb, include_requirements=not args.well_formedness_only)
    sys.stdout.write(result.text())
    if args.report is not None:
        result.write(args.report)
        sys.stderr.write(f"wrote report {args.report}\n")
    if args.bcf is not None:
        from kbplanner.cli.bcf_files import write_validation_bcf  # bcf-client: only when asked

        write_validation_bcf(project, result, args.bcf, args.bcf_version)
    if not result.conforms and args.scenario is None and project.manifest.scenarios:
        names = list(project.manifest.scenarios)
        sys.stderr.write(
            f"This was the bare model, without a scenario; {args.project} has {len(names)} scenario(s) "
            f"({', '.join(names)}), whose overlays (storages, pickup locations, grasp points) may meet "
            f"these requirements: kbplanner validate {args.project} --scenario {names[0]}"
            " (or --scenario all)\n")
    return EXIT_OK if result.conforms else EXIT_NEGATIVE


ALL = "all"


def _run_all(args: argparse.Namespace) -> int:
    """``--scenario all``: each scenario of the project validated in turn; exit 0 when every one conforms."""
    from kbplanner.core.errors import KbplannerError
    from kbplanner.knowledge.validation import validate_model
    from kbplanner.project import Project

    bare = Project.load(args.project, store=args.store)
    names = list(bare.manifest.scenarios)
    if ALL in names:  # a scenario really named "all" is that scenario
        project = Project.load(args.project, scenario=ALL, store=args.store)
        result = validate_model(project.model, project.kb, include_requirements=not args.well_formedness_only)
        sys.stdout.write(result.text())
        return EXIT_OK if result.conforms else EXIT_NEGATIVE
    if not names:
        raise KbplannerError(f"{args.project} has no scenarios, so --scenario all has nothing to validate",
                             file=Path(args.project) / "project.toml",
                             fix="validate the bare model (leave out --scenario) or add a [scenarios] entry")
    if args.report is not None or args.bcf is not None:
        raise KbplannerError("--report and --bcf write the result of one model, not of every scenario",
                             fix=f"name one scenario: --scenario {names[0]}")
    failed: list[str] = []
    for name in names:
        project = Project.load(args.project, scenario=name, store=args.store)
        result = validate_model(project.model, project.kb, include_requirements=not args.well_formedness_only)
        sys.stdout.write(f"== scenario {name}\n")
        sys.stdout.write(result.text())
        if not result.conforms:
            failed.append(name)
    verdict = (f"every scenario conforms ({', '.join(names)})" if not failed
               else f"{len(failed)} of {len(names)} scenario(s) do not conform: {', '.join(failed)}")
    sys.stdout.write(verdict + "\n")
    return EXIT_OK if not failed else EXIT_NEGATIVE
