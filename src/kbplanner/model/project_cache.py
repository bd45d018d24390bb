"""The project cache (4D model loading): a loaded project kept by a content hash of all its inputs.

Loading a project imports the IFC (itself cached, :func:`kbplanner.model.project_data.import_cached`),
reads the schedule, parses the site, jobsite, augmentation and scenario Turtle and the knowledge base,
and checks their numbers: seconds of work that give the same graphs as long as no input changes. This
module keeps the result, the model graph and the knowledge-base graph of one project and scenario, as
N-Triples (read straight into Oxigraph) and as the rdflib graphs read from them, pickled with the
merged graph (model + knowledge base) the queries run on, so that the next command unpickles one file
(a quarter of the time of parsing the N-Triples and merging the graphs) instead.

- Where: ``PROJECT/.kbplanner-cache/project/KEY/`` (``model.nt``, ``kb.nt``, ``graphs.pickle``,
  ``meta.json``), or ``$KBPLANNER_CACHE_DIR/project/KEY/`` when that variable is set; the IFC import
  cache lives beside it. ``graphs.pickle`` is the entry's own: written by the first command that reads
  the entry with rdflib (the graphs that parsing its N-Triples gives, their merge and their stamp;
  commands on Oxigraph never need it), read only from an entry whose key matches and only
  if it bears this user's seal (:mod:`kbplanner.core.cache_seal`: a project folder copied from
  elsewhere with its cache never gets its pickle unpickled; the entry is loaded again and replaced).
- Off: ``KBPLANNER_NO_CACHE=1`` (``kbplanner --no-cache``): nothing is read from or written to it.
- Key: SHA-256 of the cache format, kbplanner's version, the source of the loading code (``core``,
  ``model``, ``knowledge``) and the named queries, the project directory, the scenario, and the
  bytes of every declared input (``project.toml``, the IFC, the schedule, site, jobsite,
  augmentation, scenario and project KB Turtle, the shipped ontology and shapes). Files read through
  ``owl:imports`` are listed in ``meta.json`` with their hashes and checked at each use; any change
  makes a new load (and replaces the entry).
- Rows of the named queries the world tables read (A6, :func:`kbplanner.world.tables.world_tables`) are
  kept beside the graphs (``rows/NAME.BACKEND.json``), each with a hash of the graphs they were read
  from, and used only while the project's graphs still hash the same.
- Safe with two commands at once: an entry is written into a temporary folder and renamed into place
  in one step, so a reader sees a whole entry or none; a failed read or write falls back to a full
  load (a write that fails is logged, never an error).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rdflib import Graph
from rdflib.exceptions import ParserError

from kbplanner.core.resources import data_dir, ontology_files
from kbplanner.core.version import __version__
from kbplanner.model.graph_pickle import (
    GRAPHS,
    KeptMemory,
    dump_graphs,
    keep_graphs,
    load_graphs,
    merged_graph,
    note_edits,
    umask,
    unedited,
)
from kbplanner.model.kept_rows import META, ROWS, graphs_stamp, read_rows, write_rows

if TYPE_CHECKING:
    from kbplanner.model.project_manifest import Manifest

__all__ = ["GRAPHS", "META", "ROWS", "CacheEntry", "CachedProject", "KeptMemory", "dump_graphs", "entry_dir",
           "entry_key", "graphs_stamp", "keep_graphs", "load_graphs", "merged_graph", "read_entry",
           "read_rows", "unedited", "write_entry", "write_rows"]

log = logging.getLogger(__name__)

FORMAT = "2"
NO_CACHE_ENV = "KBPLANNER_NO_CACHE"
SUBDIR = "project"
MODEL_NT, KB_NT = "model.nt", "kb.nt"
# The code that builds the graphs, and the named queries (the schedule reads one; the kept rows are theirs).
_CODE_FILES = (("core", "*.py"), ("model", "*.py"), ("knowledge", "*.py"), ("queries", "*.rq"))


@dataclass
class CachedProject:
    """The graphs and paths of a loaded project, as the project loader builds them."""

    model: Graph
    kb: Graph
    import_dir: Path
    kb_files: list[Path]


def enabled() -> bool:
    """Whether the project cache is used (``KBPLANNER_NO_CACHE`` unset, empty or ``0``)."""
    return os.environ.get(NO_CACHE_ENV, "").strip() in ("", "0")


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


_code_digest_memo: list[str] = []


def code_digest() -> str:
    """SHA-256 of the source of the packages that build a project's graphs and of the named queries (a
    change of the code between releases invalidates the cache as a version change does)."""
    if not _code_digest_memo:
        root = Path(__file__).resolve().parents[1]
        h = hashlib.sha256()
        for pkg, pattern in _CODE_FILES:
            for path in sorted((root / pkg).rglob(pattern)):
                h.update(path.relative_to(root).as_posix().encode())
                h.update(path.read_bytes())
        _code_digest_memo.append(h.hexdigest())
    return _code_digest_memo[0]


def declared_inputs(manifest: Manifest, scenario: str | None) -> list[Path]:
    """Every file a load of ``manifest`` (with ``scenario``) reads, as the manifest and kbplanner name
    them (files reached through ``owl:imports`` come on top)."""
    files: list[Path] = [manifest.path, manifest.ifc]
    if manifest.schedule is not None:
        files.append(manifest.schedule)
    files += [*manifest.site, *manifest.jobsite, *manifest.augmentation, *manifest.knowledge_base]
    if scenario is not None:
        files += list(manifest.scenarios[scenario].overlays)
    files += ontology_files()
    files += sorted(data_dir("shapes").rglob("*.ttl"))  # the numeric rule's ranges
    return files


def entry_key(manifest: Manifest, scenario: str | None) -> str:
    """The cache key of a project and scenario: a hash of the code, version and declared inputs."""
    h = hashlib.sha256()
    for part in (FORMAT, __version__, code_digest(), str(manifest.directory.resolve()), scenario or "",
                 manifest.base):
        h.update(part.encode("utf-8") + b"\0")
    for path in declared_inputs(manifest, scenario):
        h.update(f"{Path(path).resolve()}={_sha256(path)}".encode() + b"\0")
    return h.hexdigest()[:24]


def entry_dir(root: Path, manifest: Manifest, scenario: str | None) -> Path:
    """The folder of a project's cache entry under the cache ``root``."""
    return root / SUBDIR / entry_key(manifest, scenario)


