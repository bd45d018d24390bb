"""A project directory (4D BIM environment): its manifest, and the 4D model graph built from it.

A project (``project.toml``, read by :mod:`kbplanner.model.project_manifest`) names an IFC model, a
schedule (CSV, or ``"ifc"`` for the IFC's own work schedule), site layout and jobsite Turtle files,
always-applied augmentation, and scenarios, each an overlay of Turtle files on the same base.
``Project.load(path, scenario=...)`` imports the IFC (cached by content hash), reads the schedule and
overlays, and gives the model graph (``model``), the knowledge base (``kb``) and typed entry points for
the later steps.
"""

from __future__ import annotations

import hashlib
import logging
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, Self

from rdflib import RDF, Graph

from kbplanner.core.errors import ProjectError
from kbplanner.core.named_queries import QueryResult, run_named
from kbplanner.core.number_rule import check_numbers
from kbplanner.core.rdf_io import bind_prefixes, parse_turtle, recording_reads
from kbplanner.model import load_memo, project_cache
from kbplanner.model.project_manifest import Manifest, read_manifest

if TYPE_CHECKING:
    from kbplanner.model.ifc_import import ImportResult

log = logging.getLogger(__name__)

CACHE_ENV = "KBPLANNER_CACHE_DIR"

ProgressFn = Callable[[str], None]


