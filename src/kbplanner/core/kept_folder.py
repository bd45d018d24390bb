"""Results kept on disk (all steps that keep them: configuration spaces, storey maps): the folder a block
reads and writes, and the digest of the code whose results are kept (a change of that code is a new key)."""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Iterator, Sequence
from pathlib import Path


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
