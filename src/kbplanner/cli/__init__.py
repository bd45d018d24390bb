"""Command line (all steps): ``kbplanner <command> ...``, a thin layer over the Python API.

Exit codes: 0 success (and, for ``validate``, a conforming model); 1 a reported negative result
(``validate``: the model does not conform); 2 bad input or misuse (a bad path or number, an output
that the output rule refuses, an unusable file), printed as one message without a traceback
(docs/errors.md). Each command lives in its own module of this package and registers itself through
``register(subparsers)``; ``COMMANDS`` lists them in help order. Registering only builds argparse
options: a command module imports its heavy parts (rdflib, PyBullet, ...) inside its ``run`` function,
so that ``--help`` and ``--version`` start at once (``tests/test_startup.py`` checks it).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import logging
import os
import shlex
import sys
import typing
from collections.abc import Sequence

from kbplanner import __version__
from kbplanner.core.errors import KbplannerError
from kbplanner.core.output_dirs import output_options

EXIT_OK = 0
EXIT_NEGATIVE = 1
EXIT_BAD_INPUT = 2
NO_CACHE_ENV = "KBPLANNER_NO_CACHE"  # kbplanner.model.project_cache.NO_CACHE_ENV (not imported: start-up)

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
    "init",
    "generate_building",
    "sweep",
)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one message (and the fix), exit 2."""

    def error(self, message: str) -> typing.NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n  fix: see '{self.prog} --help'\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered command."""
    parser = _Parser(
        prog="kbplanner",
        description="Plan and simulate construction robot work inside a 4D BIM model.",
        epilog="Exit codes: 0 ok, 1 negative result (e.g. model does not conform), 2 bad input.",
    )
    parser.add_argument("--version", action="version", version=f"kbplanner {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    parser.add_argument("--no-cache", action="store_true",
                        help=f"load projects from their inputs, not the project cache ({NO_CACHE_ENV}=1)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        module = importlib.import_module(f"kbplanner.cli.{name}")
        module.register(sub)
    return parser


class _WarnOnce(logging.Filter):
    """Lets a warning through once per command: the same map warning, say, is logged each time a
    command builds that storey's map (init plans several proposals on it)."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: set[tuple[str, str]] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno != logging.WARNING:
            return True
        key = (record.name, record.getMessage())
        if key in self.seen:
            return False
        self.seen.add(key)
        return True


_WARN_ONCE = _WarnOnce()


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
    _WARN_ONCE.seen.clear()
    for handler in logging.getLogger().handlers:  # basicConfig's console handler (not a test's capture)
        if type(handler) is logging.StreamHandler and _WARN_ONCE not in handler.filters:
            handler.addFilter(_WARN_ONCE)
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_BAD_INPUT
    words = list(sys.argv[1:] if argv is None else argv)
    saved = os.environ.get(NO_CACHE_ENV)
    if args.no_cache:
        os.environ[NO_CACHE_ENV] = "1"
    try:
        with output_options(force=bool(getattr(args, "force", False)),
                            command=shlex.join(["kbplanner", *words])):
            return int(args.func(args))
    except KbplannerError as err:
        sys.stderr.write(f"kbplanner: error: {err}\n")
        return EXIT_BAD_INPUT
    except OSError as err:  # a path the operating system refuses (permissions, a full disk, ...)
        where = f"{err.filename}: " if err.filename is not None else ""
        sys.stderr.write(f"kbplanner: error: {where}{err.strerror or err}\n"
                         "  fix: check the path and its permissions\n")
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        sys.stderr.write("kbplanner: interrupted\n")
        return 130
    finally:
        if args.no_cache:  # main() may run in a longer process (tests, notebooks): leave it as found
            if saved is None:
                os.environ.pop(NO_CACHE_ENV, None)
            else:
                os.environ[NO_CACHE_ENV] = saved


def command_line() -> typing.NoReturn:
    """The ``kbplanner`` program (console script, ``python -m kbplanner``): :func:`main` with the
    process's arguments, then the process ends at once, without the interpreter's teardown.

    Every output is written (and installed) before :func:`main` returns; what a command loaded is
    not freed object by object: on a whole building (``kbplanner run`` of the 10 x 8 one, 1.7 GB,
    millions of graph objects) the teardown's collection and frees took ~7 s after the last line.
    The streams and log handlers are flushed first. :func:`main` itself returns (tests, notebooks).
    """
    code = main()
    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # a closed pipe: nothing more can be written
            stream.flush()
    os._exit(code)


if __name__ == "__main__":
    command_line()
