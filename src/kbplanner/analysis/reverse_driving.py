"""Analysis of a simulation run: how far the robot's base drives backwards.

Reads ``trajectories.csv`` of a run directory and sums the distance driven with the direction of travel
more than 90 degrees off the base's yaw (backwards, towards the scanner's blind sector behind the base),
the whole distance driven, and how much of the backward distance is driven while an element is carried.
Only the recorded trajectory is read (no planner or simulation code): an independent check of the
base's motion, shared by ``benchmarks/reverse_driving.py`` and the tests.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

MIN_MOVE_M = 1e-6  # a sample-to-sample move shorter than this is standing still
BACKWARD_COS = -0.01  # backwards: the travel's component along the yaw below this fraction of its length


@dataclass(frozen=True)
class Move:
    """A move between two consecutive trajectory rows."""

    row: Mapping[str, str]  # the row it starts from (its yaw is the base's heading)
    length_m: float
    backward: bool


def moves(rows: Iterable[Mapping[str, str]]) -> Iterator[Move]:
    """The moves between consecutive rows (``x``, ``y``, ``yaw`` columns) longer than ``MIN_MOVE_M``."""
    prev: Mapping[str, str] | None = None
    for row in rows:
        if prev is not None:
            dx, dy = float(row["x"]) - float(prev["x"]), float(row["y"]) - float(prev["y"])
            d = math.hypot(dx, dy)
            if d > MIN_MOVE_M:
                yaw = float(prev["yaw"])
                yield Move(prev, d, dx * math.cos(yaw) + dy * math.sin(yaw) < BACKWARD_COS * d)
        prev = row


def reverse_of(run: Path) -> dict[str, float | str]:
    """Backward, carried-backward and whole distance (m) driven in one run directory."""
    back = carried = total = 0.0
    with (run / "trajectories.csv").open(newline="") as fh:
        for m in moves(csv.DictReader(fh)):
            total += m.length_m
            if m.backward:
                back += m.length_m
                if m.row.get("carried"):
                    carried += m.length_m
    return {"run": str(run), "backward_m": round(back, 2), "backward_carrying_m": round(carried, 2),
            "driven_m": round(total, 2)}
