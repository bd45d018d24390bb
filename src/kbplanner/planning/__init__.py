"""Task planning (paper: steps B1-B4): skill inputs by SPARQL from the bindings, element order, the
action-level plan with its robot, and arm/base poses plus carry modes refined by inverse kinematics.
"""

import importlib
from typing import Any


def __getattr__(name: str) -> Any:
    """``from kbplanner.planning import X`` as with 0.1's flat module: X of :mod:`.planner`."""
    if name.startswith("__"):
        raise AttributeError(name)
    module = importlib.import_module("kbplanner.planning.planner")
    try:
        return getattr(module, name)
    except AttributeError:
        raise AttributeError(f"module 'kbplanner.planning' has no attribute {name!r}") from None
