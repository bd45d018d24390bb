"""The simulation world (paper: step A6, the start of Figure 1's right system).

The 4D model at a date becomes a world: built elements static, the task's elements at their storage,
later ones absent; occupancy maps per storey, robot footprints on them, and SDF/glTF/map exports.
"""

import importlib
from typing import Any


def __getattr__(name: str) -> Any:
    """``from kbplanner.world import X`` as with 0.1's flat module: X of :mod:`.build`,
    :mod:`.world_types`, :mod:`.tables`, :mod:`.meshes`."""
    if name.startswith("__"):
        raise AttributeError(name)
    for home in ("build", "world_types", "tables", "meshes"):
        module = importlib.import_module(f"kbplanner.world.{home}")
        if hasattr(module, name):
            return getattr(module, name)
    raise AttributeError(f"module 'kbplanner.world' has no attribute {name!r}")
