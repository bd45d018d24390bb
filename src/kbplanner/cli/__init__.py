"""Command line (all steps): ``kbplanner <command> ...``, a thin layer over the Python API.

Exit codes: 0 success (and, for ``validate``, a conforming model); 1 a reported negative result
(``validate``: the model does not conform); 2 bad input or misuse, printed as one message without
a traceback. Each command lives in its own module of this package and registers itself through
``register(subparsers)``; ``COMMANDS`` lists them in help order.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

from kbplanner import __version__
from kbplanner.core.errors import KbplannerError

EXIT_OK = 0
EXIT_NEGATIVE = 1
EXIT_BAD_INPUT = 2

# Modules of kbplanner.cli, each with ``register(subparsers)`` setting ``func(args) -> int``.
COMMANDS: tuple[str, ...] = (
    "info",
    "query",
    "import_ifc",
    "requirements",
    "validate",
    "robots",
    "world",
    "plan",
    "simulate",
    "compare",
    "report",
    "export_mcap",
    "run",
    "generate_building",
    "sweep",
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered command."""
    parser = argparse.ArgumentParser(
        prog="kbplanner",
        description="Plan and simulate construction robot work inside a 4D BIM model.",
        epilog="Exit codes: 0 ok, 1 negative result (e.g. model does not conform), 2 bad input.",
    )
    parser.add_argument("--version", action="version", version=f"kbplanner {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        module = importlib.import_module(f"kbplanner.cli.{name}")
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (see module docstring)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: 0 for --help/--version, 2 for usage errors
        return int(exc.code or 0)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_BAD_INPUT
    try:
        return int(args.func(args))
    except KbplannerError as err:
        sys.stderr.write(f"kbplanner: error: {err}\n")
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        sys.stderr.write("kbplanner: interrupted\n")
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
