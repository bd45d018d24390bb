"""The 4D schedule from a CSV file (import step, schedule part).

Takes a CSV schedule (format in ``docs/schedule.md``) and the model graph made by the IFC import;
returns a :class:`~kbplanner.model.schedule_model.Schedule` whose element entries (GlobalIds or selectors
such as ``class=IfcWall;storey=Level 1;external=false``) are resolved to the model's element IRIs.
Every problem raises :class:`~kbplanner.core.errors.ScheduleError` naming the file, the row (line
number), the column and the fix; a predecessor cycle raises
:class:`~kbplanner.core.errors.ScheduleCycleError` carrying the cycle.
"""

from __future__ import annotations

import csv
import fnmatch
import logging
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from datetime import date, datetime
from pathlib import Path

from rdflib import Graph, Literal, URIRef

from kbplanner.core.errors import InputFileError, ScheduleError
from kbplanner.model.schedule_model import (
    Schedule,
    Task,
    check_acyclic,
    finish_of,
    parse_bool,
    query_text,
    start_of,
)

logger = logging.getLogger(__name__)

COLUMNS: tuple[str, ...] = (
    "task_id", "name", "start", "finish", "predecessors", "elements", "robotized", "task_specification",
)
SELECTOR_KEYS: tuple[str, ...] = ("class", "storey", "name", "external")

_DATE_RE = re.compile(r"\d{4}-\d{2}-\d{2}")
_DATETIME_RE = re.compile(r"\d{4}-\d{2}-\d{2}T\d{2}:\d{2}(:\d{2})?")
_TZ_RE = re.compile(r"T.*(Z|[+-]\d{2}:?\d{2})$")
_GLOBAL_ID_RE = re.compile(r"[0-9A-Za-z_$]{22}")
_PRED_SPLIT_RE = re.compile(r"[\s;]+")
_DATE_FIX = ("write an ISO date YYYY-MM-DD or date-time YYYY-MM-DDTHH:MM[:SS] in local site time "
             "without a time zone, e.g. 2024-03-04 or 2024-03-04T08:30")
_HINT_LIMIT = 12


@dataclass(frozen=True)
class ModelElement:
    """What a schedule entry can match in the model graph: one building element with a GlobalId."""

    iri: URIRef
    global_id: str
    ifc_class: str | None
    label: str | None
    storeys: frozenset[str]
    is_external: bool | None


@dataclass(frozen=True)
class Selector:
    """A parsed selector: every given key must hold for an element to match."""

    text: str
    ifc_class: str | None = None
    storey: str | None = None
    name: str | None = None
    external: bool | None = None

    def matches(self, el: ModelElement) -> bool:
        """True when the element satisfies every key of the selector."""
        if self.ifc_class is not None and (
            el.ifc_class is None or not el.ifc_class.lower().startswith(self.ifc_class.lower())
        ):
            return False
        if self.storey is not None and self.storey not in el.storeys:
            return False
        if self.name is not None and (el.label is None or not fnmatch.fnmatchcase(el.label, self.name)):
            return False
        return self.external is None or el.is_external is self.external


@dataclass
class _ElementRecord:
    global_id: str
    ifc_class: str | None = None
    label: str | None = None
    storeys: set[str] = field(default_factory=set)
    is_external: bool | None = None


def model_elements(model: Graph) -> list[ModelElement]:
    """Every building element of the model graph, sorted by GlobalId then IRI.

    Building elements are ``bot:Element`` nodes with a ``kbp:globalId``, openings excluded (the IFC
    import types every element so). Uses the named query ``schedule_element_index`` (one row per
    element and storey).
    """
    found: dict[URIRef, _ElementRecord] = {}
    for row in model.query(query_text("schedule_element_index")):
        element, gid, cls, label, storey, ext = row  # type: ignore[misc]
        if not isinstance(element, URIRef):
            continue
        rec = found.setdefault(element, _ElementRecord(global_id=str(gid)))
        if cls is not None:
            rec.ifc_class = str(cls)
        if label is not None:
            rec.label = str(label)
        if storey is not None:
            rec.storeys.add(str(storey))
        if isinstance(ext, Literal):
            value = ext.toPython()
            rec.is_external = value if isinstance(value, bool) else parse_bool(str(value))
    out = [
        ModelElement(iri=iri, global_id=r.global_id, ifc_class=r.ifc_class, label=r.label,
                     storeys=frozenset(r.storeys), is_external=r.is_external)
        for iri, r in found.items()
    ]
    return sorted(out, key=lambda e: (e.global_id, str(e.iri)))


