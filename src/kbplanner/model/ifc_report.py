"""IFC import, report (last step of ``ifc_import``): what could not be used, and why.

Holds the records an import returns besides its graph: :class:`SkippedElement` (an element left out
of the graph, or in it without a part such as its geometry), :class:`ImportNote` (an element imported
with a doubt: a property set that could not be read, an implausible mass) and the rules that decide
whether a skipped element matters to tasks. Writes ``skipped.json`` and ``skipped.csv`` next to the
import. Masses are checked here: a mass that implies a density no building material has (below
10 kg/m3 or above 20 000 kg/m3), or without a volume below 0.5 kg or above 100 t, is reported with
the file's mass unit, the usual sign of a wrong MASSUNIT.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

# IFC classes robotized tasks and the world use (task elements, obstacles, floors, rooms): a skipped
# one makes ``kbplanner import-ifc`` exit 1. Furniture, openings, proxies and the like do not.
TASK_IFC_CLASSES: tuple[str, ...] = (
    "IfcWall", "IfcDoor", "IfcWindow", "IfcSlab", "IfcSpace", "IfcStair", "IfcStairFlight", "IfcRamp",
    "IfcRampFlight", "IfcMember", "IfcPlate", "IfcCovering", "IfcColumn", "IfcBeam", "IfcRoof",
    "IfcCurtainWall", "IfcBuildingStorey",
)

PLAUSIBLE_DENSITY_KG_M3 = (10.0, 20_000.0)
PLAUSIBLE_MASS_KG = (0.5, 100_000.0)

SKIPPED_JSON = "skipped.json"
SKIPPED_CSV = "skipped.csv"


def needed_by_tasks(product: Any) -> bool:
    """Whether an IFC entity is of a class tasks or the world use (see ``TASK_IFC_CLASSES``)."""
    return any(product.is_a(name) for name in TASK_IFC_CLASSES)


@dataclass(frozen=True)
class SkippedElement:
    """An element (or part of one) the import could not use, and why.

    ``in_graph`` True: the element is in the graph but without the part named by ``reason`` (its
    geometry, typically); False: the element is not in the graph at all. ``task_class``: the element
    is of a class tasks use (walls, doors, windows, slabs, spaces, ...).
    """

    global_id: str
    ifc_class: str
    name: str
    reason: str
    in_graph: bool = False
    task_class: bool = False


def skipped_of(product: Any, reason: str, *, in_graph: bool) -> SkippedElement:
    """The record of a product (an ifcopenshell entity) that was skipped for ``reason``."""
    name = str(getattr(product, "Name", None) or "")
    return SkippedElement(str(product.GlobalId or ""), product.is_a(), name, reason, in_graph,
                          needed_by_tasks(product))


@dataclass(frozen=True)
class ImportNote:
    """An element imported with a doubt the user should check (kind: "property-set", "mass")."""

    global_id: str
    ifc_class: str
    name: str
    kind: str
    message: str


def note_of(product: Any, kind: str, message: str) -> ImportNote:
    """The note about a product."""
    return ImportNote(str(product.GlobalId or ""), product.is_a(), str(getattr(product, "Name", None) or ""),
                      kind, message)


def mass_doubt(mass_kg: float, volume_m3: float | None, mass_unit: str) -> str | None:
    """Why a mass read from a quantity set is implausible, or None when it is plausible."""
    if volume_m3 is not None and volume_m3 > 1e-6:
        density = mass_kg / volume_m3
        lo, hi = PLAUSIBLE_DENSITY_KG_M3
        if not lo <= density <= hi:
            return (f"mass {mass_kg:.4g} kg over volume {volume_m3:.4g} m3 implies {density:.4g} kg/m3, "
                    f"which no building material has (the file's mass unit is the {mass_unit}): "
                    "check the IfcProject's MASSUNIT or the quantity values")
        return None
    lo, hi = PLAUSIBLE_MASS_KG
    if not lo <= mass_kg <= hi:
        return (f"mass {mass_kg:.4g} kg is outside {lo:g}-{hi:g} kg for one element (the file's mass unit "
                f"is the {mass_unit}): check the IfcProject's MASSUNIT or the quantity values")
    return None


def blocking(skipped: Sequence[SkippedElement]) -> list[SkippedElement]:
    """The skipped elements that make an import a negative result: those of task classes."""
    return [s for s in skipped if s.task_class]


def skipped_json(skipped: Sequence[SkippedElement], notes: Sequence[ImportNote]) -> bytes:
    """skipped.json: every skipped element and every note, sorted, deterministic."""
    data = {
        "skipped": [asdict(s) for s in skipped],
        "notes": [asdict(n) for n in notes],
        "blocking": len(blocking(skipped)),
        "rule": "import-ifc exits 1 when a skipped element is of a class tasks use: "
                + ", ".join(TASK_IFC_CLASSES),
    }
    return (json.dumps(data, indent=2, sort_keys=True, ensure_ascii=False) + "\n").encode()


def skipped_csv(skipped: Sequence[SkippedElement], notes: Sequence[ImportNote]) -> bytes:
    """skipped.csv: one row per skipped element (kind "skipped" / "no part") and per note."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["global_id", "ifc_class", "name", "kind", "task_class", "reason"])
    for s in skipped:
        kind = "in graph, part missing" if s.in_graph else "skipped"
        writer.writerow([s.global_id, s.ifc_class, s.name, kind, "yes" if s.task_class else "no", s.reason])
    for n in notes:
        writer.writerow([n.global_id, n.ifc_class, n.name, f"note: {n.kind}", "", n.message])
    return out.getvalue().encode()
