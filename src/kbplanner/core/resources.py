"""Package data (all steps): where the ontology, SHACL shapes, named queries and simulation assets live.

Installed from a wheel they sit in ``kbplanner/_data/`` (the build maps the repository's top-level
``ontology/``, ``shapes/`` and ``sim/`` there); in a source checkout or editable install they are
read from the repository itself. Queries are ``.rq`` files inside the package. Nothing is fetched.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

_DATA_KINDS = ("ontology", "shapes", "sim")


def data_dir(kind: str) -> Path:
    """Directory of one kind of package data: ``"ontology"``, ``"shapes"`` or ``"sim"``.

    Example:
        >>> (data_dir("ontology") / "kbplanner.ttl").is_file()
        True
    """
    if kind not in _DATA_KINDS:
        raise ValueError(f"unknown data kind {kind!r}; expected one of {_DATA_KINDS}")
    packaged = Path(str(resources.files("kbplanner"))) / "_data" / kind
    if packaged.is_dir():
        return packaged
    checkout = Path(__file__).resolve().parents[3] / kind
    if checkout.is_dir():
        return checkout
    raise FileNotFoundError(
        f"kbplanner package data '{kind}' not found in {packaged} or {checkout}; reinstall kbplanner"
    )


def queries_dir() -> Path:
    """Directory of the named SPARQL queries (``*.rq``)."""
    return Path(str(resources.files("kbplanner"))) / "queries"


def ontology_files() -> list[Path]:
    """Every Turtle file of the ontology and knowledge base, in a stable order."""
    return sorted(data_dir("ontology").rglob("*.ttl"))


def shape_files() -> list[Path]:
    """Every Turtle file of the well-formedness shapes, in a stable order."""
    return sorted(data_dir("shapes").rglob("*.ttl"))
