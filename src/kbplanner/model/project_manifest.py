"""The project manifest (4D BIM environment, first step of loading a project): project.toml, checked.

:func:`read_manifest` parses a project directory's ``project.toml`` into a :class:`Manifest`: the IFC
model, the schedule (CSV, or ``"ifc"`` for the IFC's own work schedule), site layout, jobsite,
knowledge-base and augmentation Turtle files, the calendar, ``[simulation]`` defaults and the
scenarios (:class:`Scenario`, overlays of Turtle files), every path resolved against the directory and
checked to exist. :class:`kbplanner.model.project_data.ProjectData` loads the project from it.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from kbplanner.core.errors import ProjectError
from kbplanner.core.iris import base_iri

MANIFEST = "project.toml"


@dataclass(frozen=True)
class Scenario:
    """An overlay on the base model: extra Turtle files (site layout variant, augmentation)."""

    name: str
    description: str
    overlays: tuple[Path, ...]


@dataclass(frozen=True)
class Calendar:
    """Working hours of the project (for fitting simulated durations into the schedule)."""

    work_start: str = "07:00"
    work_end: str = "15:30"
    workdays: tuple[str, ...] = ("Mon", "Tue", "Wed", "Thu", "Fri")


@dataclass(frozen=True)
class Manifest:
    """The parsed ``project.toml`` with every path resolved against the project directory."""

    path: Path
    name: str
    description: str
    base: str
    seed: int
    ifc: Path
    schedule: Path | None
    schedule_from_ifc: bool
    site: tuple[Path, ...]
    jobsite: tuple[Path, ...]
    knowledge_base: tuple[Path, ...]
    augmentation: tuple[Path, ...]
    calendar: Calendar
    simulation: dict[str, Any]
    scenarios: dict[str, Scenario]
    reference: dict[str, Any] = field(default_factory=dict)  # figures to compare with, per scenario

    @property
    def directory(self) -> Path:
        """The project directory."""
        return self.path.parent


def _as_list(value: Any, key: str, manifest: Path) -> list[str]:
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return list(value)
    raise ProjectError(f"'{key}' must be a path or a list of paths", file=manifest, element=key,
                       fix=f'write {key} = ["file.ttl", ...]')


def _resolve(directory: Path, rel: str, key: str, manifest: Path) -> Path:
    p = (directory / rel).resolve()
    if not p.exists():
        raise ProjectError(f"'{key}' names a file that does not exist: {rel}", file=manifest, element=key,
                           fix=f"create {p} or correct the path (relative to {directory})")
    return p


def read_manifest(project_dir: Path) -> Manifest:
    """Parse and check ``project_dir/project.toml``.

    Example:
        >>> m = read_manifest(Path("data/case_study"))  # doctest: +SKIP
        >>> sorted(m.scenarios)  # doctest: +SKIP
        ['storage-inside', 'storage-outside']
    """
    project_dir = Path(project_dir)
    if project_dir.is_file() and project_dir.name == MANIFEST:
        project_dir = project_dir.parent
    manifest = project_dir / MANIFEST
    if not project_dir.is_dir():
        raise ProjectError("project directory not found", file=project_dir,
                           fix="give the path of a directory holding project.toml "
                               "(create one with 'kbplanner import-ifc MODEL.ifc --out DIR')")
    if not manifest.is_file():
        raise ProjectError("no project.toml in the project directory", file=project_dir,
                           fix="create project.toml (see docs/projects.md) or run "
                               "'kbplanner import-ifc MODEL.ifc --out DIR'")
    try:
        data = tomllib.loads(manifest.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ProjectError(f"project.toml is not valid TOML: {exc}", file=manifest,
                           fix="correct the TOML syntax") from None
    d = project_dir.resolve()
    proj = data.get("project", {})
    model = data.get("model", {})
    name = str(proj.get("name") or d.name)
    if "ifc" not in model:
        raise ProjectError("[model] has no 'ifc' entry", file=manifest, element="model.ifc",
                           fix='add ifc = "model/your_model.ifc" under [model]')
    ifc = _resolve(d, str(model["ifc"]), "model.ifc", manifest)
    sched_value = model.get("schedule")
    schedule: Path | None = None
    from_ifc = False
    if sched_value == "ifc":
        from_ifc = True
    elif sched_value:
        schedule = _resolve(d, str(sched_value), "model.schedule", manifest)

    def paths(section: dict[str, Any], key: str, label: str) -> tuple[Path, ...]:
        return tuple(_resolve(d, v, label, manifest) for v in _as_list(section.get(key), label, manifest))

    scenarios: dict[str, Scenario] = {}
    for sname, sdata in sorted((data.get("scenarios") or {}).items()):
        if not isinstance(sdata, dict):
            raise ProjectError(f"scenario {sname!r} must be a table", file=manifest, element=sname,
                               fix=f'write [scenarios.{sname}] with overlays = ["..."]')
        scenarios[sname] = Scenario(
            name=sname,
            description=str(sdata.get("description", "")),
            overlays=paths(sdata, "overlays", f"scenarios.{sname}.overlays"),
        )
    cal = data.get("calendar", {})
    calendar = Calendar(
        work_start=str(cal.get("work_start", "07:00")),
        work_end=str(cal.get("work_end", "15:30")),
        workdays=tuple(cal.get("workdays", ("Mon", "Tue", "Wed", "Thu", "Fri"))),
    )
    seed = proj.get("seed", 0)
    if not isinstance(seed, int):
        raise ProjectError("[project] seed must be an integer", file=manifest, element="project.seed",
                           fix="write seed = 7")
    return Manifest(
        path=manifest.resolve(),
        name=name,
        description=str(proj.get("description", "")),
        base=str(proj.get("base_iri") or base_iri(name)),
        seed=seed,
        ifc=ifc,
        schedule=schedule,
        schedule_from_ifc=from_ifc,
        site=paths(model, "site", "model.site"),
        jobsite=paths(model, "jobsite", "model.jobsite"),
        knowledge_base=paths(model, "knowledge_base", "model.knowledge_base"),
        augmentation=paths(model, "augmentation", "model.augmentation"),
        calendar=calendar,
        simulation=dict(data.get("simulation", {})),
        scenarios=scenarios,
        reference=dict(data.get("reference", {})),
    )