class _Row:
    """Error helper for one CSV row: every message names file, line, column and task."""

    def __init__(self, path: Path, line: int, task_id: str) -> None:
        self.path = path
        self.line = line
        self.task_id = task_id

    def error(self, column: str, problem: str, fix: str) -> ScheduleError:
        return ScheduleError(
            f"row {self.line}, column '{column}': {problem}",
            file=self.path,
            line=self.line,
            element=f"task {self.task_id}" if self.task_id else None,
            fix=fix,
        )


def _parse_time(row: _Row, column: str, text: str, *, is_finish: bool) -> datetime:
    value = text.strip()
    if not value:
        raise row.error(column, f"{column} is empty", _DATE_FIX)
    parsed: date | datetime
    try:
        if _DATE_RE.fullmatch(value):
            parsed = date.fromisoformat(value)
        elif _DATETIME_RE.fullmatch(value):
            parsed = datetime.fromisoformat(value)
        elif _TZ_RE.search(value):
            raise ValueError("it has a time zone; schedule times are local site times")
        else:
            raise ValueError("not in the documented format")
    except ValueError as exc:
        raise row.error(column, f"'{value}' is not a valid date or date-time ({exc})", _DATE_FIX) from None
    return finish_of(parsed) if is_finish else start_of(parsed)


def _parse_selector(row: _Row, entry: str) -> Selector:
    fields: dict[str, str] = {}
    for part in entry.split(";"):
        part = part.strip()
        if not part:
            continue
        key, sep, value = part.partition("=")
        key, value = key.strip().lower(), value.strip()
        if not sep or key not in SELECTOR_KEYS:
            what = f"key '{key}'" if sep else f"'{part}' (no '=')"
            known = ", ".join(SELECTOR_KEYS)
            raise row.error("elements", f"selector '{entry}': {what} is not one of the keys {known}",
                            "write key=value pairs separated by ';', e.g. class=IfcWall;storey=Level 1")
        if not value:
            raise row.error("elements", f"selector '{entry}': key '{key}' has no value",
                            f"give a value after '{key}=' or remove the pair")
        if key in fields:
            raise row.error("elements", f"selector '{entry}': key '{key}' appears twice",
                            "give each key once (all pairs must hold)")
        fields[key] = value
    external: bool | None = None
    if "external" in fields:
        external = parse_bool(fields["external"])
        if external is None:
            raise row.error("elements",
                            f"selector '{entry}': external='{fields['external']}' is not a boolean",
                            "write external=true or external=false")
    return Selector(text=entry, ifc_class=fields.get("class"), storey=fields.get("storey"),
                    name=fields.get("name"), external=external)


def _hint(values: Iterable[str]) -> str:
    vals = sorted(set(values))
    more = f", ... ({len(vals) - _HINT_LIMIT} more)" if len(vals) > _HINT_LIMIT else ""
    return ", ".join(vals[:_HINT_LIMIT]) + more if vals else "(none)"


def _no_match_fix(sel: Selector, elements: list[ModelElement]) -> str:
    parts = ["check the selector against the model (all pairs must hold; class matches by prefix, "
             "storey exactly, name as a case-sensitive glob)"]
    if sel.storey is not None:
        parts.append("storeys in the model: " + _hint(s for e in elements for s in e.storeys))
    if sel.ifc_class is not None:
        parts.append("IFC classes in the model: " + _hint(e.ifc_class for e in elements if e.ifc_class))
    if sel.external is not None:
        parts.append("elements without kbp:isExternal never match 'external'")
    return "; ".join(parts)


