"""Store specs (all steps): the ``--store`` values and their parsing, without importing rdflib.

:mod:`kbplanner.core.stores` (the backends themselves) re-exports these names; this module stays
light so that the command line can register ``--store`` without loading a graph library.

Example:
    >>> parse_store("oxigraph:/tmp/g").location
    PosixPath('/tmp/g')
"""

from __future__ import annotations

import argparse
import urllib.parse
from dataclasses import dataclass
from pathlib import Path

from kbplanner.core.errors import KbplannerError

MEMORY = "memory"
OXIGRAPH = "oxigraph"
SPARQL = "sparql"
STORE_FORMS = "memory | oxigraph | oxigraph:DIR | sparql+http://HOST:PORT/query"


class StoreError(KbplannerError):
    """A store spec that cannot be used: unknown form, unreachable endpoint, refused upload."""


@dataclass(frozen=True)
class StoreSpec:
    """A parsed ``--store`` value."""

    kind: str                       # memory | oxigraph | sparql
    text: str = MEMORY
    location: Path | None = None    # oxigraph on disk
    query_url: str | None = None    # sparql endpoint
    update_url: str | None = None

    @property
    def is_memory(self) -> bool:
        """True for the default embedded rdflib store."""
        return self.kind == MEMORY


def parse_store(spec: str | StoreSpec | None) -> StoreSpec:
    """Parse a store spec (see the module docstring); ``None`` and ``""`` mean memory.

    Raises:
        StoreError: an unknown form.
    """
    if isinstance(spec, StoreSpec):
        return spec
    text = (spec or MEMORY).strip()
    if text == MEMORY:
        return StoreSpec(MEMORY)
    if text == OXIGRAPH:
        return StoreSpec(OXIGRAPH, text)
    if text.startswith(OXIGRAPH + ":"):
        location = Path(text[len(OXIGRAPH) + 1:]).expanduser()
        if not str(location):
            raise StoreError("oxigraph: without a directory", element=text, fix="write oxigraph:DIR")
        return StoreSpec(OXIGRAPH, text, location=location)
    if text.startswith(("sparql+http://", "sparql+https://")):
        url = text[len("sparql+"):]
        parts = urllib.parse.urlsplit(url)
        if not parts.netloc:
            raise StoreError("SPARQL endpoint URL without a host", element=text,
                             fix="write sparql+http://HOST:PORT/query")
        path = parts.path.rstrip("/")
        update = url
        if path.endswith("/query"):
            update = urllib.parse.urlunsplit(parts._replace(path=path[: -len("query")] + "update"))
        return StoreSpec(SPARQL, text, query_url=url, update_url=update)
    raise StoreError(f"unknown store {text!r}", element=text, fix=f"use one of: {STORE_FORMS}")


def add_store_argument(parser: argparse.ArgumentParser, default: str = MEMORY) -> None:
    """The ``--store`` option of the commands that load a project; ``default`` where the command is
    faster on another backend with the same output (``info`` and ``query`` use Oxigraph)."""
    parser.add_argument("--store", metavar="SPEC", default=None if default == MEMORY else default,
                        help=f"graph backend: {STORE_FORMS} (default: {default})")