# ---- reading -------------------------------------------------------------------------------------

class _SameLabels(dict[str, str]):
    """An N-Triples blank-node context that keeps the file's labels (rdflib would make new ones), so
    that graphs read from one entry by rdflib and by Oxigraph name the same nodes."""

    def get(self, key: str, default: Any = None) -> str:
        del default
        return key


def _graph(path: Path, namespaces: Sequence[Sequence[str]]) -> Graph:
    g = Graph()
    for prefix, ns in namespaces:
        g.bind(prefix, ns, override=True, replace=True)
    g.parse(path, format="nt", bnode_context=_SameLabels())
    return g


@dataclass
class CacheEntry:
    """A whole cache entry: the knowledge base read; the model graph (and, where rdflib holds the
    graphs, the merged graph) read with it from ``graphs.pickle``, or on request from ``model.nt``."""

    path: Path
    meta: dict[str, Any]
    kb: Graph
    import_dir: Path
    kb_files: list[Path]
    model: Graph | None = None
    merged: Graph | None = None
    stamp: str = ""  # graphs_stamp of model and kb, when read with them

    def graphs(self, store: str | None) -> tuple[Graph, Graph | None] | None:
        """The model graph, and the merged model + knowledge-base graph: the pickled one (rdflib), or,
        where ``store`` is an in-memory Oxigraph, read straight into it
        (:func:`kbplanner.core.stores.place_files`; else ``None``: the loader places or merges as
        after a full load). ``None`` when the entry cannot be read (removed meanwhile): the caller
        loads from the inputs."""
        if store is None and self.model is not None:
            return self.model, self.merged
        try:
            if store is not None:
                from kbplanner.core.stores import place_files

                placed = place_files(store, self.path / MODEL_NT, self.path / KB_NT)
                if placed is not None:
                    return placed
            model = _graph(self.path / MODEL_NT, self.meta["model_namespaces"])
        except (OSError, ValueError, SyntaxError, ParserError) as exc:  # removed or damaged meanwhile
            log.info("project cache %s not used: %s", self.path, exc)
            return None
        if len(model) != self.meta["model_triples"]:
            return None
        return model, None


