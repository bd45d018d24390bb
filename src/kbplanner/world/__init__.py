"""The simulation world (paper: step A6, the start of Figure 1's right system).

The 4D model at a date becomes a world: built elements static, the task's elements at their storage,
later ones absent; occupancy maps per storey, robot footprints on them, and SDF/glTF/map exports.
"""

import importlib
from typing import Any


def __getattr__(name: str) -> Any:
    """``from kbplanner.world import X`` as with 0.1's flat module: X of :mod:`kbplanner.world.build`."""
    if name.startswith("__"):
        raise AttributeError(name)
    module = importlib.import_module("kbplanner.world.build")
    try:
        return getattr(module, name)
    except AttributeError:
        raise AttributeError(f"module 'kbplanner.world' has no attribute {name!r}") from None