def _resolve_elements(
    row: _Row, text: str, by_gid: dict[str, list[ModelElement]], elements: list[ModelElement]
) -> tuple[URIRef, ...]:
    out: list[URIRef] = []
    for raw in text.split("|"):
        entry = raw.strip()
        if not entry:
            continue
        if "=" in entry:
            sel = _parse_selector(row, entry)
            matched = [e.iri for e in elements if sel.matches(e)]
            if not matched:
                raise row.error("elements", f"selector '{entry}' matches no element of the model",
                                _no_match_fix(sel, elements))
            logger.debug("%s: selector %r matched %d elements", row.task_id, entry, len(matched))
            out.extend(matched)
        elif _GLOBAL_ID_RE.fullmatch(entry):
            hits = by_gid.get(entry)
            if not hits:
                raise row.error("elements", f"GlobalId '{entry}' is not a building element of the model",
                                "check the GlobalId against the IFC file the model was imported from "
                                "(storeys, spaces and openings are not built by tasks), or use a selector "
                                "such as class=IfcWall;storey=Level 1")
            out.extend(e.iri for e in hits)
        else:
            raise row.error("elements", f"'{entry}' is neither a 22-character IFC GlobalId nor a selector",
                            "separate entries with '|'; write a GlobalId or key=value pairs "
                            "(keys: class, storey, name, external) separated by ';'")
    return tuple(dict.fromkeys(out))  # first occurrence keeps its place


def _read_rows(path: Path) -> tuple[dict[str, int], list[tuple[int, list[str]]]]:
    """Header column positions and (line, fields) of each non-empty data row."""
    if not path.is_file():
        raise InputFileError("schedule file not found", file=path,
                             fix="check the path (relative paths are resolved against the project directory)")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ScheduleError(f"not UTF-8 text ({exc.reason} at byte {exc.start})", file=path,
                            fix="save the schedule as UTF-8 CSV") from None
    reader = csv.reader(text.splitlines(keepends=True))
    try:
        header = next(reader, None)
        while header is not None and not any(h.strip() for h in header):
            header = next(reader, None)
        if header is None:
            raise ScheduleError("the file is empty", file=path,
                                fix="add the header row " + ",".join(COLUMNS) + " and one row per task")
        header_line = reader.line_num
        names = [h.strip().lower() for h in header]
        missing = [c for c in COLUMNS if c not in names]
        if missing:
            raise ScheduleError(
                f"row {header_line}: header lacks column(s) {', '.join(missing)}",
                file=path, line=header_line,
                fix="the header row must name the columns " + ",".join(COLUMNS) + " (any order)",
            )
        extra = [n for n in names if n not in COLUMNS]
        if extra:
            logger.warning("%s: ignoring unknown column(s) %s", path, ", ".join(extra))
        positions = {c: names.index(c) for c in COLUMNS}
        rows: list[tuple[int, list[str]]] = []
        for fields in reader:
            if not any(f.strip() for f in fields):
                continue
            if len(fields) > len(names):
                raise ScheduleError(
                    f"row {reader.line_num}: {len(fields)} fields but the header has {len(names)}",
                    file=path, line=reader.line_num,
                    fix="quote fields that contain commas, e.g. \"Walls, level 1\"",
                )
            rows.append((reader.line_num, fields + [""] * (len(names) - len(fields))))
    except csv.Error as exc:
        raise ScheduleError(f"row {reader.line_num}: CSV syntax error ({exc})", file=path,
                            line=reader.line_num, fix="check the quotes on that line") from None
    return positions, rows


