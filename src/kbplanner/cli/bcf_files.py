"""BCF files of ``kbplanner validate --bcf`` (A4 back to BIM authors; not a command).

One topic per non-conforming IFC element (:mod:`kbplanner.analysis.bcf_export`); results about nodes
that are not IFC elements stay in the text and SHACL reports and are counted on stderr.
"""

from __future__ import annotations

import sys
from datetime import UTC, datetime
from pathlib import Path

from kbplanner.analysis.bcf_export import validation_issues, write_bcf
from kbplanner.core.errors import ProjectError
from kbplanner.knowledge.validation import ValidationResult
from kbplanner.model.project_data import ProjectData


def issue_date(project: ProjectData) -> datetime:
    """The creation date of the topics: the world date of the 4D model, else the IFC file's time."""
    try:
        return project.world_date()
    except ProjectError:
        return datetime.fromtimestamp(int(project.manifest.ifc.stat().st_mtime), tz=UTC).replace(tzinfo=None)


def write_validation_bcf(project: ProjectData, result: ValidationResult, out: Path, version: str) -> None:
    """Write the non-conforming elements of ``result`` as BCF topics to ``out``."""
    issues, elsewhere = validation_issues(result.report_graph, project.model)
    written = write_bcf(issues, out, ifc_path=project.manifest.ifc, project_name=project.name,
                        created=issue_date(project), version=version)
    sys.stderr.write(f"wrote BCF {version} {out}: {written.topics} topic(s), "
                     "one per non-conforming IFC element\n")
    if elsewhere:
        sys.stderr.write(f"  {len(elsewhere)} violation(s) not about an IFC element (tasks, site objects) "
                         "are not in the BCF; see the text or --report\n")
    for gid in written.not_in_ifc:
        sys.stderr.write(f"  {gid} is not in the IFC file: its viewpoint looks at its model position\n")
