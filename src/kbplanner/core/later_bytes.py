"""Writing results (B5 key frames): bytes that another process is still producing.

A :class:`LaterBytes` stands where a ``bytes`` value is expected (it is one, empty) while a worker
process produces the real content - a key frame PNG rendered beside the simulation step. Its content
is :meth:`LaterBytes.result`, which waits for the worker; :func:`kbplanner.core.outputs.atomic_write_bytes`
writes that, so a value handed straight to the writer needs no change by its holder. Anything else
that reads one must call :func:`resolved` first: its own bytes are empty.

Example:
    >>> later = LaterBytes(lambda: b"done")
    >>> resolved(later), resolved(b"now")
    (b'done', b'now')
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["LaterBytes", "resolved"]


class LaterBytes(bytes):
    """A stand-in for bytes that ``wait`` gives (once, when first asked); ``discard`` frees the worker
    when they are never asked for (the holder was dropped after an error)."""

    _wait: Callable[[], bytes] | None
    _discard: Callable[[], None] | None
    _value: bytes | None

    def __new__(cls, wait: Callable[[], bytes], discard: Callable[[], None] | None = None) -> LaterBytes:
        obj = super().__new__(cls, b"")
        obj._wait, obj._discard, obj._value = wait, discard, None
        return obj

    def result(self) -> bytes:
        """The content: waits for the worker the first time."""
        if self._value is None:
            wait, self._wait, self._discard = self._wait, None, None
            assert wait is not None
            self._value = wait()
        return self._value

    def __del__(self) -> None:
        discard, self._discard = getattr(self, "_discard", None), None
        if discard is not None:
            discard()

    def __reduce__(self) -> tuple[Any, ...]:  # a copy or a pickle carries the content
        return (bytes, (self.result(),))


def resolved(data: bytes) -> bytes:
    """``data`` itself, or a :class:`LaterBytes`' content (waiting for it)."""
    return data.result() if isinstance(data, LaterBytes) else data