def read_csv_schedule(path: Path, model: Graph) -> Schedule:
    """Read a CSV schedule and resolve its element entries against the model graph.

    Example:
        >>> from kbplanner.core.vocab import KBP
        >>> import tempfile
        >>> model = Graph()
        >>> from rdflib import RDF
        >>> from kbplanner.core.vocab import BOT
        >>> wall = URIRef("https://w3id.org/kbplanner/data/demo/element/2O2Fr$t4X7Zf8NOew3FLOH")
        >>> _ = model.add((wall, RDF.type, BOT.Element))
        >>> _ = model.add((wall, KBP.globalId, Literal("2O2Fr$t4X7Zf8NOew3FLOH")))
        >>> _ = model.add((wall, KBP.ifcClass, Literal("IfcWallStandardCase")))
        >>> d = Path(tempfile.mkdtemp())
        >>> _ = (d / "s.csv").write_text(
        ...     "task_id,name,start,finish,predecessors,elements,robotized,task_specification\\n"
        ...     "T1,Walls,2024-03-04,2024-03-05,,class=IfcWall,yes,I-W-F-#1\\n")
        >>> s = read_csv_schedule(d / "s.csv", model)
        >>> s.tasks[0].finish.isoformat(), s.tasks[0].element_iris == (wall,)
        ('2024-03-05T23:59:59', True)
    """
    path = Path(path)
    positions, rows = _read_rows(path)
    elements = model_elements(model)
    by_gid: dict[str, list[ModelElement]] = {}
    for e in elements:
        by_gid.setdefault(e.global_id, []).append(e)

    tasks: list[Task] = []
    lines: dict[str, int] = {}
    for line, fields in rows:
        def col(name: str, fields: list[str] = fields) -> str:
            return fields[positions[name]].strip()

        task_id = col("task_id")
        row = _Row(path, line, task_id)
        if not task_id:
            raise row.error("task_id", "task_id is empty", "give every row a unique task id, e.g. T1")
        if re.search(r"[\s;|]", task_id):
            raise row.error("task_id", f"task id '{task_id}' contains a space, ';' or '|'",
                            "use task ids without spaces, ';' or '|' (they separate predecessors)")
        if task_id in lines:
            raise row.error("task_id", f"task id '{task_id}' is already used on line {lines[task_id]}",
                            "give every task a unique task id")
        lines[task_id] = line
        start = _parse_time(row, "start", col("start"), is_finish=False)
        finish = _parse_time(row, "finish", col("finish"), is_finish=True)
        if finish < start:
            raise row.error("finish", f"finish {finish.isoformat()} is before start {start.isoformat()}",
                            "make finish the same as or later than start (a date-only finish means the "
                            "end of that day)")
        predecessors = tuple(dict.fromkeys(p for p in _PRED_SPLIT_RE.split(col("predecessors")) if p))
        robotized = parse_bool(col("robotized"))
        if robotized is None:
            raise row.error("robotized", f"'{col('robotized')}' is not a boolean",
                            "write true/false, yes/no or 1/0 (empty means false)")
        spec = col("task_specification") or None
        if robotized and spec is None:
            raise row.error("task_specification", "a robotized task needs a task specification id",
                            "name the knowledge-base task specification, e.g. I-W-F-#1, or set robotized "
                            "to false")
        element_iris = _resolve_elements(row, col("elements"), by_gid, elements)
        if robotized and not element_iris:
            logger.warning("%s:%d: robotized task %s builds no element", path, line, task_id)
        tasks.append(Task(
            task_id=task_id,
            name=col("name") or task_id,
            start=start,
            finish=finish,
            predecessors=predecessors,
            element_iris=element_iris,
            robotized=robotized,
            task_specification_id=spec,
        ))

    for t in tasks:
        for p in t.predecessors:
            if p not in lines:
                raise _Row(path, lines[t.task_id], t.task_id).error(
                    "predecessors", f"predecessor '{p}' is not a task of this schedule",
                    "list task ids of this file separated by spaces or ';' (known ids: "
                    + _hint(lines) + ")")
    check_acyclic(tasks, path)
    logger.info("%s: %d tasks, %d robotized", path, len(tasks), sum(t.robotized for t in tasks))
    return Schedule(schedule_id=path.stem, name=path.stem, source=str(path), tasks=tuple(tasks))
