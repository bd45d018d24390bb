"""``kbplanner import-ifc MODEL.ifc --out PROJECT_DIR [--name NAME]``: import an IFC model into a project.

Writes ``PROJECT_DIR/model.ttl``, ``PROJECT_DIR/meshes/`` and ``skipped.json`` + ``skipped.csv`` (every
element left out or without geometry, and every note: unreadable optional data, implausible masses,
doors without a host), and a starter ``project.toml`` naming the IFC when the directory has none. An
existing ``project.toml`` is kept and its project name (or ``base_iri``) decides the IRIs, so the
import matches what the project loader builds. Prints counts per class, storeys with elevations, the
units, skipped elements and notes.

Exit 2 on bad input; exit 1 (a negative result, the import is still written) when an element of a
class tasks use (walls, doors, windows, slabs, spaces, stairs, members, ...; see
``kbplanner.model.ifc_report.TASK_IFC_CLASSES``) was skipped or has no geometry; else 0.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.cli.arguments import positive_int
from kbplanner.core.errors import IfcError, ProjectError
from kbplanner.core.output_dirs import probe_writable

if TYPE_CHECKING:
    from kbplanner.model.ifc_import import ImportResult

MANIFEST = "project.toml"
NOTES_SHOWN = 20


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "import-ifc",
        help="import an IFC model (IFC2X3/IFC4) into a project directory: model.ttl + meshes/",
    )
    p.add_argument("model", type=Path, help="the IFC file (.ifc)")
    p.add_argument("--out", type=Path, required=True, metavar="PROJECT_DIR",
                   help="project directory to write model.ttl, meshes/ (and a starter project.toml) into")
    p.add_argument("--name", help="project name (default: the name in PROJECT_DIR/project.toml, "
                                  "else the IFC file's name)")
    p.add_argument("--processes", type=positive_int, default=1,
                   help="geometry worker processes (default 1)")
    p.set_defaults(func=run)


def _existing_manifest(path: Path) -> tuple[str | None, str | None]:
    """(name, base_iri) of an existing project.toml."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ProjectError(f"cannot read the existing project.toml: {exc}", file=path,
                           fix="correct the TOML syntax, or remove the file to get a starter one") from None
    project = data.get("project") or {}
    name = project.get("name")
    base = project.get("base_iri")
    return (str(name) if name else None), (str(base) if base else None)


def check_import_target(out: Path) -> None:
    """The output rule for an import: model.ttl and meshes/ may only replace an earlier import.

    Raises:
        IfcError: a parent of ``out`` is a file, ``model.ttl`` is not an import's, or ``meshes/`` holds
            files that are not meshes (the import replaces the folder), so nothing of the user's is lost.
    """
    from kbplanner.model.ifc_import import MESH_DIR, MODEL_FILE

    for parent in Path(os.path.abspath(out)).parents:
        if parent.exists():
            if not parent.is_dir():
                raise IfcError(f"--out is below a file ({parent})", file=out, element="--out",
                               fix="give a project directory whose parents are folders")
            break
    probe_writable(out if out.is_dir() else next(p for p in Path(os.path.abspath(out)).parents if p.exists()),
                   out)
    model = out / MODEL_FILE
    if model.is_symlink() or model.is_dir() or (model.exists() and not _is_import(model)):
        raise IfcError(f"{MODEL_FILE} exists and was not written by an import", file=model, element="--out",
                       fix="move your file away, or import into a new project directory")
    meshes = out / MESH_DIR
    if meshes.is_symlink() or (meshes.exists() and not meshes.is_dir()):
        raise IfcError(f"{MESH_DIR} exists and is not a folder of meshes", file=meshes, element="--out",
                       fix="move it away, or import into a new project directory")
    if meshes.is_dir():
        other = sorted(p.name for p in meshes.iterdir() if p.suffix != ".glb" or not p.is_file()
                       or p.is_symlink())
        if other:
            raise IfcError(f"{MESH_DIR}/ holds files that an import did not write: {', '.join(other[:3])}",
                           file=meshes, element="--out",
                           fix="move them away (an import replaces meshes/), or import into a new directory")


def _is_import(path: Path) -> bool:
    """Whether ``path`` starts as every model.ttl of an import does."""
    from rdflib import Graph

    from kbplanner.model import ifc_turtle

    first = ifc_turtle.serialize(Graph()).split(b"\n", 1)[0]
    try:
        with open(path, "rb") as fh:
            return fh.read(len(first) + 1) == first + b"\n"
    except OSError:
        return False


