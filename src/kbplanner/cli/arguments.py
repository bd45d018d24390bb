"""Command line (all steps): shared options, the numeric rule for flags, and the output rule up front.

Every number given on the command line is checked where it is read, by the argument types below: finite
and in its range, else argparse's one-line error and exit 2. ``--out`` folders and output files are
checked by the output rule (:mod:`kbplanner.core.output_dirs`) before any work starts.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path

from kbplanner.core.output_dirs import check_output_dir, check_output_file

SEED_MAX = 2**32 - 1  # numpy's and PyBullet's seeds are 32-bit


def _int(text: str) -> int:
    try:
        return int(text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None


def int_at_least(low: int, high: int | None = None) -> Callable[[str], int]:
    """An argparse type: a whole number from ``low`` (to ``high``)."""
    def parse(text: str) -> int:
        value = _int(text)
        if value < low or (high is not None and value > high):
            top = f" to {high}" if high is not None else " or more"
            raise argparse.ArgumentTypeError(f"{value} is out of range: give {low}{top}")
        return value

    parse.__name__ = "whole number"
    return parse


positive_int = int_at_least(1)
seed_int = int_at_least(0, SEED_MAX)


def finite_float(low: float = 0.0, *, inclusive: bool = False) -> Callable[[str], float]:
    """An argparse type: a finite number above ``low`` (or at least ``low`` when ``inclusive``)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text} is not a finite number")
        if value < low or (value == low and not inclusive):
            bound = f">= {low:g}" if inclusive else f"> {low:g}"
            raise argparse.ArgumentTypeError(f"{value:g} is out of range: give a number {bound}")
        return value

    parse.__name__ = "number"
    return parse


positive_float = finite_float(0.0)


def add_force(p: argparse.ArgumentParser) -> None:
    """``--force``: write into an existing folder of other files (they are kept; a clash stops the run)."""
    p.add_argument("--force", action="store_true",
                   help="write into an existing folder that kbplanner did not write; files in it are "
                        "kept (kbplanner never deletes a file it did not write)")


def check_out(path: Path | str | None, option: str = "--out") -> None:
    """The output rule for an ``--out`` folder, before any work (None: no output asked)."""
    if path is not None:
        check_output_dir(Path(path), option=option)


def check_out_file(path: Path | str | None, option: str) -> None:
    """The output rule for a single output file (``--report``, ``--template``)."""
    if path is not None:
        check_output_file(Path(path), option=option)


SEEDS_MAX = 1000  # runs per scenario of one --seeds


def seed_list(text: str) -> list[int]:
    """An argparse type: seeds as ranges and lists, ``1-20``, ``1,3,5`` or ``1-5,9`` (in the order given).

    Each seed is a whole number from 0 to ``SEED_MAX``; a range runs upwards; a seed may not repeat.

    Example:
        >>> seed_list("1-3,7")
        [1, 2, 3, 7]
    """
    seeds: list[int] = []
    parts = [p.strip() for p in text.split(",")]
    if not text.strip() or any(not p for p in parts):
        raise argparse.ArgumentTypeError(f"{text!r} is not a seed list: give e.g. 1-20 or 1,3,5")
    for part in parts:
        lo_text, sep, hi_text = part.partition("-")
        if sep and not lo_text.strip():
            raise argparse.ArgumentTypeError(f"{part!r}: seeds are whole numbers from 0 to {SEED_MAX}")
        lo = seed_int(lo_text.strip())
        hi = seed_int(hi_text.strip()) if sep else lo
        if hi < lo:
            raise argparse.ArgumentTypeError(f"{part!r} runs downwards: give the smaller seed first")
        if len(seeds) + hi - lo + 1 > SEEDS_MAX:
            raise argparse.ArgumentTypeError(f"{text!r} gives more than {SEEDS_MAX} seeds")
        seeds.extend(range(lo, hi + 1))
    repeated = sorted({s for s in seeds if seeds.count(s) > 1})
    if repeated:
        raise argparse.ArgumentTypeError(f"{text!r} repeats seed(s) {repeated}: give each seed once")
    return seeds
