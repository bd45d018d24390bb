"""A1 for `kbplanner init`: the task types ``init`` can set up, by name -> the knowledge base's task kind.

Kept apart from :mod:`kbplanner.scale.project_init` so that the CLI can list them without importing
ifcopenshell, shapely or the graph libraries (start-up time).
"""

from __future__ import annotations

TASK_TYPES = {"frame-interior-walls": "InteriorWallFraming"}  # init's task types -> KB task kind