def starter_manifest(name: str, ifc_relative: str) -> str:
    """Text of a starter project.toml (TOML basic strings are JSON strings)."""
    return (
        "# Written by 'kbplanner import-ifc'; see docs/projects.md for schedule, site layout and scenarios.\n"
        "[project]\n"
        f"name = {json.dumps(name, ensure_ascii=False)}\n"
        "\n"
        "[model]\n"
        f"ifc = {json.dumps(ifc_relative, ensure_ascii=False)}   # relative to the project directory\n"
    )


def run(args: argparse.Namespace) -> int:
    from rich.progress import Progress

    from kbplanner.core.iris import base_iri
    from kbplanner.core.outputs import atomic_write_text
    from kbplanner.model.ifc_import import import_ifc

    model: Path = args.model
    out: Path = args.out
    if args.processes < 1:
        raise IfcError("--processes must be at least 1", element=str(args.processes),
                       fix="use --processes 1 (or 2 on a machine with two cores or more)")
    if out.exists() and not out.is_dir():
        raise IfcError("--out names a file, not a directory", file=out, fix="give a project directory")
    check_import_target(out)
    manifest = out / MANIFEST
    existing_name, existing_base = _existing_manifest(manifest) if manifest.is_file() else (None, None)
    if args.name and existing_name and args.name != existing_name:
        raise ProjectError(
            f"project.toml already names the project {existing_name!r}, not {args.name!r}", file=manifest,
            element="project.name",
            fix="drop --name (the existing name is used), or change the name in project.toml",
        )
    name = args.name or existing_name or model.stem
    base = existing_base or base_iri(name)

    # A progress bar only on an interactive terminal; piped output stays plain.
    progress_bar = Progress(transient=True) if sys.stderr.isatty() else None
    if progress_bar is not None:
        with progress_bar:
            task = progress_bar.add_task("geometry", total=None)

            def report(done: int, total: int) -> None:
                progress_bar.update(task, completed=done, total=total)

            result = import_ifc(model, out, base=base, progress=report, processes=args.processes)
    else:
        result = import_ifc(model, out, base=base, processes=args.processes)

    wrote_manifest = False
    if not manifest.exists():
        relative = Path(os.path.relpath(model.resolve(), out.resolve())).as_posix()
        atomic_write_text(manifest, starter_manifest(name, relative))
        wrote_manifest = True
    sys.stdout.write(summary(result, out, name, wrote_manifest))
    return 1 if result.blocking else 0


def summary(result: ImportResult, out: Path, name: str, wrote_manifest: bool) -> str:
    """The text the command prints after an import."""
    from kbplanner.model.ifc_import import MESH_DIR, MODEL_FILE
    from kbplanner.model.ifc_report import SKIPPED_CSV

    units = result.units
    unit_text = (f"length unit {units.length_name} = {units.length_m:g} m, mass unit {units.mass_name} = "
                 f"{units.mass_kg:g} kg" if units is not None else f"length unit {result.length_unit_m:g} m")
    lines = [
        f"Imported {result.source.name} ({result.schema}, {unit_text}) into {out} in {result.seconds:.1f} s",
        f"  {MODEL_FILE}: {len(result.graph)} triples; {MESH_DIR}/: {len(result.meshes)} meshes",
        "Counts per class:",
    ]
    width = max((len(k) for k in result.counts), default=0)
    lines += [f"  {cls:<{width}}  {n:>5}" for cls, n in result.counts.items()]
    lines.append("Storeys (elevation, m):")
    lines += [f"  {s.name or s.global_id:<20} {s.elevation_m:>8.3f}" for s in result.storeys]
    if result.skipped:
        lines.append(f"Skipped or without geometry ({len(result.skipped)}; {len(result.blocking)} of classes "
                     "tasks use):")
        lines += [f"  {s.global_id} {s.ifc_class} {s.name!r}"
                  f"{' (in the graph)' if s.in_graph else ' (left out)'}: {s.reason}" for s in result.skipped]
    else:
        lines.append("Skipped: none")
    if result.notes:
        lines.append(f"Notes ({len(result.notes)}; all in {SKIPPED_CSV}):")
        shown = result.notes[:NOTES_SHOWN]
        lines += [f"  {n.global_id} {n.ifc_class} {n.name!r} [{n.kind}]: {n.message}" for n in shown]
        if len(result.notes) > NOTES_SHOWN:
            lines.append(f"  ... and {len(result.notes) - NOTES_SHOWN} more")
    if result.blocking:
        lines.append(f"Negative result: {len(result.blocking)} element(s) of classes tasks use were skipped "
                     f"(see {SKIPPED_CSV}); fix them in the authoring tool and export again")
    lines.append(f"project.toml: {'written (project ' + repr(name) + ')' if wrote_manifest else 'kept'}")
    return "\n".join(lines) + "\n"
