"""BCF out (A4 validation and B5 runs, back to BIM authors): one BCF topic per element with a problem.

``validation_issues`` turns a SHACL validation report into one issue per non-conforming IFC element (every
message of that element in the description); results about nodes that are not IFC elements (tasks, site
objects from Turtle) are returned separately, never dropped silently. ``run_issues`` gives one issue per
element a simulation run did not install, with the executor's reason. ``write_bcf`` writes them as a
BCF 2.1 or 3.0 ``.bcfzip`` with IfcOpenShell's BCF library (``bcf-client``): a topic per issue, with a
viewpoint whose camera looks at the element (its IFC placement) and whose selected component is the
element's IFC GlobalId. Topic and viewpoint GUIDs are derived from the issue (uuid5), the creation date
is given by the caller (the world date of the 4D model), and the zip is written with fixed timestamps, so
the same inputs give the same file.
"""

from __future__ import annotations

import io
import tempfile
import uuid
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

import bcf.v2.bcfxml
import bcf.v2.model
import bcf.v2.topic
import bcf.v2.visinfo
import bcf.v3.bcfxml
import bcf.v3.model
import bcf.v3.topic
import bcf.v3.visinfo
import ifcopenshell
import numpy as np
from rdflib import RDF, RDFS, Graph
from rdflib.term import Node
from xsdata.models.datatype import XmlDateTime

from kbplanner.analysis.run_record import RunRecord
from kbplanner.core.errors import IfcError, InputFileError, KbplannerError
from kbplanner.core.outputs import atomic_write_bytes
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import SH
from kbplanner.model.project_data import ProjectData

VERSIONS = ("2.1", "3.0")
_NS = uuid.UUID("6f1c2a7e-4b1d-5c3e-9a8f-2d6b0c4e1a33")
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)


@dataclass(frozen=True)
class BcfIssue:
    """One problem with one IFC element."""

    global_id: str
    title: str
    description: str
    topic_type: str = "Issue"
    position: tuple[float, float, float] | None = None  # site frame, metres; when the IFC lacks it


@dataclass(frozen=True)
class BcfWritten:
    """What :func:`write_bcf` wrote."""

    path: Path
    topics: int
    not_in_ifc: tuple[str, ...]


def _centre(model: Graph, element: Node) -> tuple[float, float, float] | None:
    box = model.value(element, KBP.bounds)
    if box is None:
        return None
    try:
        lo = [float(model.value(box, p).toPython()) for p in (KBP.minX, KBP.minY, KBP.minZ)]  # type: ignore[union-attr]
        hi = [float(model.value(box, p).toPython()) for p in (KBP.maxX, KBP.maxY, KBP.maxZ)]  # type: ignore[union-attr]
    except (AttributeError, TypeError, ValueError):
        return None
    return (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2]))


def _element_of(model: Graph, node: Node) -> Node | None:
    """The IFC element a report focus node is, or belongs to (a pose or box of one element)."""
    if model.value(node, KBP.globalId) is not None:
        return node
    owners = sorted({s for s in model.subjects(None, node) if model.value(s, KBP.globalId) is not None},
                    key=str)
    return owners[0] if len(owners) == 1 else None


def validation_issues(report: Graph, model: Graph) -> tuple[list[BcfIssue], list[str]]:
    """One issue per non-conforming IFC element of a SHACL report; and the results not about one."""
    by_element: dict[Node, list[str]] = {}
    elsewhere: list[str] = []
    for res in report.subjects(RDF.type, SH.ValidationResult):
        if report.value(res, SH.resultSeverity) not in (SH.Violation, None):
            continue
        focus = report.value(res, SH.focusNode)
        msg = str(report.value(res, SH.resultMessage) or "violates a SHACL constraint")
        element = _element_of(model, focus) if focus is not None else None
        if element is None:
            elsewhere.append(f"{focus}: {msg}")
            continue
        by_element.setdefault(element, []).append(msg)
    issues = []
    for element, msgs in by_element.items():
        gid = str(model.value(element, KBP.globalId))
        name = model.value(element, RDFS.label)
        cls = model.value(element, KBP.ifcClass)
        who = f"{name or gid}" + (f" ({cls})" if cls is not None else "")
        issues.append(BcfIssue(
            global_id=gid, title=f"Does not conform: {who}",
            description="kbplanner validation (SHACL) found:\n"
            + "\n".join(f"- {m}" for m in sorted(set(msgs))),
            topic_type="Error", position=_centre(model, element)))
    issues.sort(key=lambda i: i.global_id)
    return issues, sorted(elsewhere)


def run_issues(rec: RunRecord, scenario: str | None = None) -> list[BcfIssue]:
    """One issue per element a simulation run did not install, with the reason."""
    name = scenario or rec.scenario or rec.directory.name
    issues = []
    for e in rec.durations().elements:
        if e.outcome == "installed":
            continue
        issues.append(BcfIssue(
            global_id=e.global_id, title=f"Robot could not install {e.element} ({name})",
            description=(f"kbplanner simulation, scenario {name}, task {rec.manifest.get('task', '?')}, "
                         f"robot {rec.manifest.get('robot', '?')}, seed {rec.manifest.get('seed', '?')}: "
                         f"{e.outcome}. Reason: {e.reason or 'not given'}"),
            topic_type="Issue"))
    return issues


