"""RDF literal values (all steps): a node read from a graph as a Python float, or ``None``."""

from __future__ import annotations

from rdflib import Literal
from rdflib.term import Node


def literal_float(v: Node | None) -> float | None:
    """The float value of a literal node; ``None`` for no node, a non-literal or a non-numeric literal.

    Example:
        >>> literal_float(Literal(2)), literal_float(Literal("x")), literal_float(None)
        (2.0, None, None)
    """
    if isinstance(v, Literal):
        try:
            return float(v.toPython())
        except (TypeError, ValueError):
            return None
    return None