def file_sha256(path: Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def cache_root(project_dir: Path) -> Path:
    """Where imported models are cached: ``$KBPLANNER_CACHE_DIR`` or ``PROJECT/.kbplanner-cache``."""
    env = os.environ.get(CACHE_ENV)
    return Path(env) if env else project_dir / ".kbplanner-cache"


@dataclass(frozen=True)
class ProjectInfo:
    """A summary of a loaded project (``kbplanner info``)."""

    name: str
    path: str
    scenario: str | None
    ifc: str
    schema: str
    counts: dict[str, int]
    walls_interior: int
    walls_exterior: int
    storeys: list[tuple[str, float | None, int]]
    tasks: int
    robotized_tasks: list[tuple[str, str, str | None]]
    date_range: tuple[str | None, str | None]
    site_objects: dict[str, int]
    workers: int
    scenarios: list[str]
    triples: int


@dataclass
class ProjectData:
    """A loaded project: the model graph of one scenario (or the bare model) and the knowledge base.

    This is the data every later step reads; :class:`kbplanner.project.Project` is the facade with
    the later steps as methods.
    """

    manifest: Manifest
    scenario: str | None
    model: Graph
    kb: Graph
    import_dir: Path
    kb_files: list[Path] = field(default_factory=list)
    _merged: Graph | None = field(default=None, repr=False)
    cache_entry: Path | None = field(default=None, repr=False)  # the project cache entry of the load
    _merged_of: tuple[int, int] | None = field(default=None, repr=False)  # sizes of a kept merged graph
    _kept_stamp: str = field(default="", repr=False)  # the entry's stamp of the graphs unpickled from it

    # ---- loading -------------------------------------------------------------------------------
    @classmethod
    def load(
        cls,
        path: str | Path,
        scenario: str | None = None,
        *,
        progress: ProgressFn | None = None,
        store: str | None = None,
    ) -> Self:
        """Load a project directory, optionally with a scenario overlay.

        ``store`` puts the model and the merged graph on another backend (:mod:`kbplanner.core.stores`:
        ``oxigraph``, ``oxigraph:DIR``, ``sparql+http://HOST:PORT/query``); default: rdflib in memory.

        Example:
            >>> p = Project.load("data/case_study", scenario="storage-outside")  # doctest: +SKIP
            >>> p.query("storeys").rows[0][1]  # doctest: +SKIP
            'T/FDN'
        """
        manifest = read_manifest(Path(path))
        if store is not None:
            from kbplanner.core.stores import parse_store

            parse_store(store)  # a bad spec fails before the import
        if scenario is not None and scenario not in manifest.scenarios:
            known = ", ".join(sorted(manifest.scenarios)) or "none"
            raise ProjectError(f"unknown scenario {scenario!r}", file=manifest.path, element=scenario,
                               fix=f"choose one of: {known}")
        say = progress or (lambda _msg: None)
        entry = (project_cache.entry_dir(cache_root(manifest.directory), manifest, scenario)
                 if project_cache.enabled() else None)
        hit = project_cache.read_entry(entry, store) if entry is not None else None
        from_cache = hit.graphs(store) if hit is not None else None
        merged: Graph | None = None
        if hit is not None and from_cache is not None:
            say("project from cache")
            (model, merged), kb, import_dir, kb_files = from_cache, hit.kb, hit.import_dir, hit.kb_files
        else:
            model, kb, import_dir, kb_files = _load_graphs(manifest, scenario, say, entry)
        if store is not None and merged is None:
            from kbplanner.core.stores import place_graphs

            say(f"placing the model on {store}")
            model, merged = place_graphs(store, model, kb,
                                         graph_base=f"{manifest.base}graph/{scenario or 'bare'}/")
        if entry is not None and not (entry / project_cache.META).is_file():
            entry = None  # not written (read-only project, full disk)
        kept = (len(model), len(kb)) if merged is not None and store is None else None
        stamp = hit.stamp if hit is not None and kept is not None else ""
        return cls(manifest=manifest, scenario=scenario, model=model, kb=kb, import_dir=import_dir,
                   kb_files=kb_files, _merged=merged, cache_entry=entry, _merged_of=kept, _kept_stamp=stamp)

    def keep_graphs(self) -> None:
        """Write this load's graphs into its project cache entry (``graphs.pickle``) where the entry has
        none yet (a cold load writes the model as N-Triples only, and the first process to read it back
        parsed it, merged it with the knowledge base, hashed and pickled it: 15-20 s on a 10 x 8
        building). A whole-building run calls this right after its cold load, before its spawned
        processes load the scenario from the cache: they unpickle these graphs instead. This process
        keeps the merged graph and the stamp it computed (it would build both at its first query).
        Nothing for a graph on another store, an edited one or a load without a cache entry."""
        entry = self.cache_entry
        if (entry is None or (entry / project_cache.GRAPHS).is_file()
                or not project_cache.unedited(self.model, self.kb)):
            return
        merged = self.graph
        stamp = self._kept_stamp or project_cache.graphs_stamp(self.model, self.kb)
        project_cache.keep_graphs(entry, self.model, self.kb, merged, stamp)
        self._merged_of, self._kept_stamp = (len(self.model), len(self.kb)), stamp

    # ---- basic properties ----------------------------------------------------------------------
    @property
    def path(self) -> Path:
        """The project directory."""
        return self.manifest.directory

    @property
    def name(self) -> str:
        """The project's name."""
        return self.manifest.name

    @property
    def base(self) -> str:
        """Base IRI of the project's instance data."""
        return self.manifest.base

    @property
    def graph(self) -> Graph:
        """The model and the knowledge base merged (for queries that need both). Do not mutate."""
        if self._merged is not None and self._merged_of is not None and (
                self._merged_of != (len(self.model), len(self.kb))
                or not project_cache.unedited(self.model, self.kb)):
            self._merged = None  # the merged graph kept in the cache, and the model or KB edited since
        if self._merged is None:
            self._merged = project_cache.merged_graph(self.model, self.kb)
            self._merged_of = None
        return self._merged

    def mesh_path(self, mesh_file: str) -> Path:
        """Absolute path of a ``kbp:meshFile`` value."""
        return self.import_dir / mesh_file

    # ---- queries -------------------------------------------------------------------------------
    def query(self, name: str, **bindings: Any) -> QueryResult:
        """Run a named query on the model + knowledge base with values bound.

        Example:
            >>> p.query("doors_and_widths", storeyLabel="Level 1")  # doctest: +SKIP
        """
        return run_named(self.graph, name, **bindings)

    def pristine_rows(self, queries: Sequence[tuple[str, bool]]) -> dict[str, QueryResult]:
        """Named queries without bindings, each ``(name, on_merged_graph)``, kept in the project cache
        while the model and knowledge base are the ones loaded (checked by a hash of their triples,
        :func:`kbplanner.model.project_cache.graphs_stamp`); the world tables read theirs so (A6)."""
        from kbplanner.core.stores import describe

        entry = self.cache_entry if project_cache.enabled() else None
        backend = describe(self.graph)
        if entry is not None and backend not in ("memory", "oxigraph"):
            entry = None  # an endpoint's rows are the server's business
        stamp = ""
        if entry is not None:  # the entry's stamp while the graphs are those unpickled from it, unedited
            stamp = (self._kept_stamp if self._kept_stamp and project_cache.unedited(self.model, self.kb)
                     else project_cache.graphs_stamp(self.model, self.kb))
        out: dict[str, QueryResult] = {}
        for name, merged in queries:
            kept = project_cache.read_rows(entry, name, backend, stamp) if entry is not None else None
            if kept is None:
                kept = run_named(self.graph if merged else self.model, name)
                if entry is not None:
                    project_cache.write_rows(entry, name, backend, stamp, kept)
            out[name] = kept
        return out

    def element_states(self, at: datetime) -> dict[str, str]:
        """State of every scheduled element at a date: IRI -> 'built' | 'in progress' | 'not started'."""
        from kbplanner.model.schedule import element_states

        names = {"Built": "built", "InProgress": "in progress", "NotStarted": "not started"}
        return {str(el): names.get(str(st).rsplit("#", 1)[-1], str(st))
                for el, st in element_states(self.model, at).items()}

    # ---- the task and date of a world ----------------------------------------------------------
    def default_task(self) -> str | None:
        """The robotized task simulated by default: ``[simulation] task`` or the only robotized task."""
        task = self.manifest.simulation.get("task")
        if task:
            return str(task)
        robotized = [r[1] for r in self.query("tasks_and_elements").rows if r[5]]
        return str(robotized[0]) if len(robotized) == 1 else None

    def world_date(self, task_id: str | None = None) -> datetime:
        """The date of a task's world: ``[simulation] date`` for the ``[simulation] task`` (and when no
        task is named), the start of any other task (else the ``[simulation] date``)."""
        from kbplanner.model.dates import parse_date

        default = self.manifest.simulation.get("date")
        sim_task = self.manifest.simulation.get("task")
        if task_id is not None and sim_task is not None and task_id != str(sim_task):
            rows = self.query("tasks_and_elements", taskId=task_id).rows
            start = rows[0][3] if rows else None
            if isinstance(start, datetime):
                return start.replace(tzinfo=None)
        if default is None:
            raise ProjectError("no date given and no [simulation] date in project.toml",
                               file=self.manifest.path,
                               fix='add date = "2022-05-10T07:00:00" under [simulation]')
        return parse_date(str(default))

    def info(self) -> ProjectInfo:
        """Counts per class, storeys, tasks, robotized tasks and date range of the loaded model."""
        counts: dict[str, int] = {}
        interior = exterior = 0
        for cls_iri, external, n in self.query("element_counts").rows:
            label = str(cls_iri).rsplit("#", 1)[-1]
            counts[label] = counts.get(label, 0) + int(n)
            if label == "Wall" and external is not None:
                if external:
                    exterior += int(n)
                else:
                    interior += int(n)
        storeys = [(str(lbl), float(el) if el is not None else None, int(n))
                   for _, lbl, el, n in self.query("storeys").rows]
        tasks = self.query("tasks_and_elements").rows
        starts = [r[3] for r in tasks if r[3] is not None]
        finishes = [r[4] for r in tasks if r[4] is not None]
        robotized = [(str(r[1]), str(r[2] or ""), r[6]) for r in tasks if r[5]]
        site: dict[str, int] = {}
        for row in self.query("site_objects").rows:
            label = str(row[1]).rsplit("#", 1)[-1]
            site[label] = site.get(label, 0) + 1
        from kbplanner.core.vocab import KBP

        schema = next((str(o) for o in self.model.objects(None, KBP.ifcSchema)), "")
        return ProjectInfo(
            name=self.name,
            path=str(self.path),
            scenario=self.scenario,
            ifc=self.manifest.ifc.name,
            schema=schema,
            counts=dict(sorted(counts.items())),
            walls_interior=interior,
            walls_exterior=exterior,
            storeys=storeys,
            tasks=len(tasks),
            robotized_tasks=robotized,
            date_range=(min(starts).isoformat() if starts else None,
                        max(finishes).isoformat() if finishes else None),
            site_objects=site,
            workers=sum(1 for _ in self.model.subjects(RDF.type, KBP.Worker)),
            scenarios=sorted(self.manifest.scenarios),
            triples=len(self.model),
        )


def _load_graphs(manifest: Manifest, scenario: str | None, say: ProgressFn,
                 entry: Path | None) -> tuple[Graph, Graph, Path, list[Path]]:
    """The model graph (import, schedule, overlays) and the knowledge base of a project and scenario,
    read from the inputs; kept in the project cache (:mod:`kbplanner.model.project_cache`)."""
    with recording_reads() as reads:
        say(f"importing {manifest.ifc.name}")
        result_graph, import_dir = import_cached(manifest)
        model = Graph()
        bind_prefixes(model)
        for t in result_graph:
            model.add(t)
        if manifest.schedule is not None or manifest.schedule_from_ifc:
            say("reading schedule")
            model += _schedule_graph(manifest, model, result_graph)
        overlays: list[Path] = [*manifest.site, *manifest.jobsite, *manifest.augmentation]
        if scenario is not None:
            overlays += list(manifest.scenarios[scenario].overlays)
        for p in overlays:
            say(f"reading {p.name}")
            overlay = parse_turtle(p)
            check_numbers(overlay, p)  # the numeric rule, where the numbers are read
            for triple in overlay:
                model.add(triple)
        say("loading knowledge base")
        kb, kb_files = _load_kb(manifest.knowledge_base)
    if entry is not None:
        project_cache.write_entry(entry, project_cache.CachedProject(model, kb, import_dir, kb_files), reads,
                                  project_cache.declared_inputs(manifest, scenario),
                                  owner=project_cache.owner_of(manifest, scenario))
        project_cache.note_edits(model, kb)  # as when read back from the entry: unedited, until edited
    return model, kb, import_dir, kb_files


def import_cached(manifest: Manifest) -> tuple[Graph, Path]:
    """Import the project's IFC, or reuse a cached import of the same bytes and importer version."""
    from kbplanner.model.import_version import IMPORTER_VERSION

    digest = file_sha256(manifest.ifc)[:16]
    version = IMPORTER_VERSION
    key = hashlib.sha256(f"{digest}|{manifest.base}|{version}".encode()).hexdigest()[:20]
    out = cache_root(manifest.directory) / key
    ttl = out / "model.ttl"
    if ttl.is_file():
        kept = load_memo.kept_import(ttl)  # this process imported or parsed it already
        if kept is not None:
            return kept, out
        log.info("using cached import %s", out)
        graph = parse_turtle(ttl)
        load_memo.keep_import(ttl, graph)
        return graph, out
    from kbplanner.model import ifc_import  # ifcopenshell, trimesh: only when the IFC is imported

    # A second core computes the meshes' volumes while this one triangulates (the same volumes).
    volume_processes = 1 if (os.cpu_count() or 1) >= 2 else 0
    result: ImportResult = ifc_import.import_ifc(manifest.ifc, out, base=manifest.base,
                                                 volume_processes=volume_processes)
    load_memo.keep_import(ttl, result.graph)
    return result.graph, out


def _schedule_graph(manifest: Manifest, model: Graph, import_graph: Graph) -> Graph:
    """The schedule's graph; ``model`` holds just the triples of ``import_graph`` (what a CSV schedule
    is resolved against), so a schedule graph this process built against it is taken again."""
    from kbplanner.model import schedule as sched

    if manifest.schedule is not None and not manifest.schedule_from_ifc:
        kept = load_memo.kept_schedule(import_graph, manifest.schedule, manifest.base)
        if kept is not None:
            return kept
    if manifest.schedule_from_ifc:
        s = sched.read_ifc_schedule(manifest.ifc, manifest.base)
        if s is None:
            raise ProjectError("schedule = \"ifc\" but the IFC file has no work schedule",
                               file=manifest.path, element=str(manifest.ifc),
                               fix="add a CSV schedule (docs/schedule.md) and name it in [model] schedule")
    else:
        assert manifest.schedule is not None
        s = sched.read_csv_schedule(manifest.schedule, model)
    graph = sched.schedule_to_graph(s, manifest.base)
    if manifest.schedule is not None and not manifest.schedule_from_ifc:
        load_memo.keep_schedule(import_graph, manifest.schedule, manifest.base, graph)
    return graph


def _load_kb(extra: Sequence[Path]) -> tuple[Graph, list[Path]]:
    from kbplanner.core.resources import ontology_files

    try:
        from kbplanner.knowledge import knowledge_base
    except ImportError:  # the knowledge base module arrives with the KB step
        g = Graph()
        files = [*ontology_files(), *extra]
        for p in files:
            parse_turtle(p, into=g)
        return g, files
    from kbplanner.knowledge.binding_check import check_bindings

    kb = knowledge_base.load_kb(list(extra))
    check_bindings(kb)  # a malformed binding is an error naming its file now, never a SHACL engine error
    files = [*ontology_files(), *extra]
    return kb, files
