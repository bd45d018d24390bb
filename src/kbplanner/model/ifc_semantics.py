"""IFC import, semantics: what an IFC product is and what it is made of (helpers of ``ifc_import``).

Takes ifcopenshell entities and returns plain values: the kbplanner class of a product (by the IFC
schema's inheritance), whether a wall is external and how that was decided, the material names, a
density assumed from material keywords, and masses or volumes given by quantity sets. Nothing here
writes RDF or touches geometry.
"""

from __future__ import annotations

import re
from collections import defaultdict
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import ifcopenshell
import ifcopenshell.util.element
from rdflib import URIRef

from kbplanner.core.vocab import KBP

# IFC entity -> kbplanner class, most specific first; ``is_a`` follows the schema's inheritance, so
# IfcWallStandardCase is a wall and IfcFurniture (IFC4) a furnishing element.
IFC_CLASS_MAP: tuple[tuple[str, URIRef], ...] = (
    ("IfcOpeningElement", KBP.Opening),
    ("IfcWall", KBP.Wall),
    ("IfcDoor", KBP.Door),
    ("IfcWindow", KBP.Window),
    ("IfcSlab", KBP.Slab),
    ("IfcRoof", KBP.Roof),
    ("IfcFurnishingElement", KBP.Furniture),
    ("IfcStair", KBP.Stair),
    ("IfcStairFlight", KBP.Stair),
    ("IfcColumn", KBP.Column),
    ("IfcBeam", KBP.Beam),
    ("IfcMember", KBP.Member),
    ("IfcCovering", KBP.Covering),
    ("IfcRailing", KBP.Railing),
    ("IfcFooting", KBP.Footing),
)

# Products imported as elements: every IfcElement except these (not physical).
NON_PHYSICAL_ELEMENTS: tuple[str, ...] = ("IfcVirtualElement",)


def kbp_class(product: Any) -> URIRef:
    """The kbplanner class of an IFC element, ``KBP.OtherElement`` when none fits."""
    for ifc_name, cls in IFC_CLASS_MAP:
        if product.is_a(ifc_name):
            return cls
    return KBP.OtherElement


def is_imported_element(product: Any) -> bool:
    """True for the products the import turns into elements (physical IfcElements and openings)."""
    return bool(product.is_a("IfcElement")) and not any(product.is_a(n) for n in NON_PHYSICAL_ELEMENTS)


# ---------------------------------------------------------------------------------------------
# Property and quantity sets


@dataclass(frozen=True)
class PropertySets:
    """A product's property and quantity sets by name (its type's first, then its own), and problems.

    A set without a Name (valid in IFC2X3, written by ArchiCAD among others) is kept under
    ``"(unnamed #<step id>)"``, so two unnamed sets never merge and names stay strings; a set whose
    contents cannot be read is left out and named in ``problems``.
    """

    sets: dict[str, dict[str, Any]]
    problems: tuple[str, ...]


def _set_name(definition: Any) -> str:
    name = getattr(definition, "Name", None)
    return str(name) if name else f"(unnamed #{definition.id()})"


def _definitions(product: Any) -> list[Any]:
    found: list[Any] = []
    element_type = ifcopenshell.util.element.get_type(product) if not product.is_a("IfcTypeObject") else None
    if element_type is not None:
        found.extend(getattr(element_type, "HasPropertySets", None) or ())
    for rel in getattr(product, "IsDefinedBy", None) or ():
        if not rel.is_a("IfcRelDefinesByProperties"):
            continue
        definition = rel.RelatingPropertyDefinition
        if definition is None:
            continue
        if definition.is_a("IfcPropertySetDefinitionSet"):  # IFC4: a list of sets
            found.extend(definition.wrappedValue)
        else:
            found.append(definition)
    return found


def property_sets(product: Any) -> PropertySets:
    """Property and quantity sets of a product (occurrence values override its type's)."""
    sets: dict[str, dict[str, Any]] = {}
    problems: list[str] = []
    for definition in _definitions(product):
        name = _set_name(definition)
        try:
            values = ifcopenshell.util.element.get_property_definition(definition)
        except Exception as exc:  # a malformed set (missing values, unknown entity) must not stop the import
            problems.append(f"{definition.is_a()} {name} unreadable ({type(exc).__name__}: {exc})")
            continue
        if isinstance(values, dict):
            sets.setdefault(name, {}).update({str(k): v for k, v in values.items() if k is not None})
    return PropertySets(sets, tuple(problems))


# ---------------------------------------------------------------------------------------------
# Is a wall external?

_EXTERNAL_WORDS = re.compile(r"\b(exterior|external|facade|façade|outer|outside|aussen|außen|ext\.)",
                             re.IGNORECASE)
