"""Writing results (all steps): atomic files and run directories, and the run manifest.

A file is written to a temporary sibling and renamed into place; a run directory is assembled in
``DIR.partial`` and renamed to ``DIR`` only when the run completes, so a crashed or killed run never
leaves a half-written file that looks complete.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from importlib import metadata
from pathlib import Path
from typing import Any


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file in the same directory and ``os.replace``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: Path, text: str) -> None:
    """Write UTF-8 text atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def write_json(path: Path, data: Any) -> None:
    """Write JSON (sorted keys, 2-space indent) atomically."""
    text = json.dumps(data, indent=2, sort_keys=True, default=str, ensure_ascii=False)
    atomic_write_text(path, text + "\n")


@contextmanager
def run_directory(out: Path) -> Iterator[Path]:
    """Yield a staging directory that replaces ``out`` only if the block completes.

    Example:
        >>> import tempfile
        >>> d = Path(tempfile.mkdtemp()) / "run"
        >>> with run_directory(d) as stage:
        ...     _ = (stage / "a.txt").write_text("ok")
        >>> (d / "a.txt").read_text()
        'ok'
    """
    out = Path(out)
    stage = out.with_name(out.name + ".partial")
    if stage.exists():
        shutil.rmtree(stage)
    stage.mkdir(parents=True)
    try:
        yield stage
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    old = out.with_name(out.name + ".old")
    if old.exists():
        shutil.rmtree(old)
    if out.exists():
        os.replace(out, old)
    os.replace(stage, out)
    if old.exists():
        shutil.rmtree(old)


def sha256_file(path: Path) -> str:
    """Hex SHA-256 of a file."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


_PACKAGES = ("kbplanner", "rdflib", "pyshacl", "owlready2", "ifcopenshell", "pybullet", "ompl",
             "trimesh", "numpy", "networkx", "pyoxigraph")


def versions() -> dict[str, str]:
    """Versions of Python and of the packages a run depends on."""
    out = {"python": platform.python_version()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def input_hashes(files: list[Path], root: Path) -> dict[str, str]:
    """SHA-256 of each input file, keyed by its path relative to ``root`` when possible."""
    out: dict[str, str] = {}
    for f in sorted(set(files)):
        try:
            key = str(f.resolve().relative_to(root.resolve()))
        except ValueError:
            key = str(f)
        out[key] = sha256_file(f)
    return out