def read_entry(entry: Path, store: str | None = None) -> CacheEntry | None:
    """The project kept in ``entry``, or ``None`` when there is none, it is incomplete or any file it
    records as read through ``owl:imports`` changed. With rdflib in memory (``store`` None) the graphs
    are unpickled (a damaged pickle: ``None``, the entry is replaced by the full load); with another
    store the knowledge base is parsed from ``kb.nt``."""
    try:
        meta: dict[str, Any] = json.loads((entry / META).read_text(encoding="utf-8"))
        if meta.get("format") != FORMAT:
            return None
        for name, digest in meta["extra_reads"].items():
            if not Path(name).is_file() or _sha256(Path(name)) != digest:
                log.info("project cache %s: %s changed", entry, name)
                return None
        import_dir = Path(meta["import_dir"])
        if not import_dir.is_dir() or not (entry / MODEL_NT).is_file():
            return None
        model = merged = None
        stamp = ""
        if store is None and (entry / GRAPHS).is_file():
            model, kb, merged, stamp = _unpickled(entry)
            if len(model) != meta["model_triples"]:
                return None
        else:
            kb = _graph(entry / KB_NT, meta["kb_namespaces"])
        if len(kb) != meta["kb_triples"]:
            return None
        if store is None and model is None:  # the first read by rdflib: parsed, merged, kept pickled
            model = _graph(entry / MODEL_NT, meta["model_namespaces"])
            if len(model) != meta["model_triples"]:
                return None
            merged = merged_graph(model, kb)
            stamp = graphs_stamp(model, kb)
            keep_graphs(entry, model, kb, merged, stamp)
            note_edits(model, kb)
    except (OSError, ValueError, KeyError, TypeError, ParserError) as exc:  # missing, half-removed, damaged
        log.info("project cache %s not used: %s", entry, exc)
        return None
    log.info("project from cache %s", entry)
    return CacheEntry(path=entry, meta=meta, kb=kb, import_dir=import_dir,
                      kb_files=[Path(p) for p in meta["kb_files"]], model=model, merged=merged, stamp=stamp)


def _unpickled(entry: Path) -> tuple[Graph, Graph, Graph, str]:
    try:
        return load_graphs(entry / GRAPHS)
    except OSError:
        raise
    except Exception as exc:  # a damaged pickle raises about anything: the entry is not used
        raise ValueError(f"{entry / GRAPHS}: {exc}") from None


# ---- writing -------------------------------------------------------------------------------------

def owner_of(manifest: Manifest, scenario: str | None) -> str:
    """What an entry is of: the project directory and the scenario (older entries of it are removed)."""
    return f"{manifest.directory.resolve()}|{scenario or ''}"


def write_entry(entry: Path, project: CachedProject, reads: Iterable[Path], declared: Iterable[Path],
                owner: str = "") -> bool:
    """Keep ``project`` in ``entry`` (atomically: a temporary folder renamed into place); ``reads`` are
    the Turtle files the load parsed, those not among ``declared`` are recorded with their hashes.
    Other entries of the same ``owner`` (:func:`owner_of`; made before an input changed) are removed,
    so the cache holds one entry per project and scenario. Returns whether the entry was written; an
    error is logged, not raised (the cache is an aid)."""
    known = {Path(p).resolve() for p in declared}
    extra = {str(Path(p).resolve()): _sha256(Path(p)) for p in reads if Path(p).resolve() not in known}
    meta: dict[str, Any] = {
        "format": FORMAT,
        "kbplanner": __version__,
        "owner": owner,
        "import_dir": str(project.import_dir.resolve()),
        "kb_files": [str(p) for p in project.kb_files],
        "extra_reads": dict(sorted(extra.items())),
        "model_triples": len(project.model),
        "kb_triples": len(project.kb),
        "model_namespaces": [[p, str(ns)] for p, ns in project.model.namespaces()],
        "kb_namespaces": [[p, str(ns)] for p, ns in project.kb.namespaces()],
    }
    tmp: Path | None = None
    try:
        entry.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{entry.name}.", dir=entry.parent))
        project.model.serialize(tmp / MODEL_NT, format="nt", encoding="utf-8")
        project.kb.serialize(tmp / KB_NT, format="nt", encoding="utf-8")
        (tmp / META).write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")  # last: marks it whole
        os.chmod(tmp, 0o777 & ~umask())
        if entry.exists():  # a stale entry (an owl:imports file changed): move it aside first
            stale = Path(tempfile.mkdtemp(prefix=f".{entry.name}.stale.", dir=entry.parent))
            os.replace(entry, stale / "entry")
            shutil.rmtree(stale, ignore_errors=True)
        os.rename(tmp, entry)
        tmp = None
        log.info("project cached in %s", entry)
        if owner:
            _remove_older(entry, owner)
        return True
    except OSError as exc:  # read-only project, full disk, or another command placed it first
        if entry.is_dir() and (entry / META).is_file():
            return True
        log.info("project cache not written (%s): %s", entry, exc)
        return False
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


def _remove_older(entry: Path, owner: str) -> None:
    """Remove the other entries of ``owner`` beside ``entry`` (moved aside first: a reader sees a whole
    entry or none)."""
    for other in entry.parent.iterdir():
        if other == entry or other.name.startswith("."):
            continue
        try:
            if json.loads((other / META).read_text(encoding="utf-8")).get("owner") != owner:
                continue
            stale = Path(tempfile.mkdtemp(prefix=f".{other.name}.stale.", dir=entry.parent))
            os.replace(other, stale / "entry")
            shutil.rmtree(stale, ignore_errors=True)
        except (OSError, ValueError, AttributeError):  # removed meanwhile, or not an entry
            continue