_INTERNAL_WORDS = re.compile(r"\b(interior|internal|partition|inner|inside|innen|party wall|int\.)",
                             re.IGNORECASE)

SOURCE_PSET = "Pset_WallCommon.IsExternal"
SOURCE_BOUNDARIES = "space boundaries"
SOURCE_NAME = "name"
SOURCE_DEFAULT = "default"


@dataclass(frozen=True)
class ExternalDecision:
    """Whether an element is external, and how that was decided (``kbp:isExternalSource``)."""

    is_external: bool
    source: str


def space_boundary_index(ifc_file: ifcopenshell.file) -> dict[int, set[str]]:
    """For each building element id, the set of InternalOrExternalBoundary values of its boundaries."""
    index: dict[int, set[str]] = defaultdict(set)
    for rel in ifc_file.by_type("IfcRelSpaceBoundary"):
        element = rel.RelatedBuildingElement
        kind = rel.InternalOrExternalBoundary
        if element is not None and kind:
            index[element.id()].add(str(kind))
    return index


def _type_name(product: Any) -> str:
    element_type = ifcopenshell.util.element.get_type(product)
    return str(element_type.Name) if element_type is not None and element_type.Name else ""


def _naming_text(product: Any) -> str:
    parts = [product.Name or "", getattr(product, "ObjectType", None) or "", _type_name(product)]
    return " ".join(str(p) for p in parts if p)


def decide_wall_external(
    wall: Any, psets: Mapping[str, Mapping[str, Any]], boundaries: Mapping[int, set[str]]
) -> ExternalDecision:
    """Pset_WallCommon.IsExternal, else space boundaries, else the wall's names, else internal.

    Space boundaries: any EXTERNAL* boundary makes the wall external; only INTERNAL ones make it
    internal. Names: Name, ObjectType and the type's name are searched for words such as
    "exterior"/"facade"/"aussen" or "interior"/"partition"/"innen"; a name with both kinds of word
    decides nothing.
    """
    value = psets.get("Pset_WallCommon", {}).get("IsExternal")
    if isinstance(value, bool):
        return ExternalDecision(value, SOURCE_PSET)
    kinds = boundaries.get(wall.id(), set())
    if any(k.startswith("EXTERNAL") for k in kinds):
        return ExternalDecision(True, SOURCE_BOUNDARIES)
    if "INTERNAL" in kinds:
        return ExternalDecision(False, SOURCE_BOUNDARIES)
    text = _naming_text(wall)
    ext, inner = bool(_EXTERNAL_WORDS.search(text)), bool(_INTERNAL_WORDS.search(text))
    if ext != inner:
        return ExternalDecision(ext, SOURCE_NAME)
    return ExternalDecision(False, SOURCE_DEFAULT)


def class_chain(product: Any) -> list[str]:
    """The product's IFC class and its supertypes, most specific first (IfcWallStandardCase, IfcWall, ...)."""
    schema = ifcopenshell.ifcopenshell_wrapper.schema_by_name(product.is_a(True).split(".")[0])
    declaration: Any = schema.declaration_by_name(product.is_a())
    names: list[str] = []
    while declaration is not None:
        names.append(str(declaration.name()))
        declaration = declaration.supertype()
    return names


def common_pset_external(product: Any, psets: Mapping[str, Mapping[str, Any]]) -> ExternalDecision | None:
    """``IsExternal`` of a ``Pset_*Common`` (doors, windows, slabs, ...), when one states it.

    The common set of the product's own class (or nearest superclass) is preferred: a slab that is
    part of a roof may carry both Pset_SlabCommon and Pset_RoofCommon.
    """
    own = [f"Pset_{name[3:]}Common" for name in class_chain(product)]
    others = sorted(n for n in map(str, psets)
                    if n.startswith("Pset_") and n.endswith("Common") and n not in own)
    for name in (*own, *others):
        value = psets.get(name, {}).get("IsExternal")
        if isinstance(value, bool):
            return ExternalDecision(value, f"{name}.IsExternal")
    return None


# ---------------------------------------------------------------------------------------------
# Materials, densities and quantities

