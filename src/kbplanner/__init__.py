"""kbplanner: plan and simulate construction robot work inside a 4D BIM model.

The pipeline follows the information flow of Oyediran et al. (A1-A6, B1-B5), and the package is laid
out by the paper's three systems, each layer importing only the ones below it:

- :mod:`kbplanner.core`: errors, resources, RDF I/O, vocabulary, named queries, stores, outputs;
- :mod:`kbplanner.knowledge`: the construction robot knowledge base (A1-A5, B3);
- :mod:`kbplanner.model`: the 4D BIM environment (IFC, schedule, project files);
- :mod:`kbplanner.world`, :mod:`kbplanner.robot`, :mod:`kbplanner.planning`,
  :mod:`kbplanner.simulation`: the robot simulation environment (A6, B1-B5);
- :mod:`kbplanner.analysis`: run records, proximity, comparison, report;
- :mod:`kbplanner.scale`: generated buildings, sweeps, whole-building task runs;
- :mod:`kbplanner.project` (the :class:`Project` facade), :mod:`kbplanner.pipeline`, :mod:`kbplanner.cli`.

See ``docs/architecture.md``. ``from kbplanner import Project`` loads the facade on first use, so that
``import kbplanner`` stays cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from kbplanner.core.errors import KbplannerError

if TYPE_CHECKING:
    from kbplanner.project import Project

__version__ = "0.1.0"

__all__ = ["KbplannerError", "Project", "__version__"]


def __getattr__(name: str) -> Any:
    """``kbplanner.Project`` imported on first use (PEP 562)."""
    if name == "Project":
        from kbplanner.project import Project

        return Project
    raise AttributeError(f"module 'kbplanner' has no attribute {name!r}")
