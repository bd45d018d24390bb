"""IDS and augmented IFC files of ``kbplanner requirements`` (A3/A4 for BIM authors; not a command).

``--ids FILE`` writes the additional modeling requirements of the bare model as buildingSMART IDS 1.0
(:mod:`kbplanner.knowledge.ids_export`); ``--augmented-ifc FILE`` (with ``--scenario``) writes a copy of
the project's IFC with the IDS's properties filled from the scenario's overlays
(:mod:`kbplanner.model.ifc_augment`).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from kbplanner.core.errors import ProjectError
from kbplanner.knowledge.ids_export import IFC_VERSIONS, IdsExport, ids_export
from kbplanner.knowledge.requirements import RequirementsResult, derive_requirements
from kbplanner.knowledge.validation import well_formedness_shapes
from kbplanner.model.ifc_augment import write_augmented_ifc
from kbplanner.project import Project


def ifc_schema(path: Path) -> tuple[str, ...]:
    """The IDS ifcVersion of an IFC file from its header (all IDS versions when not recognised)."""
    with path.open("rb") as fh:
        head = fh.read(8192).decode("latin-1", "replace")
    m = re.search(r"FILE_SCHEMA\s*\(\s*\(\s*'([A-Za-z0-9_]+)'", head)
    schema = m.group(1).upper() if m else ""
    if schema.startswith("IFC4X3"):
        schema = "IFC4X3_ADD2"
    return (schema,) if schema in IFC_VERSIONS else IFC_VERSIONS


def write_ids_files(project: Project, result: RequirementsResult, task_id: str | None,
                    ids_path: Path | None, augmented_ifc: Path | None) -> None:
    """Write the IDS (from the bare model's requirements) and the augmented IFC (from the scenario)."""
    if augmented_ifc is not None and project.scenario is None:
        raise ProjectError("--augmented-ifc needs --scenario: the values come from a scenario's overlays",
                           file=project.manifest.path, element="--augmented-ifc",
                           fix="add --scenario NAME (one of the [scenarios.*] of project.toml)")
    bare = result
    if project.scenario is not None:
        base = Project.load(project.path)
        bare = derive_requirements(base.model, base.kb, task_id=task_id)
    export: IdsExport = ids_export(bare, well_formedness_shapes())
    if ids_path is not None and not export.specs:
        sys.stderr.write(f"no IDS written to {ids_path}: the bare model meets every binding IDS can express "
                         "(an IDS needs at least one specification)\n")
    elif ids_path is not None:
        export.write(ids_path, ifc_schema(project.manifest.ifc))
        sys.stderr.write(f"wrote IDS {ids_path} ({len(export.specs)} specification(s))\n")
    if augmented_ifc is not None:
        if augmented_ifc.resolve() == project.manifest.ifc.resolve():
            raise ProjectError("--augmented-ifc would overwrite the project's IFC model", file=augmented_ifc,
                               element="--augmented-ifc", fix="write the augmented IFC to another file")
        res = write_augmented_ifc(project.manifest.ifc, augmented_ifc, export, project.model)
        sys.stderr.write(f"wrote augmented IFC {augmented_ifc}: {res.properties} properties on "
                         f"{res.elements} element(s)\n")
        for gid in res.not_in_ifc:
            sys.stderr.write(f"  not in the IFC: {gid}\n")
        for what in res.missing_values:
            sys.stderr.write(f"  no value in scenario '{project.scenario}': {what}\n")
