"""The loaded project's objects set aside from the cyclic garbage collector (all steps of a whole run).

A loaded scenario is millions of Python objects (graphs, terms, tables) that live until the run ends.
Python's cyclic collector visits every one of them at each full collection, which the allocations of
any later step start now and then: on the generated 10 x 8 building about a second each, 5-15 s of a
``kbplanner run``'s command process (its bare load, summary, validation and report) finding nothing.
:func:`set_aside` moves what is alive now into the collector's permanent generation (``gc.freeze``):
later full collections visit only what was made after. Nothing is freed that would have been, and
nothing is written differently; a cycle among the set-aside objects that becomes garbage is freed
only once :func:`frozen` ends (``gc.unfreeze``), or when the process ends. :func:`growing` does the
same during a load, after each full collection (what survives it is alive), so that a cold load's
collections visit only what was made since the last one instead of the whole, growing heap each time.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


def set_aside() -> None:
    """What is alive now (after a load whose results live on) set aside from full collections: the
    young generations collected first (so recent garbage is not kept), then frozen."""
    gc.collect(1)
    gc.freeze()


def _after_full(phase: str, info: dict[str, int]) -> None:
    if phase == "stop" and info.get("generation") == 2:
        gc.freeze()  # the survivors of a full collection: alive, set aside


@contextmanager
def growing() -> Iterator[None]:
    """A block that makes objects that live on (a load): after each full collection in it, what
    survived is set aside (as by :func:`set_aside`), and at its end what it made since the last."""
    gc.callbacks.append(_after_full)
    try:
        yield
    finally:
        gc.callbacks.remove(_after_full)
    set_aside()


@contextmanager
def frozen() -> Iterator[None]:
    """A block in which :func:`set_aside` may be called; at its end what was set aside goes back to
    the collector (only if nothing was set aside before it, so nested blocks leave the outer one's)."""
    outer = gc.get_freeze_count()
    try:
        yield
    finally:
        if outer == 0:
            gc.unfreeze()