# Keyword -> assumed density (kg/m3); the first keyword found in a material name wins, so the more
# specific words come first ("Concrete Block" is block, "Insulation / Thermal Barriers" insulation).
DENSITY_TABLE: tuple[tuple[str, float], ...] = (
    ("air", 1.2),
    ("insulation", 30.0),
    ("mineral wool", 30.0),
    ("membrane", 1100.0),
    ("barrier", 1000.0),
    ("stud", 450.0),
    ("plasterboard", 800.0),
    ("gypsum", 800.0),
    ("drywall", 800.0),
    ("plaster", 1200.0),
    ("brick", 1900.0),
    ("block", 1400.0),
    ("cmu", 1400.0),
    ("grout", 2100.0),
    ("mortar", 2100.0),
    ("concrete", 2400.0),
    ("steel", 7850.0),
    ("metal", 7850.0),
    ("alumin", 2700.0),
    ("glass", 2500.0),
    ("glazing", 2500.0),
    ("ceramic", 2000.0),
    ("tile", 2000.0),
    ("stone", 2600.0),
    ("granite", 2700.0),
    ("plywood", 550.0),
    ("osb", 600.0),
    ("sheathing", 550.0),
    ("lumber", 450.0),
    ("timber", 450.0),
    ("spf", 450.0),
    ("wood", 450.0),
    ("grass", 1600.0),
    ("soil", 1600.0),
    ("earth", 1600.0),
    ("asphalt", 2300.0),
    ("bitumen", 1050.0),
)


def density_of(material_name: str) -> tuple[float, str] | None:
    """Assumed density (kg/m3) of a material from the keyword table, with the keyword that matched."""
    lowered = material_name.lower()
    for keyword, density in DENSITY_TABLE:
        if re.search(r"\b" + re.escape(keyword), lowered):
            return density, keyword
    return None


def material_names(product: Any) -> list[str]:
    """Names of the product's materials (own or inherited from its type), in set order, deduplicated."""
    names: list[str] = []
    for material in ifcopenshell.util.element.get_materials(product):
        name = getattr(material, "Name", None)
        if name and name not in names:
            names.append(str(name))
    return names


@dataclass(frozen=True)
class DensityAssumption:
    """A density (kg/m3) and the text that says how it was obtained."""

    density: float
    text: str


def _layers(product: Any) -> list[Any] | None:
    material = ifcopenshell.util.element.get_material(product)
    if material is None:
        return None
    if material.is_a("IfcMaterialLayerSetUsage"):
        material = material.ForLayerSet
    if material.is_a("IfcMaterialLayerSet"):
        return list(material.MaterialLayers)
    return None


def assumed_density(product: Any, length_scale: float) -> DensityAssumption | None:
    """Density of a product from its materials, or None when any material is unknown.

    Layered products (walls, slabs) get the layer-thickness-weighted mean of their layers; a single
    material or several unlayered materials (all with the same density) give that density.
    """
    layers = _layers(product)
    if layers:
        parts: list[tuple[str, float, float]] = []
        for layer in layers:
            thickness = float(layer.LayerThickness or 0.0) * length_scale
            if thickness <= 0.0:
                continue
            name = getattr(layer.Material, "Name", None) if layer.Material is not None else None
            found = density_of(name) if name else None
            if found is None:
                return None
            parts.append((str(name), found[0], thickness))
        total = sum(t for _, _, t in parts)
        if total <= 0.0:
            return None
        density = sum(d * t for _, d, t in parts) / total
        detail = ", ".join(f"{n} {d:g} x {t:.3f} m" for n, d, t in parts)
        return DensityAssumption(density, f"layer-thickness-weighted density of {detail}")
    names = material_names(product)
    if not names:
        return None
    found_all = [density_of(n) for n in names]
    if any(f is None for f in found_all):
        return None
    densities = {f[0] for f in found_all if f is not None}
    if len(densities) != 1:
        return None
    density = densities.pop()
    return DensityAssumption(density, f"density of {', '.join(names)} ({density:g} kg/m3 assumed)")


def _quantities(psets: Mapping[str, Mapping[str, Any]], names: Iterable[str]) -> tuple[float, str] | None:
    for qto in sorted(psets, key=str):
        for quantity in names:
            value = (psets[qto] or {}).get(quantity)
            if isinstance(value, int | float) and not isinstance(value, bool) and value > 0:
                return float(value), f"{qto}.{quantity}"
    return None


def quantity_mass(qtos: Mapping[str, Mapping[str, Any]], mass_scale: float) -> tuple[float, str] | None:
    """Mass (kg) from NetWeight, else GrossWeight, of the product's quantity sets."""
    found = _quantities(qtos, ("NetWeight",)) or _quantities(qtos, ("GrossWeight",))
    if found is None:
        return None
    return found[0] * mass_scale, found[1]


def quantity_volume(qtos: Mapping[str, Mapping[str, Any]], volume_scale: float) -> tuple[float, str] | None:
    """Volume (m3) from NetVolume, else GrossVolume, of the product's quantity sets."""
    found = _quantities(qtos, ("NetVolume",)) or _quantities(qtos, ("GrossVolume",))
    if found is None:
        return None
    return found[0] * volume_scale, found[1]