def _bcf(version: str) -> Any:
    if version not in VERSIONS:
        raise InputFileError(f"unknown BCF version {version!r}", fix=f"use one of {', '.join(VERSIONS)}")
    return bcf.v2 if version == "2.1" else bcf.v3


def write_bcf(issues: Sequence[BcfIssue], out: Path, *, ifc_path: Path | None, project_name: str,
              created: datetime, version: str = "3.0", author: str = "kbplanner") -> BcfWritten:
    """Write ``issues`` as a BCF ``version`` zip at ``out`` (atomically, deterministic bytes)."""
    v = _bcf(version)
    ifc = None
    if ifc_path is not None:
        try:
            ifc = ifcopenshell.open(str(ifc_path))
        except (OSError, RuntimeError) as exc:
            raise IfcError(f"cannot read the IFC file: {exc}", file=ifc_path,
                           fix="give the project's IFC file") from exc
    doc = v.bcfxml.BcfXml.create_new(project_name=project_name)
    doc.project_info.project.project_id = str(uuid.uuid5(_NS, f"project|{project_name}"))
    when = XmlDateTime.from_datetime(created)
    missing: list[str] = []
    for issue in issues:
        key = f"{project_name}|{issue.global_id}|{issue.title}"
        guid = str(uuid.uuid5(_NS, f"topic|{key}"))
        topic = v.model.Topic(guid=guid, title=issue.title, description=issue.description,
                              creation_author=author, creation_date=when, topic_type=issue.topic_type,
                              topic_status="Open")
        handler = v.topic.TopicHandler(topic_dir=Path(guid))
        handler.markup = v.model.Markup(topic=topic)
        element = None
        if ifc is not None:
            try:
                element = ifc.by_guid(issue.global_id)
            except RuntimeError:
                element = None
        if element is not None and getattr(element, "ObjectPlacement", None) is not None:
            info = v.visinfo.build_viewpoint(element)
        else:
            missing.append(issue.global_id)
            pos = np.array(issue.position if issue.position is not None else (0.0, 0.0, 0.0), dtype=float)
            info = v.visinfo.build_viewpoint_from_position_and_guids(pos, issue.global_id)
        info.guid = str(uuid.uuid5(_NS, f"viewpoint|{key}"))
        handler.add_visinfo_handler(v.visinfo.VisualizationInfoHandler(visualization_info=info))
        doc.topics[guid] = handler
    with tempfile.TemporaryDirectory() as tmp:
        doc.save(Path(tmp) / "topics.bcfzip")
        doc.close()
        atomic_write_bytes(out, _repack(Path(tmp) / "topics.bcfzip"))
    return BcfWritten(path=out, topics=len(issues), not_in_ifc=tuple(missing))


def _repack(src: Path) -> bytes:
    """The zip's bytes with sorted entries and fixed timestamps."""
    buf = io.BytesIO()
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zout:
        for name in sorted(zin.namelist()):
            info = zipfile.ZipInfo(name, date_time=_ZIP_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o40755 << 16) if name.endswith("/") else (0o644 << 16)
            zout.writestr(info, zin.read(name))
    return buf.getvalue()


def read_bcf_topics(path: Path) -> list[tuple[str, str, list[str]]]:
    """Read a ``.bcfzip`` back with the BCF library: (title, topic type, selected GlobalIds) per topic."""
    with zipfile.ZipFile(path) as z:
        version = z.read("bcf.version").decode("utf-8")
    v = bcf.v3 if 'VersionId="3.0"' in version else bcf.v2
    out = []
    with v.bcfxml.BcfXml.load(path) as doc:
        for handler in doc.topics.values():
            guids = [g for vp in handler.viewpoints.values() for g in (vp.get_selected_guids() or [])]
            out.append((str(handler.topic.title), str(handler.topic.topic_type or ""), guids))
    return sorted(out)




RUN_BCF = "not_installed.bcfzip"


def write_run_bcf(runs: dict[str, RunRecord], out_dir: Path, *, ifc_path: Path | None, project_name: str,
                  created: datetime, version: str = "3.0") -> BcfWritten | None:
    """``out_dir/not_installed.bcfzip``: a topic per element some run did not install (None: all were)."""
    issues = [i for name, rec in runs.items() for i in run_issues(rec, name)]
    if not issues:
        return None
    return write_bcf(issues, out_dir / RUN_BCF, ifc_path=ifc_path, project_name=project_name,
                     created=created, version=version)


def run_issue_date(project: ProjectData, runs: dict[str, RunRecord]) -> datetime:
    """The creation date of run topics: the world date of the simulated task (else 2000-01-01)."""
    task = next((str(r.manifest["task"]) for r in runs.values() if r.manifest.get("task")), None)
    try:
        return project.world_date(task)
    except KbplannerError:
        return datetime(2000, 1, 1)
