"""Progress on the command line (all steps): a live status on a terminal, plain lines elsewhere.

Rich's live displays print nothing when stderr is not a terminal (CI logs, ``nohup``, a pipe), so a
five-minute run would be silent. :func:`status` and :func:`counter` give the same callbacks either
way: on a terminal a spinner or bar, elsewhere one line per new message and at most one line per
``every_s`` seconds for counts (and the last count), each with the elapsed time.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import IO

from rich.console import Console


class PlainLines:
    """Progress as plain, time-stamped lines on a stream (no terminal control codes)."""

    def __init__(self, stream: IO[str], every_s: float = 5.0) -> None:
        self.stream = stream
        self.every_s = every_s
        self.t0 = time.monotonic()
        self.last_message = ""
        self.last_count_at = -1e9

    def _line(self, text: str) -> None:
        self.stream.write(f"[{time.monotonic() - self.t0:7.1f} s] {text}\n")
        self.stream.flush()

    def say(self, message: str) -> None:
        """A new stage or state: printed once (repeats of the same message are dropped)."""
        if message and message != self.last_message:
            self.last_message = message
            self._line(message)

    def count(self, label: str, done: int, total: int) -> None:
        """A count: printed at most once per ``every_s`` seconds, and when it is complete."""
        now = time.monotonic()
        if done >= total or now - self.last_count_at >= self.every_s:
            self.last_count_at = now
            self._line(f"{label}: {done}/{total}")


@contextmanager
def status(console: Console, first: str) -> Iterator[Callable[[str], None]]:
    """A ``say(message)`` callback: rich's spinner on a terminal, plain lines otherwise."""
    if console.is_terminal:
        with console.status(first) as live:
            yield lambda m: live.update(m)
        return
    lines = PlainLines(console.file)
    lines.say(first)
    yield lines.say


def plain_counter(console: Console) -> PlainLines | None:
    """Plain lines for counts when the console is not a terminal (``None`` on a terminal)."""
    return None if console.is_terminal else PlainLines(console.file)
