"""IRIs minted for instance data (import step): one place decides how elements, storeys and tasks are named.

IRIs are minted from GlobalIds and task ids by percent-encoding; they are only ever used as RDF
terms (bound into queries with ``initBindings``), never pasted into query text.
"""

from __future__ import annotations

import re
from urllib.parse import quote

from rdflib import URIRef

DATA_ROOT = "https://w3id.org/kbplanner/data/"


def slug(name: str) -> str:
    """A lowercase, IRI-safe slug of a project name: ``slug("Duplex A") == "duplex-a"``."""
    s = re.sub(r"[^A-Za-z0-9]+", "-", name).strip("-").lower()
    return s or "project"


def base_iri(project_name: str) -> str:
    """The base IRI of a project's instance data, ending in ``/``."""
    return f"{DATA_ROOT}{slug(project_name)}/"


def mint(base: str, kind: str, key: str) -> URIRef:
    """An IRI ``{base}{kind}/{key}`` with ``key`` percent-encoded (GlobalIds contain ``$``)."""
    return URIRef(f"{base}{kind}/{quote(key, safe='')}")


def element_iri(base: str, global_id: str) -> URIRef:
    """IRI of a building element, site object or other product keyed by its GlobalId."""
    return mint(base, "element", global_id)


def task_iri(base: str, task_id: str) -> URIRef:
    """IRI of a construction task keyed by its task id."""
    return mint(base, "task", task_id)
