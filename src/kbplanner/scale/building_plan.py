"""Test buildings (scale, issue 6), step 1: the plan of a generated building.

The dimensions of the generated residential building (storeys, units, corridor, core, wall
thicknesses, doors), the frame storages of the scenario, the schedule's start and names, the record
of one stud-frame panel (:class:`Panel`) and the seeded plan of each unit (where its partitions and
doors are). The IFC writer (:mod:`kbplanner.scale.building_ifc`), the geometry
(:mod:`kbplanner.scale.building_geometry`), the schedule (:mod:`kbplanner.scale.building_schedule`)
and the site files (:mod:`kbplanner.scale.building_site`) build on it;
:func:`kbplanner.scale.building_generator.generate_building` puts them together.
"""

from __future__ import annotations

import random
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import date

from kbplanner.core.errors import KbplannerError

MAX_STOREYS = 60
MAX_UNITS = 40

# Plan (metres, site frame = IFC world frame): units of UNIT_W x UNIT_D in a row along x from x = 0,
# a corridor of CORRIDOR_W on their north side, a core of CORE_W at the east end.
STOREY_HEIGHT = 3.0
SLAB_T = 0.2
WALL_HEIGHT = STOREY_HEIGHT - SLAB_T  # floor to the underside of the slab above
UNIT_W = 8.0
UNIT_D = 7.0
CORRIDOR_W = 2.0
CORE_W = 6.0
EXT_T = 0.3  # facades (body inside the footprint)
PARTY_T = 0.2  # party, corridor and lift shaft walls (centred)
PARTITION_T = 0.1  # interior partitions (centred)
DOOR_W = 0.9
ENTRANCE_W = 1.2
UNIT_DOOR_W = 1.2
DOOR_H = 2.1

# Frame panels: kbplanner.model.stud_frames, as in the case study (data/case_study/tools/build_frames.py).
MAX_PANEL_LENGTH = 0.75  # keeps every panel between about 9 and 14 kg

# Frame storage in each unit's living room (bearers as in the case study) and the robot's pickup.
STORAGE_SIZE = (2.6, 0.8, 0.1)
PICKUP_STANDOFF = 1.15  # the Husky's half length + a cell of margin clear of the bearers
STORAGE_FROM_WEST = 0.9  # storage centres, metres east of the unit's west wall axis
STORAGE_YS = (2.0, 4.8)  # two stacks per unit, along the living room's west wall
MAX_STACK = 8  # frames per stack: the top frame stays within the arm's reach (case study: 11 x 89 mm)

START_DATE = date(2024, 3, 4)  # a Monday: week 0 (mobilisation)
SCENARIO = "storage-in-units"
FRAMING_SPEC = "I-W-F-#1"


class GeneratorError(KbplannerError):
    """Bad arguments for the building generator, or an output directory that cannot be used."""


@dataclass(frozen=True)
class Panel:
    """One stud-frame panel: where it stands and what it weighs (metres, radians, kilograms)."""

    panel_id: str
    global_id: str
    storey: int  # 1-based
    unit: int  # 1-based
    wall: str  # GlobalId of the host partition
    sequence: int  # install order within the storey's framing task (1 = first)
    unit_order: int  # install order within the unit (1 = first)
    x: float
    y: float
    z: float
    yaw: float
    length: float
    studs: int
    volume_m3: float
    mass_kg: float
    centre_of_mass_local: tuple[float, float, float]


@dataclass(frozen=True)
class UnitPlan:
    """Where the partitions and doors of one unit are (unit-local x from the unit's west axis)."""

    p1_x: float  # north-south partition (living room | bedrooms)
    p2_y: float  # east-west partition between the two bedrooms
    unit_door_x: float  # start of the unit door along the corridor wall
    door_s: float  # start of the south bedroom door along P1 (from its south end)
    door_n: float  # start of the north bedroom door along P1


def unit_plans(storeys: int, units: int, seed: int) -> dict[tuple[int, int], UnitPlan]:
    """The plan of every unit, by (storey, unit) from 0; seed 0 gives the same plan everywhere."""
    rng = random.Random(seed)
    out = {}
    for k in range(storeys):
        for j in range(units):
            if seed == 0:
                p1, p2, ud, ds, dn = 4.0, 3.5, 2.2, 1.2, 4.6
            else:
                p1 = 4.0 + rng.choice((-0.2, -0.1, 0.0, 0.1, 0.2))
                p2 = 3.5 + rng.choice((-0.3, -0.15, 0.0, 0.15, 0.3))
                ud = 2.2 + rng.choice((0.0, 0.2, 0.4))
                ds = 1.2 + rng.choice((-0.2, 0.0, 0.2))
                dn = 4.6 + rng.choice((-0.2, 0.0, 0.2))
            out[(k, j)] = UnitPlan(p1, p2, ud, ds, dn)
    return out


def segments(length: float, cuts: Iterable[tuple[float, float]]) -> list[tuple[float, float]]:
    """Free lengths of a wall axis ``[0, length]`` between door cuts."""
    out, start = [], 0.0
    for a, b in sorted(cuts):
        if a > start + 1e-9:
            out.append((start, a))
        start = max(start, b)
    if start < length - 1e-9:
        out.append((start, length))
    return out
