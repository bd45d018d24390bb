"""IFC import, opening (first step of ``ifc_import``): read an IFC file and its project units.

Takes a path and returns an open ``ifcopenshell.file`` (or raises :class:`IfcError` naming the file,
what is wrong with it and what to do), and the file's units as SI factors: metres per length unit,
cubic metres per volume unit and kilograms per mass unit, from the IfcUnitAssignment (SI units with
prefixes and conversion-based units such as the inch, foot or pound, via ``ifcopenshell.util.unit``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import ifcopenshell
import ifcopenshell.util.unit

from kbplanner.core.errors import IfcError

# ifcopenshell reads these; IFC4X3_ADD2 geometry was checked on files written by ifcopenshell.api.
SUPPORTED_SCHEMAS: tuple[str, ...] = ("IFC2X3", "IFC4", "IFC4X3_ADD2")

_EXPORT_FIX = "export the model again from the BIM authoring tool as IFC4 or IFC2X3 (.ifc, STEP format)"


# ---------------------------------------------------------------------------------------------
# Opening the file


def open_ifc(ifc_path: Path) -> ifcopenshell.file:
    """Open an IFC file, or raise :class:`IfcError` saying what is wrong with it and what to do.

    Example:
        >>> open_ifc(Path("/work/shared/data/ifc/Duplex_A_20110907.ifc")).schema
        'IFC2X3'
    """
    path = Path(ifc_path)
    if not path.exists():
        raise IfcError("IFC file not found", file=path,
                       fix="check the path of the IFC model (relative paths start in the current directory)")
    if not path.is_file():
        raise IfcError("not a file", file=path, fix="give the path of an .ifc file, not of a directory")
    try:
        with path.open("rb") as stream:
            head = stream.read(512)
            stream.seek(0, os.SEEK_END)
            size = stream.tell()
            stream.seek(max(0, size - 4096))
            tail = stream.read()
    except OSError as exc:
        raise IfcError(f"cannot read the file ({exc.strerror})", file=path,
                       fix="check the file's permissions") from None
    start = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if start.startswith(b"PK"):
        raise IfcError("this is a ZIP archive (ifcZIP), which is not read", file=path,
                       fix="unzip it and import the .ifc file inside")
    if start.startswith(b"<"):
        raise IfcError("this is XML (ifcXML), which is not read", file=path, fix=_EXPORT_FIX)
    if not start.upper().startswith(b"ISO-10303-21"):
        raise IfcError("not an IFC file (it does not start with an ISO-10303-21 STEP header)", file=path,
                       fix=_EXPORT_FIX)
    if b"END-ISO-10303-21" not in tail.upper():
        raise IfcError("the IFC file is incomplete (no END-ISO-10303-21; at its end)", file=path,
                       fix="copy or export the file again; this copy was cut off")
    try:
        ifc_file = ifcopenshell.open(str(path))
    except ifcopenshell.SchemaError as exc:
        schema = str(exc).rsplit(":", 1)[-1].strip()
        raise IfcError(f"unsupported IFC schema {schema}", file=path, element=schema,
                       fix=f"{_EXPORT_FIX}; kbplanner reads {', '.join(SUPPORTED_SCHEMAS)}") from None
    except Exception as exc:  # ifcopenshell raises plain Error/OSError for unparsable files
        raise IfcError(f"ifcopenshell cannot parse the file: {exc}", file=path, fix=_EXPORT_FIX) from None
    schema = str(ifc_file.schema_identifier)
    if schema not in SUPPORTED_SCHEMAS:
        raise IfcError(f"unsupported IFC schema {schema}", file=path, element=schema,
                       fix=f"{_EXPORT_FIX}; kbplanner reads {', '.join(SUPPORTED_SCHEMAS)}")
    return ifc_file


# ---------------------------------------------------------------------------------------------
# Units


@dataclass(frozen=True)
class UnitScales:
    """Factors from the file's units to metres, cubic metres and kilograms, and the units' names."""

    length_m: float
    volume_m3: float
    mass_kg: float
    length_name: str = "metre"
    mass_name: str = "kilogram"


def unit_name(unit: Any) -> str:
    """A readable name of an IFC unit entity: "millimetre", "gram", "pound", "inch"."""
    if unit is None:
        return ""
    if unit.is_a("IfcSIUnit"):
        prefix = str(unit.Prefix or "").lower()
        name = str(unit.Name or "").lower()
        return f"{prefix}{name}"
    if unit.is_a("IfcConversionBasedUnit"):
        return str(unit.Name or "conversion-based unit").lower()
    return str(unit.is_a())


def _scale(ifc_file: ifcopenshell.file, unit_type: str, what: str, source: Path | None) -> float:
    try:
        value = float(ifcopenshell.util.unit.calculate_unit_scale(ifc_file, unit_type))
    except Exception as exc:  # a malformed unit entity (no ConversionFactor, unknown prefix, ...)
        raise IfcError(f"cannot read the {what} unit: {type(exc).__name__}: {exc}", file=source,
                       element=unit_type, fix="correct the IfcUnitAssignment of the IfcProject, or "
                       + _EXPORT_FIX) from None
    if not (math.isfinite(value) and value > 0):
        raise IfcError(f"the {what} unit has a scale of {value}", file=source, element=unit_type,
                       fix="correct the IfcUnitAssignment of the IfcProject (a positive factor)")
    return value


def unit_scales(ifc_file: ifcopenshell.file, source: Path | None = None) -> UnitScales:
    """The file's project units as SI factors (IFC's default mass unit is the kilogram).

    Raises:
        IfcError: a unit whose scale cannot be read or is not a positive number.
    """
    length = _scale(ifc_file, "LENGTHUNIT", "length", source)
    volume = _scale(ifc_file, "VOLUMEUNIT", "volume", source)
    mass_unit = ifcopenshell.util.unit.get_project_unit(ifc_file, "MASSUNIT")
    # ifcopenshell measures masses in grams (the SI base unit is the gram, KILO its prefix).
    mass = _scale(ifc_file, "MASSUNIT", "mass", source) / 1000.0 if mass_unit is not None else 1.0
    length_unit = ifcopenshell.util.unit.get_project_unit(ifc_file, "LENGTHUNIT")
    return UnitScales(length, volume, mass, unit_name(length_unit) or "metre",
                      unit_name(mass_unit) or "kilogram")
