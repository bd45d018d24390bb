"""Errors of kbplanner: the one exception hierarchy for broken input and misuse.

Expected outcomes (a model that does not conform, a robot that does not fit, an unreachable goal) are
never raised: they are reported in result objects. What is raised here is input that cannot be used.
Every message names the file (and the element or term where known) and says what to fix; the CLI
prints it without a traceback and exits with code 2.
"""

from __future__ import annotations

from pathlib import Path


class KbplannerError(Exception):
    """Base class: bad input or misuse. ``str(err)`` is the full user-facing message."""

    def __init__(
        self,
        problem: str,
        *,
        file: str | Path | None = None,
        element: str | None = None,
        fix: str | None = None,
        line: int | None = None,
    ) -> None:
        self.problem = problem
        self.file = str(file) if file is not None else None
        self.element = element
        self.fix = fix
        self.line = line
        super().__init__(self._message())

    def _message(self) -> str:
        where = ""
        if self.file is not None:
            where = self.file + (f":{self.line}" if self.line is not None else "") + ": "
        text = where + self.problem
        if self.element:
            text += f" [{self.element}]"
        if self.fix:
            text += f"\n  fix: {self.fix}"
        return text


class InputFileError(KbplannerError):
    """A file is missing, unreadable, or of the wrong kind."""


class IfcError(InputFileError):
    """An IFC file cannot be opened or has an unsupported schema."""


class RdfSyntaxError(InputFileError):
    """A Turtle (or other RDF) file does not parse."""


class RemoteImportError(InputFileError):
    """An ``owl:imports`` names a remote IRI; kbplanner never fetches from the network."""


class ScheduleError(InputFileError):
    """A schedule has bad dates, unknown elements or tasks, or an invalid row."""


class ScheduleCycleError(ScheduleError):
    """Predecessor links form a cycle; ``cycle`` lists the task ids in order."""

    def __init__(self, cycle: list[str], *, file: str | Path | None = None) -> None:
        self.cycle = cycle
        super().__init__(
            "predecessors form a cycle: " + " -> ".join([*cycle, cycle[0]]),
            file=file,
            fix="remove one of these predecessor links so that the schedule is acyclic",
        )


class ProjectError(InputFileError):
    """A project directory or its manifest (project.toml) is invalid."""


class KnowledgeBaseError(KbplannerError):
    """The knowledge base refers to a term, skill or specification that does not exist."""


class QueryError(KbplannerError):
    """A named query does not exist, or a binding is missing or malformed."""


class WorldError(KbplannerError):
    """The world cannot be built: unknown task, no task to simulate, a mesh file that is missing."""


class NumberRangeError(InputFileError):
    """A number from a user's file is not finite or outside its physical range (the numeric rule)."""


class SiteLocationError(InputFileError):
    """A declared site location (a pickup location, a storage) cannot be used: off the site, inside an
    element or a solid site object, or in a no-go zone."""
