"""Results kept on disk (all steps that keep them: configuration spaces, storey maps, cell paths, walking
legs): the folder a block reads and writes, the digest of the code whose results are kept (a change of that
code is a new key), reading a kept ``.npz`` and keeping only the newest files."""

from __future__ import annotations

import contextlib
import hashlib
import io
import logging
import os
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from kbplanner.core.outputs import atomic_write_bytes

log = logging.getLogger(__name__)


class KeptFolder:
    """A stack of folders: the innermost :meth:`kept_in` block's folder is :meth:`current`."""

    def __init__(self) -> None:
        self._stack: list[Path] = []

    @contextlib.contextmanager
    def kept_in(self, folder: Path | None) -> Iterator[None]:
        """Read and write kept files in ``folder`` while the block runs (None, or the cache off: neither)."""
        if folder is None or os.environ.get("KBPLANNER_NO_CACHE", "").strip() not in ("", "0"):
            yield
            return
        self._stack.append(Path(folder))
        try:
            yield
        finally:
            self._stack.pop()

    def current(self) -> Path | None:
        """The folder given by the innermost :meth:`kept_in`, or None."""
        return self._stack[-1] if self._stack else None


def code_digest(prefix: str, here: Path, names: Sequence[str]) -> bytes:
    """SHA-256 of ``prefix`` and each named source file of folder ``here`` (name, NUL, bytes, NUL)."""
    h = hashlib.sha256(prefix.encode())
    for name in names:
        h.update(name.encode() + b"\0" + (here / name).read_bytes() + b"\0")
    return h.digest()


def read_arrays(path: Path, fields: Mapping[str, Any], what: str) -> list[npt.NDArray[Any]] | None:
    """The named arrays of a kept ``.npz`` file (no pickle), in ``fields``' order, each as the dtype
    given (None: as stored); None where the file is missing or damaged (a damaged one is logged, made
    again and replaced by its writer; ``what`` names it in the message)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            return [np.asarray(data[name], dtype=dtype) for name, dtype in fields.items()]
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, EOFError) as exc:
        log.warning("ignoring the kept %s %s: %s", what, path.name, exc)
        return None


def write_arrays(path: Path, what: str, keep: int | None, **arrays: npt.ArrayLike) -> bool:
    """Keep ``arrays`` as the ``.npz`` file ``path`` (no pickle; written atomically: a process killed
    half-way leaves the file it had or none), then, with ``keep``, only the ``keep`` newest files of its
    folder. False where it could not be written (logged, naming ``what``; a result not kept is made
    again by the next run)."""
    buf = io.BytesIO()
    np.savez(buf, **arrays)  # type: ignore[arg-type]
    try:
        atomic_write_bytes(path, buf.getvalue())
        if keep is not None:
            keep_newest(path.parent, keep)
    except OSError as exc:
        log.warning("could not keep the %s in %s: %s", what, path.parent, exc)
        return False
    return True


def keep_newest(folder: Path, keep: int) -> None:
    """Remove all but the ``keep`` newest ``.npz`` files of a kept folder (kbplanner's own files)."""
    kept = sorted(folder.glob("*.npz"), key=lambda p: (p.stat().st_mtime_ns, p.name), reverse=True)
    for old in kept[keep:]:
        old.unlink(missing_ok=True)
