"""Scenario sweeps (analysis, after B5), step 1: the ``--vary`` axes and the variants they give.

``parse_vary`` reads ``--vary AXIS=VALUES`` options (``storage``, ``seed``, ``start``) into
:class:`SweepAxes`; ``parse_storage`` reads one storage candidate (a scenario name, ``X,Y[,YAW]``, or
``grid:STEP``); :class:`Variant` is one combination of them. Bad syntax is a :class:`SweepError`
naming the option and the fix.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from kbplanner.core.errors import KbplannerError

AXES = ("storage", "seed", "start")


class SweepError(KbplannerError):
    """A sweep that cannot be set up: bad ``--vary`` syntax, an unknown scenario, a missing extra."""


@dataclass(frozen=True)
class StorageCandidate:
    """A storage location to try: a named scenario, or the base storage moved to x, y (m), yaw (rad)."""

    label: str
    scenario: str | None = None
    x: float | None = None
    y: float | None = None
    yaw: float | None = None  # None: keep the base storage's yaw

    @property
    def moved(self) -> bool:
        """True for a moved storage, False for a named scenario."""
        return self.scenario is None


@dataclass(frozen=True)
class Variant:
    """One variant of the project: its id, scenario, storage candidate, seed and start time."""

    id: str
    scenario: str
    storage: StorageCandidate | None
    seed: int
    start: str  # HH:MM
    start_offset_s: float


@dataclass(frozen=True)
class SweepAxes:
    """The parsed ``--vary`` values (raw storage candidates, seeds, start times)."""

    storage: tuple[str, ...] = ()
    seed: tuple[int, ...] = ()
    start: tuple[str, ...] = ()


def _bad_vary(text: str, why: str, fix: str) -> SweepError:
    return SweepError(f"bad --vary {text!r}: {why}", element=text, fix=fix)


def parse_vary(texts: Sequence[str]) -> SweepAxes:
    """Parse ``--vary AXIS=VALUES`` options (``storage=...``, ``seed=1,2``, ``start=07:00,10:00``).

    Example:
        >>> parse_vary(["seed=1,2", "storage=1,2;grid:2"]).storage
        ('1,2', 'grid:2')
    """
    storage: list[str] = []
    seeds: list[int] = []
    starts: list[str] = []
    for text in texts:
        axis, sep, values = text.partition("=")
        axis = axis.strip()
        if not sep or axis not in AXES:
            raise _bad_vary(text, f"expected AXIS=VALUES with AXIS one of {', '.join(AXES)}",
                            "write e.g. --vary storage=12.0,-16.0 --vary seed=1,2 --vary start=07:00,10:00")
        if not values.strip():
            raise _bad_vary(text, f"no values for {axis}", f"give at least one value after {axis}=")
        if axis == "storage":
            for cand in values.split(";"):
                if cand.strip():
                    storage.append(cand.strip())
        elif axis == "seed":
            for v in values.split(","):
                try:
                    seeds.append(int(v.strip()))
                except ValueError:
                    raise _bad_vary(text, f"seed {v.strip()!r} is not an integer",
                                    "write --vary seed=1,2,3") from None
        else:
            for v in values.split(","):
                clock_s(v.strip(), text)
                starts.append(v.strip())
    return SweepAxes(tuple(storage), tuple(dict.fromkeys(seeds)), tuple(dict.fromkeys(starts)))


def clock_s(value: str, text: str) -> float:
    hh, sep, mm = value.partition(":")
    if not sep or not hh.isdigit() or not mm.isdigit() or int(mm) > 59 or int(hh) > 23:
        raise _bad_vary(text, f"start time {value!r} is not HH:MM", "write --vary start=07:00,10:30")
    return int(hh) * 3600.0 + int(mm) * 60.0


def parse_storage(value: str, scenarios: Iterable[str]) -> StorageCandidate | float:
    """A storage candidate: a scenario name, ``X,Y[,YAW]``; or the step (m) of ``grid:STEP``."""
    known = set(scenarios)
    if value in known:
        return StorageCandidate(label=value, scenario=value)
    if value.startswith("grid:"):
        try:
            step = float(value[5:])
        except ValueError:
            step = -1.0
        if not step > 0 or not math.isfinite(step):
            raise _bad_vary(f"storage={value}", "grid step must be a positive number of metres",
                            "write --vary storage=grid:2.0")
        return step
    parts = value.split(",")
    try:
        nums = [float(p) for p in parts]
    except ValueError:
        nums = []
    if len(nums) not in (2, 3) or not all(math.isfinite(n) for n in nums):
        raise _bad_vary(f"storage={value}",
                        "a storage candidate is a scenario name, X,Y, X,Y,YAW or grid:STEP",
                        "use metres and radians in the site frame, e.g. storage=12.0,-16.0,1.5708; "
                        "scenarios: " + (", ".join(sorted(known)) or "none"))
    x, y = round(nums[0], 3), round(nums[1], 3)
    yaw = round(nums[2], 6) if len(nums) == 3 else None
    label = f"x{x:.2f}y{y:.2f}" + (f"r{yaw:.2f}" if yaw is not None else "")
    return StorageCandidate(label=label, x=x, y=y, yaw=yaw)
