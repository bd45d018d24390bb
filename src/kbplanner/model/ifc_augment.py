"""Augmented IFC (A4 back to BIM authors): a copy of the project's IFC with the robot-task properties set.

The IDS mapping of :mod:`kbplanner.knowledge.ids_export` says which property of the property set
``Kbplanner_RobotTaskInputs`` holds which value of the augmented RDF model (a scenario's overlays).
``write_augmented_ifc`` reads those values from the graph and writes them with ``ifcopenshell.api``
(``pset.add_pset`` / ``pset.edit_pset``) into a copy of the IFC; the input file is never changed. An IFC
written this way passes the IDS where the RDF model passes the SHACL requirements. Elements the IDS
names that are missing from the IFC or lack a value in the graph are listed, never skipped silently.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import ifcopenshell
import ifcopenshell.api
from rdflib import Graph, Literal
from rdflib.term import Node

from kbplanner.core.errors import IfcError
from kbplanner.core.outputs import atomic_write_text
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.ids_export import PSET, IdsExport


@dataclass
class AugmentResult:
    """What :func:`write_augmented_ifc` wrote, and what it could not."""

    path: Path
    elements: int = 0
    properties: int = 0
    not_in_ifc: list[str] = field(default_factory=list)
    missing_values: list[str] = field(default_factory=list)


def element_iris(graph: Graph) -> dict[str, Node]:
    """GlobalId -> element node of a model graph."""
    return {str(gid): s for s, gid in graph.subject_objects(KBP.globalId) if isinstance(gid, Literal)}


def write_augmented_ifc(ifc_path: Path, out: Path, export: IdsExport, model: Graph) -> AugmentResult:
    """Write a copy of ``ifc_path`` to ``out`` with the IDS properties filled from ``model``."""
    try:
        f = ifcopenshell.open(str(ifc_path))
    except (OSError, RuntimeError) as exc:
        raise IfcError(f"cannot read the IFC file: {exc}", file=ifc_path,
                       fix="give a readable IFC2X3/IFC4 file") from exc
    values = export.values(model, element_iris(model))
    result = AugmentResult(path=out)
    done: set[str] = set()
    for spec in export.specs:
        for gid in spec.global_ids:
            try:
                product = f.by_guid(gid)
            except RuntimeError:
                result.not_in_ifc.append(gid)
                continue
            have = values.get(gid, {})
            props = {p.name: have[p.name] for p in spec.properties if p.name in have}
            result.missing_values.extend(f"{gid}: {p.name}" for p in spec.properties if p.name not in have)
            if not props:
                continue
            pset = _pset(f, product)
            ifcopenshell.api.run("pset.edit_pset", f, pset=pset, properties=props)
            done.add(gid)
            result.properties += len(props)
    result.elements = len(done)
    atomic_write_text(out, f.to_string())
    return result


def _pset(f: ifcopenshell.file, product: ifcopenshell.entity_instance) -> ifcopenshell.entity_instance:
    for rel in getattr(product, "IsDefinedBy", ()) or ():
        if rel.is_a("IfcRelDefinesByProperties"):
            d = rel.RelatingPropertyDefinition
            if d.is_a("IfcPropertySet") and d.Name == PSET:
                return d
    return ifcopenshell.api.run("pset.add_pset", f, product=product, name=PSET)
