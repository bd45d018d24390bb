"""Dates of the 4D model (4D BIM environment): the ISO dates at which a world is built."""

from __future__ import annotations

from datetime import datetime

from kbplanner.core.errors import WorldError


def parse_date(text: str) -> datetime:
    """An ISO date or date-time (local site time, no time zone) for the world.

    Raises:
        WorldError: not an ISO date, or with a time zone.
    """
    try:
        at = datetime.fromisoformat(text)
    except ValueError:
        raise WorldError(f"not an ISO date: {text!r}", element="--date",
                         fix="write it as YYYY-MM-DD or YYYY-MM-DDTHH:MM[:SS], e.g. 2022-05-10T07:00"
                         ) from None
    if at.tzinfo is not None:
        raise WorldError(f"date with a time zone: {text!r}", element="--date",
                         fix="schedule times are local site time: drop the time zone")
    return at
