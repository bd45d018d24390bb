"""Writing results (all steps): atomic files, strict JSON, run directories and the run manifest.

A file is written to a temporary sibling and renamed into place, with the mode that the umask gives;
a run directory is assembled in ``DIR.partial`` and installed only when the run completes
(:mod:`kbplanner.core.output_dirs`, the output rule), so a crashed or killed run never leaves a
half-written file that looks complete. JSON is strict: a NaN or infinity is refused, never written.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import platform
import tempfile
from importlib import metadata
from pathlib import Path
from typing import Any

from kbplanner.core.errors import KbplannerError
from kbplanner.core.later_bytes import resolved
from kbplanner.core.output_dirs import run_directory

__all__ = ["atomic_write_bytes", "atomic_write_text", "file_mode", "input_hashes", "json_text",
           "run_directory", "sha256_file", "versions", "write_json"]


def file_mode() -> int:
    """The mode of a new file under the process umask (``0o666 & ~umask``)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file in the same directory and ``os.replace``.

    ``data`` may be a :class:`~kbplanner.core.later_bytes.LaterBytes` (a key frame a worker process
    renders): its content is waited for first."""
    data = resolved(data)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            os.fchmod(fh.fileno(), file_mode())  # mkstemp makes 0600; a file gets what the umask gives
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: Path, text: str) -> None:
    """Write UTF-8 text atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def _non_finite(data: Any, where: str = "") -> str | None:
    """The path of the first NaN or infinity in ``data``, or None."""
    if isinstance(data, float) and not math.isfinite(data):
        return where or "(top level)"
    if isinstance(data, dict):
        items: list[tuple[str, Any]] = [(f"{where}.{k}" if where else str(k), v) for k, v in data.items()]
    elif isinstance(data, list | tuple):
        items = [(f"{where}[{i}]", v) for i, v in enumerate(data)]
    else:
        return None
    for w, v in items:
        found = _non_finite(v, w)
        if found is not None:
            return found
    return None


def json_text(data: Any, *, name: str = "JSON output", indent: int | None = 2, sort_keys: bool = True) -> str:
    """Strict JSON text (no NaN or Infinity): a non-finite number is an error naming where it is.

    Raises:
        KbplannerError: ``data`` holds a NaN or an infinity (it came from a number no site could have).
    """
    try:
        return json.dumps(data, indent=indent, sort_keys=sort_keys, default=str, ensure_ascii=False,
                          allow_nan=False)
    except ValueError:
        where = _non_finite(data) or "a value"
        raise KbplannerError(f"{name} would hold a non-finite number at {where}", element=where,
                             fix="check the numbers of the inputs (speeds, distances, sizes must be finite)"
                             ) from None


def write_json(path: Path, data: Any) -> None:
    """Write strict JSON (sorted keys, 2-space indent) atomically."""
    atomic_write_text(path, json_text(data, name=Path(path).name) + "\n")


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
    """Versions of Python and of the packages a run depends on (a new dict each call)."""
    return dict(_versions())


@functools.cache
def _versions() -> tuple[tuple[str, str], ...]:
    """The versions, read once per process (``importlib.metadata`` scans every installed distribution:
    a command asked twice, for the refined-plan cache's key and the run's manifest)."""
    out = [("python", platform.python_version())]
    for name in _PACKAGES:
        try:
            out.append((name, metadata.version(name)))
        except metadata.PackageNotFoundError:
            out.append((name, "not installed"))
    return tuple(out)


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
