"""The output rule (every step that writes): where kbplanner may write, and run directories.

``--out`` must be a new path, an empty folder, or a folder that kbplanner wrote before (it holds a
``.kbplanner-run`` marker: the command, the version and the files kbplanner wrote there). Anything else is
refused with :class:`OutputError` (exit 2) before any work is done: a project folder, the current folder
(or one holding it), an existing file, a path below a file, a symbolic link, a folder of someone else's
files (unless ``--force``). ``--force`` lets kbplanner write into a folder of other files, and still never
deletes, moves or overwrites a file that kbplanner did not write: a name clash stops the run.

A run directory is assembled in ``DIR.partial`` and installed only when complete. Installing replaces
only the files kbplanner wrote before (listed in the marker); other files in the folder are kept. A
failure (including an unwritable target) removes ``DIR.partial`` and leaves ``DIR`` as it was.
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from kbplanner.core.errors import KbplannerError

MARKER = ".kbplanner-run"
PARTIAL_SUFFIX = ".partial"
PROJECT_MANIFEST = "project.toml"
# Files kbplanner writes into a single-file output (--report, --template) start with this text.
FILE_SIGNATURE = "# Written by kbplanner"

_FORCE: contextvars.ContextVar[bool] = contextvars.ContextVar("kbplanner_force", default=False)
_COMMAND: contextvars.ContextVar[str] = contextvars.ContextVar("kbplanner_command",
                                                              default="kbplanner (Python API)")


class OutputError(KbplannerError):
    """An output path that kbplanner must not or cannot write (exit 2, nothing touched)."""


@contextmanager
def output_options(*, force: bool = False, command: str | None = None) -> Iterator[None]:
    """Within the block, run directories accept ``--force`` and record ``command`` in their marker."""
    t1 = _FORCE.set(force)
    t2 = _COMMAND.set(command or _COMMAND.get())
    try:
        yield
    finally:
        _FORCE.reset(t1)
        _COMMAND.reset(t2)


def current_command() -> str:
    """The command run directories record in their marker here (set by :func:`output_options`)."""
    return _COMMAND.get()


def _version() -> str:
    from kbplanner.core.version import __version__

    return __version__


def _absolute(path: Path) -> Path:
    return Path(os.path.abspath(path))


def read_marker(directory: Path) -> set[str] | None:
    """The files kbplanner wrote into ``directory`` (relative POSIX paths), or None without a marker."""
    marker = Path(directory) / MARKER
    if not marker.is_file() or marker.is_symlink():
        return None
    try:
        data = json.loads(marker.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("written_by") != "kbplanner" or data.get("partial"):
        return None
    files = data.get("files")
    return {str(f) for f in files} if isinstance(files, list) else set()


def _marker_text(files: set[str], *, partial: bool = False) -> str:
    data: dict[str, object] = {"written_by": "kbplanner", "version": _version(), "command": _COMMAND.get()}
    if partial:
        data["partial"] = True
    else:
        data["files"] = sorted(files)
    return json.dumps(data, indent=2, sort_keys=True, allow_nan=False) + "\n"


@dataclass
class _Contents:
    files: set[str] = field(default_factory=set)  # every non-directory entry (files, links), relative
    dirs: set[str] = field(default_factory=set)


def _contents(root: Path) -> _Contents:
    out = _Contents()
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        rel = Path(dirpath).relative_to(root)
        for d in list(dirnames):
            if (Path(dirpath) / d).is_symlink():
                out.files.add((rel / d).as_posix())
                dirnames.remove(d)
            else:
                out.dirs.add((rel / d).as_posix())
        for f in filenames:
            out.files.add((rel / f).as_posix())
    out.files.discard(MARKER)
    return out


def _parents(files: set[str]) -> set[str]:
    out: set[str] = set()
    for f in files:
        p = Path(f).parent
        while str(p) not in (".", ""):
            out.add(p.as_posix())
            p = p.parent
    return out


def _foreign(contents: _Contents, owned: set[str]) -> list[str]:
    """Entries of a folder that kbplanner did not write (files, links and folders holding none of ours)."""
    ours = owned & contents.files
    keep = _parents(ours)
    files = sorted(contents.files - ours)
    dirs = sorted(d for d in contents.dirs - keep if not any(f.startswith(d + "/") for f in files))
    return files + dirs


def _cwd_inside(path: Path) -> bool:
    try:
        Path.cwd().resolve().relative_to(path.resolve())
    except (ValueError, OSError):
        return False
    return True


def check_output_dir(out: Path | str, *, option: str = "--out") -> None:
    """Refuse an output folder that the output rule does not allow (see the module docstring).

    Raises:
        OutputError: with why and what to pass instead; nothing is touched.
    """
    out = Path(out)
    path = _absolute(out)
    if path.is_symlink():
        raise OutputError(f"{option} is a symbolic link", file=out, element=option,
                          fix="give the folder it points to, or a new folder")
    if path.exists() and not path.is_dir():
        raise OutputError(f"{option} is an existing file, not a folder", file=out, element=option,
                          fix="give a new folder name; kbplanner never replaces a file it did not write")
    for parent in path.parents:
        if parent.exists() or parent.is_symlink():
            if not parent.is_dir():
                raise OutputError(f"{option} is below a file ({parent})", file=out, element=option,
                                  fix="give a path whose parent folders are folders")
            break
    if path.exists() and _cwd_inside(path):
        raise OutputError(f"{option} is the current folder or holds it", file=out, element=option,
                          fix="give a new folder, e.g. --out runs/NAME")
    if not path.is_dir():
        probe_writable(next(p for p in path.parents if p.exists()), out)
        return
    owned = read_marker(path)
    try:
        contents = _contents(path)
    except OSError as exc:
        raise OutputError(f"{option} cannot be read ({exc.strerror})", file=out, element=option,
                          fix="give a folder you can read and write") from None
    if PROJECT_MANIFEST in contents.files and PROJECT_MANIFEST not in (owned or set()):
        raise OutputError(f"{option} is a project folder (it holds project.toml)", file=out, element=option,
                          fix="give a new folder for the results, e.g. --out runs/NAME")
    if owned is None and (contents.files or contents.dirs) and not _FORCE.get():
        foreign = _foreign(contents, set())
        example = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
        raise OutputError(
            f"{option} is a folder that kbplanner did not write ({len(foreign)} "
            f"{'entry' if len(foreign) == 1 else 'entries'}: {example})",
            file=out, element=option,
            fix="give a new folder, or pass --force to write into it (your files are kept; a name clash "
                "stops the run)")
    probe_writable(path.parent, out)  # the staging folder goes beside it
    probe_writable(path, out)


def probe_writable(folder: Path, out: Path | str) -> None:
    """Refuse before any work a folder where nothing can be created (permissions, read-only, immutable)."""
    try:
        Path(tempfile.mkdtemp(prefix=".kbplanner-probe-", dir=folder)).rmdir()
    except OSError as exc:
        raise OutputError(f"cannot write into {folder} ({exc.strerror or exc})", file=out, element="--out",
                          fix="give a folder you can write to (check permissions, a read-only or "
                              "immutable folder)") from None


def check_output_file(path: Path | str, *, option: str) -> None:
    """Refuse a single-file output that is a folder, below a file, or a file kbplanner did not write."""
    path = Path(path)
    full = _absolute(path)
    if full.is_dir():
        raise OutputError(f"{option} is a folder, not a file", file=path, element=option,
                          fix=f"give a file name, e.g. {option} {path / 'out.ttl'}")
    for parent in full.parents:
        if parent.exists():
            if not parent.is_dir():
                raise OutputError(f"{option} is below a file ({parent})", file=path, element=option,
                                  fix="give a path whose parent folders are folders")
            break
    if full.is_symlink() or (full.exists() and not _signed(full)):
        raise OutputError(f"{option} is an existing file that kbplanner did not write", file=path,
                          element=option, fix="give a new file name; kbplanner never replaces your files")
    probe_writable(next(p for p in full.parents if p.exists()), path)


def _signed(path: Path) -> bool:
    try:
        with open(path, "rb") as fh:
            return fh.read(len(FILE_SIGNATURE)).decode("utf-8", "replace") == FILE_SIGNATURE
    except OSError:
        return False


def _os_error(exc: OSError, out: Path) -> OutputError:
    where = exc.filename if exc.filename is not None else out
    return OutputError(f"cannot write the output ({exc.strerror or exc})", file=where, element="--out",
                       fix="give a folder you can write to (check permissions, free space, a read-only "
                           "or immutable folder)")


def _remove_stage(stage: Path) -> None:
    shutil.rmtree(stage, ignore_errors=True)


def _about_output(exc: OSError, stage: Path, path: Path) -> bool:
    """Whether an OSError concerns the output (the staging folder, the target or its parent)."""
    if exc.filename is None:
        return False
    name = _absolute(Path(os.fsdecode(exc.filename)))
    return any(name == p or p in name.parents for p in (stage, path)) or name == path.parent


def _make_stage(out: Path, path: Path) -> Path:
    stage = path.with_name(path.name + PARTIAL_SUFFIX)
    if stage.is_symlink() or (stage.exists() and not stage.is_dir()):
        raise OutputError(f"{stage.name} exists and is not kbplanner's staging folder", file=stage,
                          element="--out", fix="remove or rename it, or give another --out")
    if stage.is_dir():
        marker = stage / MARKER
        text = marker.read_text(encoding="utf-8") if marker.is_file() else ""
        if '"partial": true' not in text:
            raise OutputError(f"{stage.name} exists and is not kbplanner's staging folder", file=stage,
                              element="--out", fix="remove or rename it, or give another --out")
        shutil.rmtree(stage)  # left behind by a killed run
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        stage.mkdir()
    except OSError as exc:
        raise _os_error(exc, out) from None
    try:
        (stage / MARKER).write_text(_marker_text(set(), partial=True), encoding="utf-8")
    except OSError as exc:
        _remove_stage(stage)
        raise _os_error(exc, out) from None
    return stage


def _install(stage: Path, path: Path, out: Path, *, replace: bool) -> None:
    (stage / MARKER).unlink()
    new = _contents(stage).files
    if not path.exists():
        (stage / MARKER).write_text(_marker_text(new), encoding="utf-8")
        os.replace(stage, path)
        return
    owned = read_marker(path) or set()
    contents = _contents(path)
    foreign = _foreign(contents, owned)
    clash = sorted(f for f in foreign
                   if f in new or any(n.startswith(f + "/") for n in new) or any(f.startswith(n + "/")
                                                                                  for n in new))
    if clash:
        raise OutputError(
            f"the output would replace file(s) that kbplanner did not write: {', '.join(clash[:5])}",
            file=out, element="--out", fix="move those files away, or give a new folder")
    if replace and not foreign:  # the folder holds only our files: swap it in whole
        (stage / MARKER).write_text(_marker_text(new), encoding="utf-8")
        old = Path(tempfile.mkdtemp(prefix=f".{path.name}.old-", dir=path.parent))
        try:
            os.replace(path, old / "d")
        except OSError:
            old.rmdir()
            raise
        try:
            os.replace(stage, path)
        except OSError:
            os.replace(old / "d", path)  # put the earlier run back
            old.rmdir()
            raise
        shutil.rmtree(old, ignore_errors=True)
        return
    # Merge: other files stay where they are; ours are replaced file by file.
    ours = owned & contents.files
    for rel in sorted(ours - new) if replace else []:
        (path / rel).unlink(missing_ok=True)
    for rel in sorted(new):
        target = path / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(stage / rel, target)
    for d in sorted(_parents(ours - new) if replace else set(), key=lambda s: -s.count("/")):
        with contextlib.suppress(OSError):
            (path / d).rmdir()  # only folders left empty by removing our files
    files = new | (set() if replace else ours)
    tmp = path / f".{MARKER}.tmp"
    tmp.write_text(_marker_text(files), encoding="utf-8")
    os.replace(tmp, path / MARKER)
    shutil.rmtree(stage, ignore_errors=True)


@contextmanager
def run_directory(out: Path | str, *, replace: bool = True) -> Iterator[Path]:
    """Yield a staging folder whose files are installed into ``out`` only if the block completes.

    ``out`` is checked by the output rule first (:func:`check_output_dir`). With ``replace`` the files
    kbplanner wrote into ``out`` before are replaced by the new ones; without, the new files are added.

    Example:
        >>> import tempfile
        >>> d = Path(tempfile.mkdtemp()) / "run"
        >>> with run_directory(d) as stage:
        ...     _ = (stage / "a.txt").write_text("ok")
        >>> (d / "a.txt").read_text()
        'ok'
    """
    out = Path(out)
    check_output_dir(out)
    path = _absolute(out)
    stage = _make_stage(out, path)
    try:
        yield stage
        _install(stage, path, out, replace=replace)
    except OSError as exc:
        _remove_stage(stage)
        if not _about_output(exc, stage, path):
            raise
        raise _os_error(exc, out) from None
    except BaseException:
        _remove_stage(stage)
        raise
