"""The numeric rule (all steps): every number a user gives is finite and in its physical range.

The ranges are the SHACL shapes of ``shapes/numbers.ttl`` (one per property: speeds, sizes, masses
> 0; distances, times, indices >= 0; coordinates finite). ``kbplanner validate`` reports violations in
its SHACL report; :func:`check_numbers` applies the same ranges to a graph read from one file, where it
is read, so that every command stops with exit 2 naming the file, the subject, the property and the
value before any step uses the number.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from rdflib import Graph, Literal, Namespace, URIRef

from kbplanner.core.errors import NumberRangeError
from kbplanner.core.resources import shape_files

SH = Namespace("http://www.w3.org/ns/shacl#")
KBP_NS = "https://w3id.org/kbplanner/ontology#"


@dataclass(frozen=True)
class NumberRange:
    """The allowed values of one property: ``low`` (exclusive or inclusive) to ``high`` (inclusive)."""

    prop: URIRef
    low: float
    low_inclusive: bool
    high: float

    def allows(self, value: float) -> bool:
        if not math.isfinite(value) or value > self.high:
            return False
        return value >= self.low if self.low_inclusive else value > self.low

    def words(self) -> str:
        op = ">=" if self.low_inclusive else ">"
        return f"a finite number {op} {self.low:g} and <= {self.high:g}"


@lru_cache(maxsize=1)
def number_ranges() -> dict[URIRef, NumberRange]:
    """The ranges of the properties of ``shapes/numbers.ttl``; a lower bound given by another shape
    file for the same property (``shapes/jobsite.ttl``) counts too (the strictest bound wins)."""
    lows: dict[URIRef, tuple[float, bool]] = {}
    highs: dict[URIRef, float] = {}
    ruled: set[URIRef] = set()
    for path in shape_files():
        g = Graph()
        g.parse(path, format="turtle")
        for ps in g.subjects(SH.path, None):
            prop = g.value(ps, SH.path)
            if not isinstance(prop, URIRef):
                continue
            if path.name == "numbers.ttl":
                ruled.add(prop)
            for bound, inclusive in ((SH.minExclusive, False), (SH.minInclusive, True)):
                v = g.value(ps, bound)
                if isinstance(v, Literal):
                    new = (float(v.toPython()), inclusive)
                    old = lows.get(prop)
                    if old is None or new[0] > old[0] or (new[0] == old[0] and not inclusive):
                        lows[prop] = new
            hi = g.value(ps, SH.maxInclusive)
            if isinstance(hi, Literal):
                highs[prop] = min(highs.get(prop, math.inf), float(hi.toPython()))
    return {p: NumberRange(p, *lows.get(p, (-math.inf, True)), highs.get(p, math.inf)) for p in sorted(ruled)}


def literal_number(value: Literal) -> float | None:
    """The float of a numeric literal (``None`` for text, booleans and dates)."""
    py = value.toPython()
    if isinstance(py, bool) or (not isinstance(py, int | float) and type(py).__name__ != "Decimal"):
        return None
    try:
        return float(py)
    except (TypeError, ValueError, OverflowError):
        return None


def check_numbers(graph: Graph, file: str | Path) -> None:
    """Raise :class:`NumberRangeError` for the first number of ``graph`` (read from ``file``) that is
    not finite or outside its property's range (properties without a range: only finiteness).

    Example:
        >>> g = Graph().parse(data='<urn:a> <https://w3id.org/kbplanner/ontology#maxSpeed> -1.0 .',
        ...                   format="turtle")
        >>> check_numbers(g, "jobsite.ttl")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        kbplanner.core.errors.NumberRangeError: jobsite.ttl: kbp:maxSpeed of <urn:a> is -1.0, ...
    """
    ranges = number_ranges()
    for s, p, o in sorted(graph, key=lambda t: (str(t[0]), str(t[1]), str(t[2]))):
        if not isinstance(o, Literal):
            continue
        value = literal_number(o)
        if value is None:
            continue
        rng = ranges.get(p) if isinstance(p, URIRef) else None
        if math.isfinite(value) and (rng is None or rng.allows(value)):
            continue
        name = f"kbp:{str(p)[len(KBP_NS):]}" if str(p).startswith(KBP_NS) else f"<{p}>"
        need = rng.words() if rng is not None else "a finite number"
        raise NumberRangeError(f"{name} of <{s}> is {o}, not {need}", file=file, element=f"<{s}> {name}",
                               fix=f"give {name} {need} in {Path(file).name}")
