"""Occupancy maps, levels (helper of ``exports``, A6 world): slabs and stairs at other heights than the floor.

Takes the static elements of a world, a storey's floor elevation and the map's height band, and
lists the floor-like elements that do not lie at the storey's floor: a split-level slab of this storey
whose top lies above the floor's step height but within the robot's band (a raised floor region: an
obstacle on this storey's map, the robot cannot climb it), the same for a slab of another storey (a
foundation level sees the ground floor's slabs so), a slab hanging into the band from above (an
overhead obstacle), a slab of this storey whose top lies more than the support depth below the
floor (a sunken region: no floor under the robot there on an upper storey), and stairs or ramps
within the band (obstacles). Nothing is changed on the map here: these are the reasons the map
shows what it shows, reported in the world's summary and ``world.json``.

Example:
    >>> classify(0.35, 0.80, floor=0.0, band=(0.05, 1.8), kind="Slab", own_storey=True)
    'raised floor'
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from kbplanner.world.world_types import WorldElement

FLOOR_KINDS = ("Slab", "Covering")
STAIR_KINDS = ("Stair", "Ramp")
SUPPORT_DEPTH_M = 0.3  # a floor's top within this depth below the storey level carries the robot

RAISED = "raised floor"
OTHER_STOREY = "another storey's floor"
OVERHEAD = "overhead slab"
SUNKEN = "sunken floor"
STAIR = "stair"


@dataclass(frozen=True)
class LevelRegion:
    """A floor-like element at another height than the storey's floor, and what it is on the map."""

    iri: str
    label: str
    kind: str
    role: str  # RAISED, OTHER_STOREY, OVERHEAD, SUNKEN or STAIR
    bottom_m: float  # relative to the storey's floor
    top_m: float
    area_m2: float  # of its box in plan

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields (rounded)."""
        return {"iri": self.iri, "label": self.label, "kind": self.kind, "role": self.role,
                "bottom_m": round(self.bottom_m, 3) + 0.0, "top_m": round(self.top_m, 3) + 0.0,
                "area_m2": round(self.area_m2, 2) + 0.0}

    def text(self) -> str:
        """One line for the command line."""
        return (f"{self.role}: {self.label} ({self.kind}, top {self.top_m:+.2f} m, "
                f"{self.area_m2:.1f} m2 in plan)")


def classify(zmin: float, zmax: float, *, floor: float, band: tuple[float, float], kind: str,
             own_storey: bool) -> str | None:
    """The role of a floor-like element with bottom ``zmin`` and top ``zmax`` (site z, m), or None."""
    top, bottom = zmax - floor, zmin - floor
    lo, hi = band[0] - floor, band[1] - floor
    if kind in STAIR_KINDS:
        return STAIR if zmax >= band[0] and zmin <= band[1] else None
    if kind not in FLOOR_KINDS:
        return None
    if lo < top <= hi:
        return RAISED if own_storey else OTHER_STOREY
    if top > hi and lo < bottom < hi:
        return OVERHEAD
    if own_storey and -hi <= top < -SUPPORT_DEPTH_M:
        return SUNKEN
    return None


def level_regions(elements: Sequence[WorldElement], storey_iri: str, floor: float,
                  band: tuple[float, float]) -> list[LevelRegion]:
    """The floor-like elements at other heights than the floor, sorted by role and label."""
    found: list[LevelRegion] = []
    for e in elements:
        if e.bounds is None:
            continue
        b = e.bounds
        own = e.storey == storey_iri
        role = classify(b.zmin, b.zmax, floor=floor, band=band, kind=e.kind, own_storey=own)
        if role is None:
            continue
        area = max(0.0, b.xmax - b.xmin) * max(0.0, b.ymax - b.ymin)
        found.append(LevelRegion(e.iri, e.label, e.kind, role, b.zmin - floor, b.zmax - floor, area))
    return sorted(found, key=lambda r: (r.role, r.label, r.iri))


def levels_summary(regions: Sequence[LevelRegion]) -> str:
    """"1 raised floor, 2 stair" (empty when there are none)."""
    counts: dict[str, int] = {}
    for r in regions:
        counts[r.role] = counts.get(r.role, 0) + 1
    return ", ".join(f"{n} {role}" for role, n in sorted(counts.items()))
